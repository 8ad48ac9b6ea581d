"""Reading a saved run folder: the single place where figures and summaries read parquet.

:func:`load_run` reads a run folder's tables (:data:`~resilient_tracking.runs.schema.TABLES`,
all but ``timing``) and ``manifest.json`` into a :class:`RunData`, checking every table against
the declaration, so that a malformed or old folder fails with an error naming the table and the
missing columns instead of a ``KeyError`` deep in a plot.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from resilient_tracking import interrupts
from resilient_tracking.runs.folders import read_manifest
from resilient_tracking.runs.records import EpisodeResult
from resilient_tracking.runs.schema import REPRODUCIBLE, TABLES
from resilient_tracking.scenario.errors import short_repr

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class RunData:
    """Everything a figure may use from one run folder."""

    run_dir: Path
    team: pd.DataFrame
    robots: pd.DataFrame
    targets: pd.DataFrame
    events: pd.DataFrame
    zones: pd.DataFrame
    knowledge: pd.DataFrame
    #: where each moving zone was at each step (empty when no zone moves)
    zone_tracks: pd.DataFrame = field(default_factory=pd.DataFrame)
    #: the posterior Cramér–Rao bound per step (empty unless the run computed it)
    bound: pd.DataFrame = field(default_factory=pd.DataFrame)
    manifest: dict[str, Any] = field(default_factory=dict)

    @property
    def scenario(self) -> dict[str, Any]:
        """The scenario as the manifest stores it (a mapping; empty when absent)."""
        scenario = self.manifest.get("scenario", {})
        return scenario if isinstance(scenario, dict) else {}

    @property
    def scenario_name(self) -> str:
        """The scenario's name, else the run folder's name."""
        return str(self.scenario.get("name", self.run_dir.name))

    @property
    def policy(self) -> str:
        """The policy's name from the manifest (``?`` when absent)."""
        return str(self.manifest.get("policy", "?"))

    @property
    def seed(self) -> int | None:
        """The episode's seed from the manifest; None when absent."""
        seed = self.manifest.get("seed")
        return int(seed) if seed is not None else None

    @property
    def dt(self) -> float:
        """Time step (s) from the manifest, else inferred from the team table, else 0.1."""
        dt = self.scenario.get("dt")
        if dt is not None:
            return float(dt)
        if len(self.team) >= 2:
            steps = self.team["step"].to_numpy(dtype=float)
            times = self.team["time"].to_numpy(dtype=float)
            span = steps[-1] - steps[0]
            if span > 0:
                return float((times[-1] - times[0]) / span)
        return 0.1

    @property
    def workspace(self) -> tuple[float, float, float, float] | None:
        """``(xmin, xmax, ymin, ymax)`` from the manifest, or ``None`` when not recorded."""
        ws = self.scenario.get("workspace")
        if not isinstance(ws, dict):
            return None
        try:
            return (float(ws["xmin"]), float(ws["xmax"]), float(ws["ymin"]), float(ws["ymax"]))
        except (KeyError, TypeError, ValueError):
            logger.warning("manifest workspace %r is malformed; ignoring it", ws)
            return None

    @property
    def last_step(self) -> int:
        """The last step in the team, robot and target tables (0 when all are empty)."""
        frames = [df["step"] for df in (self.team, self.robots, self.targets) if len(df)]
        return int(max(int(s.max()) for s in frames)) if frames else 0

    def title(self) -> str:
        """``"<scenario> · <policy> · seed <n>"``."""
        seed = "?" if self.seed is None else str(self.seed)
        return f"{self.scenario_name} · {self.policy} · seed {seed}"

    def times_of(self, steps: Any) -> np.ndarray:
        """Times (s) of ``steps``: from the team table where recorded, else ``step · dt``."""
        steps_arr = np.asarray(steps, dtype=float)
        fallback = steps_arr * self.dt
        if self.team.empty:
            return fallback
        lookup = pd.Series(
            self.team["time"].to_numpy(dtype=float),
            index=self.team["step"].to_numpy(dtype=float),
        )
        lookup = lookup[~lookup.index.duplicated(keep="last")]
        found = lookup.reindex(steps_arr.ravel()).to_numpy(dtype=float).reshape(steps_arr.shape)
        return np.where(np.isnan(found), fallback, found)


def _read_table(run_dir: Path, name: str) -> pd.DataFrame:
    table = TABLES[name]
    path = run_dir / table.file
    required = table.names
    if not path.exists():
        if table.optional:
            logger.info("%s not found in %s; using an empty table", path.name, run_dir)
            return table.empty_frame()
        raise FileNotFoundError(f"run folder {run_dir} has no {path.name}")
    try:
        df = pd.read_parquet(path)
    except Exception as err:  # a damaged file: whatever the reader raises, name the file
        interrupts.check()
        raise ValueError(f"{path}: not a readable table ({type(err).__name__}: {err})") from None
    missing = [c for c in required if c not in df.columns]
    if missing:
        if df.empty:
            # An empty table written without a schema: give it the expected columns.
            for c in missing:
                df[c] = pd.Series(dtype=object)
        else:
            raise ValueError(
                f"{path}: missing columns {missing} (has {list(df.columns)}): "
                "not a run folder of this version; run it again"
            )
    if "step" in df.columns and not df.empty:
        df = df.sort_values("step", kind="stable").reset_index(drop=True)
    return df


def manifest_problem(manifest: dict[str, Any]) -> str | None:
    """Why the manifest fields that :class:`RunData` reads (``seed``, ``policy``, and the
    scenario's ``name`` and ``dt``) cannot be used, naming the field, or None when they can
    (each may be absent)."""
    seed = manifest.get("seed")
    if seed is not None and (type(seed) is not int or seed < 0):
        return f"seed: expected a non-negative integer, got {short_repr(seed, 40)}"
    policy = manifest.get("policy")
    if policy is not None and not isinstance(policy, str):
        return f"policy: expected a name, got {short_repr(policy, 40)}"
    scenario = manifest.get("scenario", {})
    if not isinstance(scenario, dict):
        return f"scenario: expected a mapping, got {short_repr(scenario, 40)}"
    name = scenario.get("name")
    if name is not None and not isinstance(name, str):
        return f"scenario.name: expected a name, got {short_repr(name, 40)}"
    dt = scenario.get("dt")
    if dt is not None and (type(dt) not in (int, float) or not 0 < dt < math.inf):
        return f"scenario.dt: expected a positive number of seconds, got {short_repr(dt, 40)}"
    return None


def load_run(run_dir: str | Path) -> RunData:
    """Read a run folder's tables and manifest.

    Raises ``FileNotFoundError`` when the folder, ``manifest.json`` or a required table is
    missing, and ``ValueError`` naming the file when the manifest is broken or a field it reads
    has the wrong type (:func:`manifest_problem`) or a non-empty table lacks a declared column
    (a folder of an older version). ``events`` and ``knowledge`` may be absent or empty.
    """
    run_dir = Path(run_dir)
    if not run_dir.is_dir():
        raise FileNotFoundError(f"run folder {run_dir} does not exist")
    manifest_path = run_dir / "manifest.json"
    if not manifest_path.exists():
        raise FileNotFoundError(f"run folder {run_dir} has no manifest.json")
    manifest = read_manifest(run_dir)  # a ValueError naming the file if it is broken
    why = manifest_problem(manifest)
    if why is not None:
        raise ValueError(f"{manifest_path}: {why}")
    tables = {name: _read_table(run_dir, name) for name in REPRODUCIBLE}
    logger.debug(
        "loaded run %s: %s",
        run_dir,
        ", ".join(f"{k}={len(v)} rows" for k, v in tables.items()),
    )
    return RunData(run_dir=run_dir, manifest=manifest, **tables)


def run_data(result: EpisodeResult, name: str = "in-memory") -> RunData:
    """The :class:`RunData` of an episode that was not written to disk (``run_dir`` is ``name``)."""
    tables = {table: result.tables[table] for table in REPRODUCIBLE}
    return RunData(run_dir=Path(name), manifest=dict(result.manifest), **tables)


def attack_table(run: RunData, until_step: int | None = None) -> pd.DataFrame:
    """Attack events with their kind and the attacked robot's position at that step.

    Columns ``step, robot, kind, x, y`` (``x, y`` are NaN when the robot's row is missing,
    e.g. for team-level rows with ``robot == -1``), restricted to ``step <= until_step``.
    """
    ev = run.events
    ev = ev[ev["event"] == "attack"]
    if until_step is not None:
        ev = ev[ev["step"] <= until_step]
    out = pd.DataFrame(
        {
            "step": ev["step"].to_numpy(dtype=np.int64),
            "robot": ev["robot"].to_numpy(dtype=np.int64),
            "kind": ev["kind"].astype(str).to_numpy(),
        }
    )
    if out.empty or run.robots.empty:
        out["x"] = np.nan
        out["y"] = np.nan
        return out
    pos = run.robots[["step", "robot", "x", "y"]].astype({"step": np.int64, "robot": np.int64})
    pos = pos.drop_duplicates(["step", "robot"], keep="last")
    out = out.merge(pos, on=["step", "robot"], how="left")
    n_missing = int(out["x"].isna().sum())
    if n_missing:
        logger.debug("%d attack event(s) have no robot position; not drawn on maps", n_missing)
    return out
