"""``rtrack animate``: a run's trajectory map as a moving picture, from its saved tables."""

from __future__ import annotations

import logging
import shutil
from collections.abc import Callable
from pathlib import Path

import numpy as np
from matplotlib import rc_context
from matplotlib.animation import FFMpegWriter, FuncAnimation, PillowWriter
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from resilient_tracking.runs.reading import load_run
from resilient_tracking.viz.trajectories import plot_trajectory_map

log = logging.getLogger(__name__)


def ffmpeg_path() -> str | None:
    """A system ffmpeg on the path, else the one bundled with ``imageio-ffmpeg`` (the
    ``video`` extra), else None."""
    found = shutil.which("ffmpeg")
    if found:
        return found
    try:
        import imageio_ffmpeg
    except ImportError:
        return None
    try:
        return str(imageio_ffmpeg.get_ffmpeg_exe())
    except RuntimeError:  # the package is there but has no binary for this platform
        return None


def animate_run(
    run_dir: str | Path,
    out: str | Path | None = None,
    frames: int = 60,
    fps: int = 10,
    progress: Callable[[int], object] | None = None,
) -> list[Path]:
    """Write ``out`` (default ``run_dir/figures/animation.gif``) and, when an ffmpeg is found
    (:func:`ffmpeg_path`), an MP4 beside it. ``frames`` evenly spaced steps are drawn;
    ``progress(n)`` is called with the number of frames just written (GIF and MP4 both)."""
    run = load_run(run_dir)
    gif = Path(out) if out is not None else Path(run_dir) / "figures" / "animation.gif"
    steps = np.unique(np.linspace(0, run.last_step, max(2, frames)).round().astype(int))
    fig = Figure(figsize=(8.0, 5.5), layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()

    def draw(step: int) -> list:
        ax.clear()
        plot_trajectory_map(run, None, until_step=int(step), ax=ax, legend=False)
        return []

    # the first frame before any file: the movie writer would hide its error behind its own
    draw(int(steps[0]))
    gif.parent.mkdir(parents=True, exist_ok=True)

    def tick(_frame: int, _total: int) -> None:
        if progress is not None:
            progress(1)

    animation = FuncAnimation(fig, draw, frames=steps, blit=False)
    written = [gif]
    animation.save(gif, writer=PillowWriter(fps=fps), progress_callback=tick)
    ffmpeg = ffmpeg_path()
    if ffmpeg is not None:
        mp4 = gif.with_suffix(".mp4")
        with rc_context({"animation.ffmpeg_path": ffmpeg}):
            animation.save(mp4, writer=FFMpegWriter(fps=fps), progress_callback=tick)
        written.append(mp4)
    else:
        log.warning(
            "no ffmpeg found (neither on the path nor imageio-ffmpeg); wrote the GIF only. "
            "For an MP4: pip install 'resilient-tracking[video]'"
        )
    log.info("wrote %s", ", ".join(map(str, written)))
    return written
