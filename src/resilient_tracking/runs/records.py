"""Tables of one episode and how they are written to a run folder.

A run folder holds one parquet file per table of :data:`~resilient_tracking.runs.schema.TABLES`
(``team``, ``robots``, ``targets``, ``events``, ``zones``, ``knowledge``, ``timing``) and
``manifest.json``. The folder is written under a temporary name beside its destination and
renamed into place when every file is complete, so a run folder is either complete or absent
(never partial).
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from resilient_tracking.runs import folders
from resilient_tracking.runs.schema import ALL_TABLES, TABLES


@dataclass
class EpisodeResult:
    """All tables of an episode, plus the manifest fields."""

    tables: dict[str, pd.DataFrame]
    manifest: dict[str, Any] = field(default_factory=dict)

    def __getitem__(self, name: str) -> pd.DataFrame:
        return self.tables[name]


class ColumnTable:
    """A table that grows a block of rows at a time, stored as NumPy columns.

    The per-step tables (a row per robot and per target every step) would otherwise hold a
    Python dict and a boxed number per cell: about 1 kB per row, the bulk of a long run's
    memory. Give ``capacity`` when the final number of rows is known: the columns are then
    allocated once (the operating system maps their pages as they are written), so memory grows
    exactly with the rows. Beyond it, columns double, so appending stays amortised O(rows).
    """

    def __init__(self, dtypes: dict[str, Any], capacity: int = 16):
        size = max(int(capacity), 1)
        self._columns = {name: np.empty(size, dtype=dtype) for name, dtype in dtypes.items()}
        self._rows = 0

    def __len__(self) -> int:
        return self._rows

    def append(self, rows: int | None = None, **values: Any) -> None:
        """Append rows: every column gets an array (or a scalar, broadcast) of the same length,
        ``rows`` of them (when not given: the longest array's length, else one)."""
        if rows is None:
            lengths = [np.shape(v)[0] for v in values.values() if np.ndim(v)]
            rows = max(lengths, default=1)
        start, end = self._rows, self._rows + rows
        columns = self._columns
        if end > len(next(iter(columns.values()))):
            self._grow(end)
        for name, column in columns.items():
            column[start:end] = values[name]  # NumPy converts and broadcasts in place
        self._rows = end

    def append_row(self, **values: Any) -> None:
        """Append one row of scalars (the per-step team and timing rows)."""
        row = self._rows
        columns = self._columns
        if row == len(next(iter(columns.values()))):
            self._grow(row + 1)
        for name, column in columns.items():
            column[row] = values[name]
        self._rows = row + 1

    def last(self, name: str) -> Any:
        """The value of column ``name`` in the last row appended."""
        return self._columns[name][self._rows - 1]

    def _grow(self, rows: int) -> None:
        """Double the columns (at least to ``rows``), keeping the rows written so far."""
        for name, column in self._columns.items():
            grown = np.empty(max(rows, 2 * len(column)), dtype=column.dtype)
            grown[: self._rows] = column[: self._rows]
            self._columns[name] = grown

    def frame(self) -> pd.DataFrame:
        """The rows appended so far as a DataFrame (a copy)."""
        return pd.DataFrame({name: c[: self._rows].copy() for name, c in self._columns.items()})


def join_sides(name: str, team: pd.DataFrame, truth: pd.DataFrame) -> pd.DataFrame:
    """Table ``name`` from the part the team recorded and the part truth recorded.

    Columns come in declared order, each from the side that records it; the key columns
    (``step``, ``target``...) are in both parts and must agree row for row.
    """
    table = TABLES[name]
    for key in table.keys:
        if not np.array_equal(team[key].to_numpy(), truth[key].to_numpy()):
            raise ValueError(f"{name}: the team's and truth's rows differ in {key!r}")
    columns = {
        c.name: (team if c.side == "team" or c.name in table.keys else truth)[c.name]
        for c in table.columns
    }
    return pd.DataFrame(columns)


def append_truth_rows(team: pd.DataFrame, truth: pd.DataFrame) -> pd.DataFrame:
    """The team's rows with truth's own rows among them, ordered by step (truth's after the
    team's of the same step); the team's table itself when truth has none."""
    if truth.empty:
        return team
    if team.empty:
        return truth.reset_index(drop=True)
    both = pd.concat([team, truth], ignore_index=True)
    return both.sort_values("step", kind="stable", ignore_index=True)


def join_tables(
    team: dict[str, pd.DataFrame], truth: dict[str, pd.DataFrame]
) -> dict[str, pd.DataFrame]:
    """Every table of a run (in :data:`~resilient_tracking.runs.schema.ALL_TABLES` order) from
    the parts the team and truth recorded (:func:`join_sides` where both recorded one)."""
    tables = {}
    for name in ALL_TABLES:
        if name in team and name in truth and TABLES[name].truth_rows:
            tables[name] = append_truth_rows(team[name], truth[name])
        elif name in team and name in truth:
            tables[name] = join_sides(name, team[name], truth[name])
        else:
            tables[name] = team[name] if name in team else truth[name]
    return tables


def is_run_folder(path: Path) -> bool:
    """Whether ``path`` is an empty folder or one that :func:`write_run` wrote, holding nothing
    else (so it may be replaced whole)."""
    return path.is_dir() and not folders.foreign_entries(path)


def write_run(
    result: EpisodeResult,
    out_dir: str | Path,
    finish: Callable[[Path], object] | None = None,
    overwrite: bool = False,
) -> Path:
    """Write every table and the manifest into ``out_dir``, all or nothing.

    Everything is written into a hidden staging folder beside ``out_dir``; ``finish`` (e.g. the
    figures) is then called with the staging folder, and only when all of it succeeded is the
    staging folder renamed to ``out_dir``. The manifest records the SHA-256 of every file
    written (:func:`~resilient_tracking.runs.folders.seal`).

    An existing ``out_dir`` is replaced whole only if this tool wrote everything in it. If it
    holds anything else, :class:`FileExistsError` is raised before writing, unless
    ``overwrite``: then the run's files are moved in beside the others, which are kept. The
    folder is locked while written (:class:`~resilient_tracking.runs.folders.FolderBusyError`
    if another process holds it), and staging folders of killed writes are removed first.
    """
    out = Path(out_dir)
    with folders.folder_lock(out):
        folders.clean_stale(out)
        foreign = folders.check_out_folder(out, overwrite)
        staging = Path(tempfile.mkdtemp(dir=out.parent, prefix=f".{out.name}.", suffix=".partial"))
        try:
            for name in ALL_TABLES:
                result.tables[name].to_parquet(staging / f"{name}.parquet", index=False)
            _write_manifest(staging, result.manifest)
            if finish is not None:
                finish(staging)
            _write_manifest(staging, folders.seal(result.manifest, staging))
            os.chmod(staging, 0o755)  # mkdtemp creates 0700; run folders are meant to be shared
            if foreign:
                folders.merge_into(staging, out)
            elif out.exists():
                old = Path(tempfile.mkdtemp(dir=out.parent, prefix=f".{out.name}.", suffix=".old"))
                os.replace(out, old / out.name)
                os.replace(staging, out)
                shutil.rmtree(old, ignore_errors=True)
            else:
                os.replace(staging, out)
        except BaseException:
            shutil.rmtree(staging, ignore_errors=True)
            raise
    return out


def _write_manifest(folder: Path, manifest: dict[str, Any]) -> None:
    text = json.dumps(manifest, indent=2, sort_keys=True, default=str)
    (folder / "manifest.json").write_text(text + "\n")
