"""Figures over many saved runs (docs/model.md §8): snapshots, mean ± 1 std bands, box plots.

Inputs are :class:`~resilient_tracking.runs.reading.RunData` read from run folders and the summary
table built from them, never objects of a live simulation.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from resilient_tracking.runs.reading import RunData
from resilient_tracking.viz.curves import wants_log_scale
from resilient_tracking.viz.trajectories import plot_trajectory_map

log = logging.getLogger(__name__)

#: Curves of the band figures: team-table column, axis label.
BAND_METRICS = (("mse", "MSE [m²]"), ("nll", "NLL [nats]"), ("trace", "Σ tr P [m²]"))
EFFORT_METRIC = (("effort", "effort Σ‖u‖ [m/s]"),)
#: Resolution of sweep figures: reports hold dozens of them, so lighter than a run's figures.
SWEEP_DPI = 100
#: Box colours of the policies, in the order given.
POLICY_COLORS = ("tab:blue", "tab:orange", "tab:green", "tab:purple")


def _save(fig: Figure, path: Path, tight: bool = True) -> Path:
    """Write ``fig``; ``tight=False`` for figures laid out with fixed margins (no second
    drawing pass to measure a tight bounding box)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=SWEEP_DPI, bbox_inches="tight" if tight else None)
    log.info("wrote %s", path)
    return path


def snapshot_steps(last_step: int, n: int = 6) -> list[int]:
    """``n`` evenly spread steps from the first sixth of the run to its end."""
    return [int(round(s)) for s in np.linspace(last_step / n, last_step, n)]


def plot_snapshots(run: RunData, path: Path, n: int = 6) -> Path:
    """The trajectory map at ``n`` times in one figure (the paper's snapshot panels)."""
    steps = snapshot_steps(run.last_step, n)
    cols = 3
    rows = (len(steps) + cols - 1) // cols
    height = 3.9 * rows + 0.8
    # fixed margins, not constrained layout: laying out 6 maps' ticks and labels cost
    # seconds per figure, most of a stored report's re-run (docs/performance.md)
    fig = Figure(figsize=(5.2 * cols, height))
    fig.subplots_adjust(
        left=0.05, right=0.99, top=1 - 0.55 / height, bottom=1.05 / height, wspace=0.18, hspace=0.3
    )
    FigureCanvasAgg(fig)
    axes = np.atleast_1d(fig.subplots(rows, cols)).ravel()
    for ax, step in zip(axes, steps, strict=False):
        t = float(run.times_of([step])[0])
        plot_trajectory_map(run, None, until_step=step, ax=ax, legend=False, title=f"t = {t:.1f} s")
    for ax in axes[len(steps) :]:
        ax.set_visible(False)
    handles, labels = axes[0].get_legend_handles_labels()
    unique = dict(zip(labels, handles, strict=False))
    fig.legend(unique.values(), unique.keys(), loc="lower center", ncols=5, fontsize="small")
    fig.suptitle(run.title(), fontsize="medium")
    return _save(fig, path, tight=False)


def _stack(runs: Sequence[RunData], column: str) -> tuple[np.ndarray, np.ndarray]:
    """Time axis and a (seeds, steps) array of ``column`` (runs cut to the shortest)."""
    n = min(len(r.team) for r in runs)
    time = runs[0].team["time"].to_numpy(dtype=float)[:n]
    values = np.stack([r.team[column].to_numpy(dtype=float)[:n] for r in runs])
    return time, values


def band(values: np.ndarray, positive: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mean over seeds (rows) and the band mean ± 1 std; for a ``positive`` metric (a trace,
    an MSE, drawn on a log axis when it spans decades) the band's lower edge stops at the
    smallest positive value seen, so the axis keeps to the data's range."""
    mean, std = values.mean(axis=0), values.std(axis=0)
    low = mean - std
    if positive:
        seen = values[values > 0]
        low = np.maximum(low, seen.min() if seen.size else np.finfo(float).tiny)
    return mean, low, mean + std


def plot_bands(
    groups: Mapping[str, Sequence[RunData]],
    path: Path,
    metrics: Sequence[tuple[str, str]] = BAND_METRICS,
    title: str = "",
) -> Path:
    """Mean ± 1 std over seeds against time, one curve per group, one panel per metric."""
    height = 2.9 * len(metrics) + 0.6
    fig = Figure(figsize=(8.5, height))  # fixed margins: see plot_snapshots
    fig.subplots_adjust(left=0.1, right=0.98, top=1 - 0.5 / height, bottom=0.5 / height)
    FigureCanvasAgg(fig)
    axes = np.atleast_1d(fig.subplots(len(metrics), 1, sharex=True))
    for ax, (column, label) in zip(axes, metrics, strict=True):
        all_values = []
        for name, runs in groups.items():
            if not runs:
                continue
            time, values = _stack(runs, column)
            mean, low, high = band(values, positive=column != "effort")
            (line,) = ax.plot(time, mean, lw=1.4, label=f"{name} (n={len(runs)})")
            ax.fill_between(time, low, high, color=line.get_color(), alpha=0.2, lw=0)
            all_values.append(values)
        if (
            column in ("mse", "trace")
            and all_values
            and wants_log_scale(np.concatenate([v.ravel() for v in all_values]))
        ):
            ax.set_yscale("log")
        ax.set_ylabel(label)
        ax.grid(True, lw=0.4, alpha=0.4)
    axes[0].legend(fontsize="small")
    axes[-1].set_xlabel("time [s]")
    if title:
        fig.suptitle(title, fontsize="medium")
    return _save(fig, path, tight=False)


def plot_scale_boxes(summary: pd.DataFrame, path: Path, metric: str = "trace") -> Path:
    """Box plots of a time-averaged metric: robots on the x axis, one panel per target count,
    one box per method side by side."""
    targets = sorted(summary["targets"].unique())
    robots = sorted(summary["robots"].unique())
    methods = sorted(summary["tag_method"].unique())
    fig = Figure(figsize=(4.2 * len(targets), 3.8), layout="constrained")
    FigureCanvasAgg(fig)
    axes = np.atleast_1d(fig.subplots(1, len(targets), sharey=True))
    width = 0.8 / len(methods)
    colors = ("tab:blue", "tab:orange", "tab:green", "tab:purple")
    for ax, t in zip(axes, targets, strict=True):
        for m, method in enumerate(methods):
            rows = summary[(summary["targets"] == t) & (summary["tag_method"] == method)]
            data = [rows.loc[rows["robots"] == r, metric].to_numpy() for r in robots]
            positions = np.arange(len(robots)) + (m - (len(methods) - 1) / 2) * width
            box = ax.boxplot(
                data, positions=positions, widths=width * 0.9, patch_artist=True, showfliers=False
            )
            for patch in box["boxes"]:
                patch.set_facecolor(colors[m % len(colors)])
                patch.set_alpha(0.5)
            _overlay_points(ax, positions, data, colors[m % len(colors)])
            ax.plot([], [], color=colors[m % len(colors)], lw=6, alpha=0.5, label=method)
        ax.set_xticks(np.arange(len(robots)), [str(r) for r in robots])
        ax.set_xlabel("robots")
        ax.set_title(f"{t} targets", fontsize="medium")
        ax.grid(True, axis="y", lw=0.4, alpha=0.4)
    if wants_log_scale(summary[metric].to_numpy(dtype=float)):
        axes[0].set_yscale("log")
    axes[0].set_ylabel(f"time-averaged {metric}")
    axes[-1].legend(fontsize="small")
    return _save(fig, path)


def _overlay_points(ax, positions, data, color: str) -> None:
    """Every seed as a dot over its box (the boxes draw no outliers of their own), so that a
    box of one or two seeds still shows them."""
    for x, values in zip(positions, data, strict=True):
        offsets = np.linspace(-0.08, 0.08, len(values)) if len(values) > 1 else np.zeros(1)
        ax.plot(
            x + offsets[: len(values)], values, "o", ms=3.5, mfc=color, mec="k", mew=0.5, zorder=3
        )


def plot_policy_boxes(
    runs: pd.DataFrame, path: Path, metrics: Sequence[str] = ("trace", "mse")
) -> Path:
    """Box plots of time-averaged metrics over seeds, one box per policy, one panel per
    metric; each seed is drawn as a dot."""
    policies = list(dict.fromkeys(runs["policy"]))
    fig = Figure(figsize=(3.4 * len(metrics), 3.4), layout="constrained")
    FigureCanvasAgg(fig)
    axes = np.atleast_1d(fig.subplots(1, len(metrics)))
    for ax, metric in zip(axes, metrics, strict=True):
        data = [runs.loc[runs["policy"] == p, metric].to_numpy(dtype=float) for p in policies]
        positions = np.arange(len(policies), dtype=float)
        box = ax.boxplot(data, positions=positions, widths=0.6, patch_artist=True, showfliers=False)
        for patch, color in zip(box["boxes"], POLICY_COLORS, strict=False):
            patch.set_facecolor(color)
            patch.set_alpha(0.4)
        for k, values in enumerate(data):
            _overlay_points(
                ax, positions[k : k + 1], [values], POLICY_COLORS[k % len(POLICY_COLORS)]
            )
        ax.set_xticks(positions, policies, rotation=15)
        if metric in ("trace", "mse") and wants_log_scale(runs[metric].to_numpy(dtype=float)):
            ax.set_yscale("log")
        ax.set_title(f"time-averaged {metric}", fontsize="medium")
        ax.grid(True, axis="y", lw=0.4, alpha=0.4)
    return _save(fig, path)
