"""``rtrack animate``: a run's trajectory map as a moving picture, from its saved tables."""

from __future__ import annotations

import logging
import shutil
from pathlib import Path

import numpy as np
from matplotlib.animation import FFMpegWriter, FuncAnimation, PillowWriter
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from resilient_tracking.viz.io import load_run
from resilient_tracking.viz.trajectories import plot_trajectory_map

log = logging.getLogger(__name__)


def animate_run(
    run_dir: str | Path, out: str | Path | None = None, frames: int = 60, fps: int = 10
) -> list[Path]:
    """Write ``out`` (default ``run_dir/figures/animation.gif``) and, when ffmpeg is on the
    path, an MP4 beside it. ``frames`` evenly spaced steps are drawn."""
    run = load_run(run_dir)
    gif = Path(out) if out is not None else Path(run_dir) / "figures" / "animation.gif"
    gif.parent.mkdir(parents=True, exist_ok=True)
    steps = np.unique(np.linspace(0, run.last_step, max(2, frames)).round().astype(int))
    fig = Figure(figsize=(8.0, 5.5), layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()

    def draw(step: int) -> list:
        ax.clear()
        plot_trajectory_map(run, None, until_step=int(step), ax=ax, legend=False)
        return []

    animation = FuncAnimation(fig, draw, frames=steps, blit=False)
    written = [gif]
    animation.save(gif, writer=PillowWriter(fps=fps))
    if shutil.which("ffmpeg"):
        mp4 = gif.with_suffix(".mp4")
        animation.save(mp4, writer=FFMpegWriter(fps=fps))
        written.append(mp4)
    else:
        log.info("ffmpeg not found; wrote the GIF only")
    log.info("wrote %s", ", ".join(map(str, written)))
    return written
