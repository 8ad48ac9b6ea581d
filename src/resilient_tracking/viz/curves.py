"""Per-run metric curves: MSE, covariance trace, control effort and failed robots vs. time.

Drawn from the saved ``team`` and ``events`` tables of a
:class:`~resilient_tracking.runs.reading.RunData`.
"""

from __future__ import annotations

import logging
from collections.abc import Iterable
from pathlib import Path

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch
from matplotlib.ticker import MaxNLocator

from resilient_tracking.runs.reading import RunData, attack_table
from resilient_tracking.viz.trajectories import COMM_COLOR, DPI, SENSING_COLOR

logger = logging.getLogger(__name__)

#: A y axis goes logarithmic when its positive values span more than this ratio (2 decades).
LOG_RATIO = 100.0


def wants_log_scale(values: Iterable[float], ratio: float = LOG_RATIO) -> bool:
    """True when the finite positive ``values`` span more than ``ratio`` (max / min)."""
    arr = np.asarray(list(values), dtype=float)
    arr = arr[np.isfinite(arr) & (arr > 0)]
    if arr.size < 2:
        return False
    return bool(arr.max() / arr.min() > ratio)


def _true_spans(time: np.ndarray, mask: np.ndarray) -> list[tuple[float, float]]:
    """``(start, end)`` times of the runs of ``mask``; a run lasts until the next sample."""
    spans: list[tuple[float, float]] = []
    if time.size == 0:
        return spans
    step = float(np.median(np.diff(time))) if time.size > 1 else 0.0
    padded = np.concatenate([[False], mask.astype(bool), [False]])
    edges = np.flatnonzero(np.diff(padded.astype(np.int8)))
    for a, b in zip(edges[::2], edges[1::2], strict=True):
        end = float(time[b]) if b < time.size else float(time[-1]) + step
        spans.append((float(time[a]), end))
    return spans


def _shade_failures(ax: Axes, time: np.ndarray, sensing: np.ndarray, comm: np.ndarray) -> None:
    """Light bands over the times when at least one robot has a failure of that kind."""
    for mask, color in ((sensing > 0, SENSING_COLOR), (comm > 0, COMM_COLOR)):
        for start, end in _true_spans(time, mask):
            ax.axvspan(start, end, color=color, alpha=0.08, lw=0, zorder=0)


def _mark_attacks(ax: Axes, attack_times: dict[str, np.ndarray]) -> None:
    for kind, color in (("sensing", SENSING_COLOR), ("comm", COMM_COLOR)):
        for t in attack_times.get(kind, np.empty(0)):
            ax.axvline(float(t), color=color, lw=0.9, alpha=0.7, zorder=1)


def plot_metric_curves(run: RunData, path: Path) -> Path:
    """Save a four-panel figure of the run's team metrics against time to ``path``.

    Panels: MSE [m²], Σ trace P [m²], control effort Σ‖u‖ [m/s] and number of robots with a
    sensing / comm failure. MSE and trace use a log y axis when their positive values span more
    than two decades (:func:`wants_log_scale`). Attacks are vertical lines (red sensing, cyan
    comm) on every panel; light red / cyan bands mark times when some robot is failed.
    Returns ``path``.
    """
    team = run.team.sort_values("step", kind="stable")
    time = team["time"].to_numpy(dtype=float)
    sensing = team["n_sensing_failed"].to_numpy(dtype=float)
    comm = team["n_comm_failed"].to_numpy(dtype=float)

    attacks = attack_table(run)
    attack_times = {
        kind: run.times_of(attacks.loc[attacks["kind"] == kind, "step"].to_numpy())
        for kind in ("sensing", "comm")
    }

    fig = Figure(figsize=(8.5, 9.0), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(4, 1, sharex=True, height_ratios=[3, 3, 2, 1.5])
    ax_mse, ax_trace, ax_effort, ax_fail = axes

    series = (
        (ax_mse, "mse", "MSE [m²]", "tab:blue"),
        (ax_trace, "trace", "Σ tr P [m²]", "tab:purple"),
        (ax_effort, "effort", "effort Σ‖u‖ [m/s]", "tab:green"),
    )
    for ax, col, label, color in series:
        values = team[col].to_numpy(dtype=float)
        ax.plot(time, values, color=color, lw=1.4, zorder=3)
        ax.set_ylabel(label)
        if col in ("mse", "trace") and wants_log_scale(values):
            ax.set_yscale("log")
        _shade_failures(ax, time, sensing, comm)
        _mark_attacks(ax, attack_times)
        ax.grid(True, lw=0.4, alpha=0.4)

    ax_fail.step(time, sensing, where="post", color=SENSING_COLOR, lw=1.4, label="sensing")
    ax_fail.step(time, comm, where="post", color=COMM_COLOR, lw=1.4, label="comm")
    _mark_attacks(ax_fail, attack_times)
    ax_fail.set_ylabel("# failed")
    ax_fail.yaxis.set_major_locator(MaxNLocator(integer=True))
    ax_fail.set_ylim(bottom=-0.1)
    ax_fail.set_xlabel("time [s]")
    ax_fail.grid(True, lw=0.4, alpha=0.4)
    if time.size:
        ax_fail.set_xlim(float(np.nanmin(time)), float(np.nanmax(time)))

    handles = [
        Line2D([], [], color=SENSING_COLOR, lw=1.4, label="sensing attack / # failed"),
        Line2D([], [], color=COMM_COLOR, lw=1.4, label="comm attack / # failed"),
        Patch(facecolor=SENSING_COLOR, alpha=0.2, label="some robot sensing-failed"),
        Patch(facecolor=COMM_COLOR, alpha=0.2, label="some robot comm-failed"),
    ]
    fig.legend(handles=handles, loc="outside lower center", fontsize="small", ncols=2)
    fig.suptitle(run.title(), fontsize="medium")

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=DPI)
    logger.info("wrote %s", path)
    return path
