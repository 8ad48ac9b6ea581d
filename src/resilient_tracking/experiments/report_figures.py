"""The figures of a report (``report.md``): which to draw for an experiment, drawn only when
their inputs changed, and drawn in worker processes; and the experiment's summary kept for
the next report while its runs do not change.

An experiment's figures and summary depend on its stored runs and on this package's code. A
stamp ``figures/inputs.sha256`` beside the figures holds a hash of both (every finished run's
id and ``manifest.json``, which carries the checksum of each of its tables, plus
:data:`FIGURES_REVISION` and the package version); when it matches and every figure exists,
nothing is redrawn. Otherwise the experiment's figures are drawn again, spread over ``jobs``
processes (joblib, the sweep's worker pool when it is still up), and the stamp is written
last, so an interrupted drawing is redone next time. The summary table and the figures'
captions are kept under the same hash in ``.summary.parquet`` and ``.summary.json`` (hidden:
``summary.csv`` is the table meant for people), so a report of unchanged runs reads no run.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import logging
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd

from resilient_tracking import interrupts
from resilient_tracking.experiments.catalog import (
    ADVERSARIAL,
    BEYOND,
    RISK_LEVELS,
    Experiment,
    Task,
)
from resilient_tracking.experiments.sweep import run_dir
from resilient_tracking.runs.folders import write_text_atomic
from resilient_tracking.runs.reading import RunData
from resilient_tracking.version import __version__
from resilient_tracking.viz.sweeps import (
    BAND_METRICS,
    EFFORT_METRIC,
    plot_bands,
    plot_scale_boxes,
    plot_snapshots,
)

log = logging.getLogger(__name__)

#: Part of every figure stamp: raise it when the figures' look or the summary's columns change,
#: so stored reports draw and summarise theirs again.
FIGURES_REVISION = 3
#: The stamp file inside an experiment's figures folder.
STAMP = "inputs.sha256"


@dataclass(frozen=True)
class FigureJob:
    """One figure: its caption in the report, its file, and how to draw it."""

    caption: str
    path: Path
    draw: Callable[..., Path]
    args: tuple[Any, ...]
    kwargs: tuple[tuple[str, Any], ...] = ()

    def __call__(self) -> Path:
        return self.draw(*self.args, self.path, **dict(self.kwargs))


def _scenario_of(label: str) -> str:
    """The scenario of a three-team arm's label, ``<scenario>-<team>``."""
    return label.rsplit("-", 1)[0]


def figure_jobs(
    exp: Experiment, runs: dict[str, list[RunData]], summary: pd.DataFrame, out: Path
) -> list[FigureJob]:
    """The figures of an experiment (files in ``out``), not drawn yet."""
    jobs: list[FigureJob] = []
    first = {label: rs[0] for label, rs in runs.items() if rs}
    if exp.kind == "scale":
        jobs.append(
            FigureJob("time-averaged trace", out / "boxes-trace.png", plot_scale_boxes, (summary,))
        )
        jobs.append(
            FigureJob(
                "time-averaged MSE",
                out / "boxes-mse.png",
                plot_scale_boxes,
                (summary,),
                (("metric", "mse"),),
            )
        )
        largest = max(first, key=lambda k: (first[k].robots.robot.nunique(), k))
        jobs.append(
            FigureJob(
                f"snapshots, {largest}", out / "snapshots.png", plot_snapshots, (first[largest],)
            )
        )
        return jobs
    shipped = {"beyond": BEYOND, "adversarial": ADVERSARIAL}.get(exp.kind)
    if shipped is not None:  # the shipped scenarios' runs only; the suite's are many
        first = {k: v for k, v in first.items() if _scenario_of(k) in shipped}
        runs = {k: v for k, v in runs.items() if _scenario_of(k) in shipped}
    for label, run in first.items():
        jobs.append(
            FigureJob(
                f"snapshots, {label}, seed {run.seed}",
                out / f"snapshots-{label}.png",
                plot_snapshots,
                (run,),
            )
        )
    metrics = (*BAND_METRICS, *EFFORT_METRIC)
    if exp.kind == "pair":
        jobs.append(
            FigureJob(
                "MSE, trace and effort, mean ± 1 std over seeds",
                out / "bands.png",
                plot_bands,
                (runs,),
                (("metrics", metrics), ("title", exp.name)),
            )
        )
    elif exp.kind in ("adversarial", "beyond"):  # per scenario, its teams
        for name in dict.fromkeys(_scenario_of(label) for label in runs):
            groups = {k: v for k, v in runs.items() if _scenario_of(k) == name}
            jobs.append(
                FigureJob(
                    f"{name}: the teams vanilla, default and {exp.kind}"
                    + (" (and guarded)" if f"{name}-guarded" in groups else "")
                    + ", mean ± 1 std over seeds",
                    out / f"bands-{name}.png",
                    plot_bands,
                    (groups,),
                    (("metrics", metrics), ("title", name)),
                )
            )
    else:
        for level in RISK_LEVELS:
            groups = {k: v for k, v in runs.items() if k.endswith(f"-{level}")}
            jobs.append(
                FigureJob(
                    f"{level}: ours vs SOG, mean ± 1 std over seeds",
                    out / f"bands-{level}.png",
                    plot_bands,
                    (groups,),
                    (("metrics", metrics), ("title", f"{exp.name}, {level}")),
                )
            )
    return jobs


def inputs_digest(out: Path, done: Sequence[Task]) -> str:
    """The hash of what an experiment's figures are drawn from (see the module docstring)."""
    h = hashlib.sha256(f"figures {FIGURES_REVISION} {__version__}\n".encode())
    for task in sorted(done, key=lambda t: t.run_id):
        h.update(task.run_id.encode() + b"\n")
        h.update((run_dir(out, task) / "manifest.json").read_bytes())
    return h.hexdigest()


def up_to_date(folder: Path, digest: str, figures: Sequence[tuple[str, Path]]) -> bool:
    """Whether ``folder``'s figures, ``(caption, path)``, were drawn from inputs with this
    ``digest`` and all exist (no figures: always)."""
    if not figures:
        return True
    stamp = folder / STAMP
    try:
        same = stamp.read_text().strip() == digest
    except OSError:
        return False
    return same and all(path.exists() for _, path in figures)


def _draw_all(jobs: Sequence[FigureJob]) -> list[Path]:
    return [job() for job in jobs]


def draw(pending: Sequence[tuple[Path, str, Sequence[FigureJob]]], jobs: int = 1) -> int:
    """Draw every figure of ``pending`` (figures folder, its digest, its figures) over ``jobs``
    processes, then stamp each folder; returns how many figures were drawn."""
    work = [job for _, _, figs in pending for job in figs]
    if not work:
        return 0
    if jobs > 1 and len(work) > 1:
        from joblib import Parallel, delayed

        # one batch per worker and folder keeps the pickled runs to a few transfers
        batches = [list(figs) for _, _, figs in pending if figs]
        Parallel(n_jobs=min(jobs, len(batches)))(delayed(_draw_all)(b) for b in batches)
    else:
        _draw_all(work)
    for folder, digest, _ in pending:
        write_text_atomic(folder / STAMP, digest + "\n")
    log.info("drew %d report figures", len(work))
    return len(work)


@dataclass(frozen=True)
class KeptSummary:
    """An experiment's summary and figure list from an earlier report of the same runs."""

    summary: pd.DataFrame
    #: (caption, path) of every figure
    figures: list[tuple[str, Path]]


def read_kept(folder: Path, digest: str) -> KeptSummary | None:
    """The summary kept in ``folder`` for runs with this ``digest``, if any and readable."""
    try:
        meta = json.loads((folder / ".summary.json").read_text())
        if meta.get("digest") != digest:
            return None
        summary = pd.read_parquet(folder / ".summary.parquet")
        figures = [(str(c), folder / str(p)) for c, p in meta["figures"]]
    except (OSError, ValueError, KeyError, TypeError) as err:
        log.debug("no kept summary in %s (%s)", folder, err)
        return None
    return KeptSummary(summary, figures)


def keep(folder: Path, digest: str, summary: pd.DataFrame, jobs: Sequence[FigureJob]) -> None:
    """Keep ``summary`` and the figure list for the next report (best effort: a summary that
    cannot be stored is simply computed again next time)."""
    figures = [[job.caption, job.path.relative_to(folder).as_posix()] for job in jobs]
    try:
        summary.to_parquet(folder / ".summary.parquet", index=False)
    except Exception as err:  # e.g. a column of mixed types: nothing to keep
        interrupts.check()
        log.debug("summary of %s not kept: %s", folder, err)
        with contextlib.suppress(OSError):
            (folder / ".summary.json").unlink()
        return
    meta = {"digest": digest, "figures": figures}
    write_text_atomic(folder / ".summary.json", json.dumps(meta, indent=1) + "\n")
