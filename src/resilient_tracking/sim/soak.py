"""Soak runs (issue #6, item 4): a long episode with memory measured along the way.

:func:`soak` runs one episode and, at given steps, records the process's peak resident memory
(``getrusage``) and the Python heap traced by :mod:`tracemalloc`, split into the rows the episode
recorder keeps (allocated in ``sim/episode.py``, growing by design with the number of steps) and
everything else (belief, planner caches, solver problems, world), which must stay flat. After
the run it checks every table for NaN/inf. ``tools/soak.py`` prints the report.
"""

from __future__ import annotations

import logging
import resource
import sys
import time
import tracemalloc
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from resilient_tracking.scenario import Scenario
from resilient_tracking.sim import episode as episode_module
from resilient_tracking.sim.episode import run_episode
from resilient_tracking.sim.records import EpisodeResult

log = logging.getLogger(__name__)

MB = 1024 * 1024


@dataclass(frozen=True)
class MemoryCheckpoint:
    step: int
    #: peak resident set size of the process so far (MB)
    peak_rss_mb: float
    #: resident set size now (MB; NaN where /proc is not available)
    rss_mb: float
    #: Python heap currently traced (MB), and its split
    traced_mb: float
    records_mb: float
    other_mb: float


@dataclass
class SoakReport:
    scenario: str
    policy: str
    seed: int
    steps: int
    wall_s: float
    checkpoints: list[MemoryCheckpoint] = field(default_factory=list)
    #: tables with a NaN or infinite number, and how many such cells
    non_finite: dict[str, int] = field(default_factory=dict)
    events: dict[str, int] = field(default_factory=dict)

    @property
    def finite(self) -> bool:
        return not self.non_finite

    def other_growth_mb(self) -> float:
        """Growth of the non-record heap between the first and last checkpoint."""
        if len(self.checkpoints) < 2:
            return 0.0
        return self.checkpoints[-1].other_mb - self.checkpoints[0].other_mb


def _peak_rss_mb() -> float:
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return peak / MB if sys.platform == "darwin" else peak / 1024  # bytes on macOS, else KiB


def _rss_mb() -> float:
    try:
        pages = int(Path("/proc/self/statm").read_text().split()[1])
    except (OSError, IndexError, ValueError):
        return float("nan")
    return pages * resource.getpagesize() / MB


def _heap_split() -> tuple[float, float, float]:
    recorder_file = str(Path(episode_module.__file__).resolve())
    snapshot = tracemalloc.take_snapshot()
    total = records = 0
    for stat in snapshot.statistics("filename"):
        total += stat.size
        if str(Path(stat.traceback[0].filename).resolve()) == recorder_file:
            records += stat.size
    return total / MB, records / MB, (total - records) / MB


def non_finite_cells(result: EpisodeResult) -> dict[str, int]:
    """Per table, the number of numeric cells that are NaN or infinite (absent when none)."""
    out = {}
    for name, table in result.tables.items():
        numbers = table.select_dtypes("number").to_numpy(dtype=float)
        bad = int(np.size(numbers) - np.count_nonzero(np.isfinite(numbers)))
        missing = int(table.select_dtypes(exclude="number").isna().to_numpy().sum())
        if bad + missing:
            out[name] = bad + missing
    return out


def soak(
    scenario: Scenario,
    steps: int | None = None,
    checkpoints: tuple[int, ...] = (500, 2000),
    policy: str | None = None,
    seed: int | None = None,
) -> SoakReport:
    """Run ``steps`` steps (default: the scenario's) measuring memory at ``checkpoints``."""
    if steps is not None:
        scenario = scenario.with_overrides(steps=steps)
    marks = sorted({c for c in checkpoints if 0 < c <= scenario.steps} | {scenario.steps})
    taken: list[MemoryCheckpoint] = []
    done = 0

    def progress(n: int) -> None:
        nonlocal done
        done += n
        if done in marks:
            traced, records, other = _heap_split()
            point = MemoryCheckpoint(done, _peak_rss_mb(), _rss_mb(), traced, records, other)
            log.info("soak step %d: %s", done, point)
            taken.append(point)

    was_tracing = tracemalloc.is_tracing()
    if not was_tracing:
        tracemalloc.start(1)
    started = time.perf_counter()
    try:
        result = run_episode(scenario, policy=policy, seed=seed, progress=progress)
    finally:
        if not was_tracing:
            tracemalloc.stop()
    events = result["events"]
    counts = events["event"].value_counts().to_dict() if len(events) else {}
    return SoakReport(
        scenario=scenario.name,
        policy=str(result.manifest["policy"]),
        seed=int(result.manifest["seed"]),
        steps=scenario.steps,
        wall_s=time.perf_counter() - started,
        checkpoints=taken,
        non_finite=non_finite_cells(result),
        events={str(k): int(v) for k, v in counts.items()},
    )
