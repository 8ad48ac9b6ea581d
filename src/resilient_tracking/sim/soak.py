"""Soak runs (docs/reliability.md): a long episode with its memory sampled along the way.

:func:`soak` runs one episode and every ``sample_every`` steps reads the process's resident set
size (``/proc/self/statm``) and peak (``getrusage``), and the process-wide cache of league
problems (:func:`~resilient_tracking.planning.nlp_cache.nlp_cache`). Memory may grow in
two ways only: the recorded tables (a fixed number of bytes per step, by design), and a new
problem or solver being built (a zone learned, a league split, a first fallback to IPOPT),
which the cache's budget bounds. :meth:`SoakReport.leak_mb` sums whatever else the resident
memory gained over the stretches in which nothing was built; it must stay near zero. After the
run every table is checked for NaN/inf.
``tools/soak.py`` prints the report.
"""

from __future__ import annotations

import logging
import resource
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from resilient_tracking.planning.nlp_cache import nlp_cache, solver_builds
from resilient_tracking.runs.records import EpisodeResult
from resilient_tracking.scenario import Scenario
from resilient_tracking.sim.episode import run_episode

log = logging.getLogger(__name__)

MB = 1024 * 1024


@dataclass(frozen=True)
class MemorySample:
    step: int
    #: resident set size now, and the process's peak so far (MB)
    rss_mb: float
    peak_rss_mb: float
    #: league problems in the process-wide cache, their weight (instructions), and how many
    #: problems and solvers were built so far
    cached: int
    cache_weight: float
    builds: int


@dataclass
class SoakReport:
    """A long run's memory samples, timing and table health (tools/soak.py,
    docs/reliability.md §4)."""

    scenario: str
    policy: str
    seed: int
    steps: int
    wall_s: float
    samples: list[MemorySample] = field(default_factory=list)
    #: the steps whose samples are printed
    checkpoints: tuple[int, ...] = ()
    cache_budget: float = 0.0
    #: bytes the recorded tables hold per step (their final size over the number of steps)
    record_bytes_per_step: float = 0.0
    #: tables with a NaN or infinite number, and how many such cells
    non_finite: dict[str, int] = field(default_factory=dict)
    events: dict[str, int] = field(default_factory=dict)

    @property
    def finite(self) -> bool:
        """Whether no recorded table holds a NaN or infinite number."""
        return not self.non_finite

    def at_checkpoints(self) -> list[MemorySample]:
        """The memory samples taken at the :attr:`checkpoints` steps."""
        return [s for s in self.samples if s.step in self.checkpoints]

    def records_mb(self, steps: int) -> float:
        """Memory of the tables recorded over ``steps`` steps."""
        return steps * self.record_bytes_per_step / MB

    def leak_mb(self) -> float:
        """Resident memory gained beyond the recorded tables between samples with nothing built."""
        pairs = zip(self.samples, self.samples[1:], strict=False)
        return sum(
            b.rss_mb - a.rss_mb - self.records_mb(b.step - a.step)
            for a, b in pairs
            if b.builds == a.builds
        )

    def growth_mb(self) -> float:
        """Resident memory gained from the first to the last checkpoint."""
        marks = self.at_checkpoints()
        return marks[-1].rss_mb - marks[0].rss_mb if len(marks) > 1 else 0.0


def _peak_rss_mb() -> float:
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return peak / MB if sys.platform == "darwin" else peak / 1024  # bytes on macOS, else KiB


def _rss_mb() -> float:
    try:
        pages = int(Path("/proc/self/statm").read_text().split()[1])
    except (OSError, IndexError, ValueError):
        return float("nan")
    return pages * resource.getpagesize() / MB


def record_bytes(result: EpisodeResult) -> int:
    """Bytes of the recorded tables as the recorder holds them (8 per text cell: a pointer)."""
    total = 0
    for table in result.tables.values():
        for dtype in table.dtypes:
            total += len(table) * (dtype.itemsize if dtype.kind in "biuf" else 8)
    return total


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
    sample_every: int = 50,
) -> SoakReport:
    """Run ``steps`` steps (default: the scenario's), sampling memory every ``sample_every``
    steps and at ``checkpoints``."""
    if steps is not None:
        scenario = scenario.with_overrides(steps=steps)
    marks = tuple(sorted({c for c in checkpoints if 0 < c <= scenario.steps} | {scenario.steps}))
    cache = nlp_cache()
    samples: list[MemorySample] = []
    done = 0

    def sample() -> None:
        built = cache.builds + solver_builds()
        point = MemorySample(done, _rss_mb(), _peak_rss_mb(), len(cache), cache.total, built)
        log.debug("soak step %d: %s", done, point)
        samples.append(point)

    def progress(n: int) -> None:
        nonlocal done
        done += n
        if done % sample_every == 0 or done in marks:
            sample()

    started = time.perf_counter()
    sample()
    result = run_episode(scenario, policy=policy, seed=seed, progress=progress)
    events = result["events"]
    counts = events["event"].value_counts().to_dict() if len(events) else {}
    return SoakReport(
        scenario=scenario.name,
        policy=str(result.manifest["policy"]),
        seed=int(result.manifest["seed"]),
        steps=scenario.steps,
        wall_s=time.perf_counter() - started,
        samples=samples,
        checkpoints=marks,
        cache_budget=cache.budget,
        record_bytes_per_step=record_bytes(result) / max(scenario.steps, 1),
        non_finite=non_finite_cells(result),
        events={str(k): int(v) for k, v in counts.items()},
    )
