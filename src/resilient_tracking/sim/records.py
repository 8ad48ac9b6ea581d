"""Tables of one episode and how they are written to a run folder.

A run folder holds ``team.parquet`` (a row per step), ``robots.parquet`` (a row per robot per
step), ``targets.parquet``, ``events.parquet``, ``zones.parquet`` (truth, for plots only),
``knowledge.parquet`` (zone estimates as robots learn them), ``timing.parquet`` (planning wall
time per step, the one table that is not reproducible bit for bit) and ``manifest.json``.
Files are written to a temporary name and renamed, so a file is either complete or absent.
"""

from __future__ import annotations

import json
import os
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pandas as pd

#: Tables that are identical, bit for bit, for the same scenario and seed.
TABLES = ("team", "robots", "targets", "events", "zones", "knowledge")
#: Wall-clock measurements: the one table that differs between identical runs.
TIMING = "timing"

COLUMNS: dict[str, list[str]] = {
    "events": ["step", "robot", "event", "detail"],
    "knowledge": [
        "step",
        "robot",
        "zone",
        "kind",
        "source",
        "x",
        "y",
        "sigma_xx",
        "sigma_xy",
        "sigma_yy",
        "size",
    ],
}


@dataclass
class EpisodeResult:
    """All tables of an episode, plus the manifest fields."""

    tables: dict[str, pd.DataFrame]
    manifest: dict[str, Any] = field(default_factory=dict)

    def __getitem__(self, name: str) -> pd.DataFrame:
        return self.tables[name]


def frame(rows: list[dict[str, Any]], name: str) -> pd.DataFrame:
    """A table from row dicts; empty tables keep their declared columns."""
    if not rows:
        return pd.DataFrame({c: pd.Series(dtype="object") for c in COLUMNS.get(name, [])})
    return pd.DataFrame(rows)


def _atomic_write(path: Path, write: Any) -> None:
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    os.close(fd)
    try:
        write(tmp)
        os.chmod(tmp, 0o644)  # mkstemp creates 0600; run folders are meant to be shared
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def write_run(result: EpisodeResult, out_dir: str | Path) -> Path:
    """Write every table and the manifest into ``out_dir`` (created if needed)."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    for name in (*TABLES, TIMING):
        table = result.tables[name]
        _atomic_write(out / f"{name}.parquet", lambda p, t=table: t.to_parquet(p, index=False))
    text = json.dumps(result.manifest, indent=2, sort_keys=True, default=str)
    _atomic_write(out / "manifest.json", lambda p: Path(p).write_text(text + "\n"))
    return out
