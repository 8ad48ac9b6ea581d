"""Figures made from saved run data (never from in-memory simulation objects).

:func:`~resilient_tracking.runs.reading.load_run` is the only place the tables of a run folder are
read; the plotting functions take the resulting :class:`~resilient_tracking.runs.reading.RunData`.
Figures are rendered with matplotlib's Agg canvas directly (no pyplot, no global state).

- :func:`make_run_figures` — every per-run figure into ``run_dir/figures/``.
- :func:`plot_trajectory_map` — truth vs. known zones, robots, targets, attacks (can draw into a
  caller's axes, e.g. for snapshot panels at several steps).
- :func:`plot_metric_curves` — MSE, trace, effort and failed robots against time.
- :func:`known_zones_at` — the team's zone estimates as of a step.
"""

from __future__ import annotations

import logging
from pathlib import Path

from resilient_tracking.runs.reading import RunData, attack_table, load_run
from resilient_tracking.viz.curves import plot_metric_curves, wants_log_scale
from resilient_tracking.viz.trajectories import (
    covariance_ellipse,
    known_zones_at,
    plot_trajectory_map,
    robot_color,
)

logger = logging.getLogger(__name__)

#: File names written by :func:`make_run_figures` inside ``run_dir/figures/``.
TRAJECTORY_FILE = "trajectories.png"
METRICS_FILE = "metrics.png"


def make_run_figures(run_dir: Path) -> list[Path]:
    """Write the per-run figures of ``run_dir`` into ``run_dir/figures/``; return their paths.

    Currently ``trajectories.png`` (:func:`plot_trajectory_map` over the whole run) and
    ``metrics.png`` (:func:`plot_metric_curves`).
    """
    run_dir = Path(run_dir)
    run = load_run(run_dir)
    out_dir = run_dir / "figures"
    out_dir.mkdir(parents=True, exist_ok=True)
    paths: list[Path] = []
    traj = out_dir / TRAJECTORY_FILE
    plot_trajectory_map(run, traj)
    paths.append(traj)
    paths.append(plot_metric_curves(run, out_dir / METRICS_FILE))
    logger.info("wrote %d figure(s) for %s", len(paths), run_dir)
    return paths


__all__ = [
    "METRICS_FILE",
    "TRAJECTORY_FILE",
    "RunData",
    "attack_table",
    "covariance_ellipse",
    "known_zones_at",
    "load_run",
    "make_run_figures",
    "plot_metric_curves",
    "plot_trajectory_map",
    "robot_color",
    "wants_log_scale",
]
