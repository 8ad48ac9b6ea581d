"""Frames of an episode in progress: the project's map (:mod:`resilient_tracking.viz`) of the
steps taken so far, as an RGB array."""

from __future__ import annotations

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from resilient_tracking.runs.reading import run_data
from resilient_tracking.runs.records import EpisodeResult
from resilient_tracking.viz.trajectories import plot_trajectory_map

#: Size of a frame in inches at :data:`DPI` (a frame is ``(480, 640, 3)``).
FIGSIZE = (6.4, 4.8)
DPI = 100


def map_frame(result: EpisodeResult) -> np.ndarray:
    """The map of the run so far, ``(H, W, 3)`` ``uint8``; an empty run draws the zones and
    the workspace only."""
    fig = Figure(figsize=FIGSIZE, dpi=DPI, layout="constrained")
    canvas = FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    plot_trajectory_map(run_data(result, "environment"), None, ax=ax, legend=False)
    canvas.draw()
    return np.asarray(canvas.buffer_rgba())[..., :3].copy()
