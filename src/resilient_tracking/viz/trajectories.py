"""Trajectory map of one run: truth vs. what the team knows, robots, targets and attacks.

Everything is drawn from a :class:`~resilient_tracking.runs.reading.RunData` (saved tables), never
from simulation objects. :func:`plot_trajectory_map` can draw into a caller's axes so that
multi-panel snapshot figures (the map at several ``until_step`` values) reuse it.
"""

from __future__ import annotations

import logging
import math
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import rgb_to_hsv, to_hex, to_rgb
from matplotlib.figure import Figure
from matplotlib.patches import Circle, Ellipse, Rectangle

from resilient_tracking.runs.reading import RunData, attack_table

logger = logging.getLogger(__name__)

#: Robot colours: tab10 without red, grey and cyan, which mean sensing, targets and comm.
ROBOT_COLORS = (
    "tab:blue",
    "tab:orange",
    "tab:green",
    "tab:purple",
    "tab:brown",
    "tab:pink",
    "tab:olive",
    "navy",
    "darkgoldenrod",
    "teal",
)
SENSING_COLOR = "tab:red"
COMM_COLOR = "tab:cyan"
KNOWN_SENSING_COLOR = "darkred"
KNOWN_COMM_COLOR = "darkcyan"
TARGET_COLOR = "0.45"
TARGET_EST_COLOR = "0.15"
N_SIGMA = 2.0
DPI = 150


#: Most robots a scenario may have (``scenario.MAX_ROBOTS``); each gets its own colour.
N_ROBOT_COLORS = 64


def _extra_colors(base: tuple[str, ...], n: int) -> tuple[str, ...]:
    """``n`` colours after ``base``, picked greedily from a 6×6×6 RGB grid without greys, black,
    red (sensing) and cyan (comm): each is the candidate farthest from every colour picked so
    far, so the colours of a large team stay apart."""
    grid = np.stack(np.meshgrid(*[np.linspace(0, 1, 6)] * 3, indexing="ij"), -1).reshape(-1, 3)
    hsv = rgb_to_hsv(grid)
    hue, sat, val = hsv[:, 0], hsv[:, 1], hsv[:, 2]
    keep = (
        (sat > 0.3)  # not grey (targets)
        & (val > 0.25)  # not black
        & ((np.minimum(hue, 1 - hue) > 0.03) | (sat < 0.6))  # not red (sensing)
        & ((np.abs(hue - 0.5) > 0.05) | (sat < 0.6))  # not cyan (comm)
    )
    candidates = grid[keep]
    chosen = [np.array(to_rgb(c)) for c in base]
    picked: list[str] = []
    for _ in range(n):
        gap = np.min(np.linalg.norm(candidates[:, None] - np.array(chosen)[None], axis=-1), axis=1)
        best = int(np.argmax(gap))
        chosen.append(candidates[best])
        picked.append(to_hex(candidates[best]))
    return tuple(picked)


ROBOT_PALETTE = ROBOT_COLORS + _extra_colors(ROBOT_COLORS, N_ROBOT_COLORS - len(ROBOT_COLORS))


def robot_color(robot: int) -> str:
    """Colour of robot ``robot`` (stable across figures of one run): the ten above, then
    54 more, so that every robot of the largest team has its own."""
    return ROBOT_PALETTE[int(robot) % len(ROBOT_PALETTE)]


def known_zones_at(knowledge: pd.DataFrame, step: int | None) -> pd.DataFrame:
    """Zones as known to the team at ``step``: the latest knowledge row per zone.

    Keeps rows with ``step <= step`` (all rows when ``step`` is ``None``) and, per ``zone``, the
    one with the greatest step; ties go to the row written last. The result keeps the input
    columns, has one row per zone, is sorted by ``zone`` and has a fresh index.
    """
    if knowledge.empty:
        return knowledge.iloc[0:0].reset_index(drop=True)
    rows = knowledge if step is None else knowledge[knowledge["step"] <= step]
    if rows.empty:
        return rows.reset_index(drop=True)
    order = np.argsort(rows["step"].to_numpy(), kind="stable")
    latest = rows.iloc[order].drop_duplicates("zone", keep="last")
    return latest.sort_values("zone", kind="stable").reset_index(drop=True)


def covariance_ellipse(
    cx: float,
    cy: float,
    sxx: float,
    sxy: float,
    syy: float,
    n_sigma: float = N_SIGMA,
    **kwargs: Any,
) -> Ellipse | None:
    """The ``n_sigma`` ellipse of the 2×2 covariance ``[[sxx, sxy], [sxy, syy]]`` at ``(cx, cy)``.

    Returns ``None`` (and logs) when the numbers are not finite.
    """
    cov = np.array([[sxx, sxy], [sxy, syy]], dtype=float)
    if not (np.all(np.isfinite(cov)) and math.isfinite(cx) and math.isfinite(cy)):
        logger.warning("not drawing ellipse with non-finite center/covariance at (%s, %s)", cx, cy)
        return None
    vals, vecs = np.linalg.eigh(cov)
    vals = np.clip(vals, 0.0, None)
    angle = math.degrees(math.atan2(vecs[1, 1], vecs[0, 1]))
    width = 2.0 * n_sigma * math.sqrt(vals[1])
    height = 2.0 * n_sigma * math.sqrt(vals[0])
    return Ellipse((cx, cy), width, height, angle=angle, **kwargs)


def _legend_proxy(ax: Axes, label: str, **kwargs: Any) -> None:
    """An empty line that only exists to give the legend an entry."""
    ax.plot([], [], label=label, **kwargs)


def zones_at(zones: pd.DataFrame, tracks: pd.DataFrame, step: int | None) -> pd.DataFrame:
    """The zones table with each moving zone where it was at ``step`` (its last recorded step
    when ``None`` or later); static zones as they are."""
    if tracks.empty or zones.empty:
        return zones
    if step is not None:
        tracks = tracks[tracks["step"] <= step]
    last = tracks.sort_values("step", kind="stable").groupby("zone").tail(1).set_index("zone")
    out = zones.copy()
    for col in ("mu_x", "mu_y", "true_x", "true_y"):
        moved = out["zone"].map(last[col])
        out[col] = moved.where(moved.notna(), out[col])
    return out


def _draw_zone_tracks(ax: Axes, tracks: pd.DataFrame, step: int | None) -> None:
    """The path of each moving zone's true centre up to ``step``."""
    if tracks.empty:
        return
    if step is not None:
        tracks = tracks[tracks["step"] <= step]
    for _, track in tracks.sort_values(["zone", "step"], kind="stable").groupby("zone"):
        ax.plot(track["true_x"], track["true_y"], ls=":", lw=1.0, color="0.35", zorder=1)


def _draw_true_zones(ax: Axes, zones: pd.DataFrame) -> None:
    have_sensing = have_comm = False
    for z in zones.to_dict(orient="records"):
        kinds = str(z["kind"]).split("+")  # a zone of several kinds: "sensing+comm"
        if not set(kinds) <= {"sensing", "comm"}:
            logger.warning("zone %s has unknown kind %r; not drawn", z["zone"], z["kind"])
            continue
        tx, ty = float(z["true_x"]), float(z["true_y"])
        if "sensing" in kinds:
            ax.add_patch(
                Circle(
                    (tx, ty),
                    float(z["size"]),
                    facecolor=SENSING_COLOR,
                    edgecolor=SENSING_COLOR,
                    alpha=0.22,
                    lw=1.0,
                    zorder=1,
                )
            )
            have_sensing = True
        if "comm" in kinds:
            ring = covariance_ellipse(
                float(z["mu_x"]),
                float(z["mu_y"]),
                float(z["sigma_xx"]),
                float(z["sigma_xy"]),
                float(z["sigma_yy"]),
                fill=False,
                edgecolor=COMM_COLOR,
                lw=1.2,
                alpha=0.8,
                zorder=1,
            )
            if ring is not None:
                ax.add_patch(ring)
            ax.plot(
                [tx],
                [ty],
                marker="D",
                ms=7,
                color=COMM_COLOR,
                mec="k",
                mew=0.6,
                ls="none",
                zorder=4,
            )
            have_comm = True
        ax.plot(
            [float(z["mu_x"])], [float(z["mu_y"])], marker="+", ms=9, mew=1.4, color="k", zorder=4
        )
    if have_sensing:
        _legend_proxy(
            ax,
            "sensing zone (truth, radius r)",
            marker="o",
            ms=12,
            color=SENSING_COLOR,
            alpha=0.3,
            ls="none",
        )
    if have_comm:
        _legend_proxy(
            ax,
            "comm zone center (truth)",
            marker="D",
            ms=7,
            color=COMM_COLOR,
            mec="k",
            mew=0.6,
            ls="none",
        )
        _legend_proxy(ax, f"comm zone prior {N_SIGMA:g}σ", color=COMM_COLOR, lw=1.2)
    if len(zones):
        _legend_proxy(ax, "zone prior mean μ", marker="+", ms=9, mew=1.4, color="k", ls="none")


def _draw_known_zones(ax: Axes, known: pd.DataFrame) -> None:
    kinds: set[str] = set()
    for z in known.to_dict(orient="records"):
        kind = str(z["kind"])
        color = KNOWN_SENSING_COLOR if kind == "sensing" else KNOWN_COMM_COLOR
        ell = covariance_ellipse(
            float(z["x"]),
            float(z["y"]),
            float(z["sigma_xx"]),
            float(z["sigma_xy"]),
            float(z["sigma_yy"]),
            fill=False,
            edgecolor=color,
            ls="--",
            lw=1.3,
            zorder=2,
        )
        if ell is not None:
            ax.add_patch(ell)
        if kind == "sensing" and math.isfinite(float(z["size"])):
            ax.add_patch(
                Circle(
                    (float(z["x"]), float(z["y"])),
                    float(z["size"]),
                    fill=False,
                    edgecolor=color,
                    ls=(0, (2, 2)),
                    lw=1.0,
                    zorder=2,
                )
            )
        kinds.add(kind)
    if "sensing" in kinds:
        _legend_proxy(
            ax, f"known sensing zone ({N_SIGMA:g}σ, r)", color=KNOWN_SENSING_COLOR, ls="--"
        )
    if kinds - {"sensing"}:
        _legend_proxy(ax, f"known comm zone ({N_SIGMA:g}σ)", color=KNOWN_COMM_COLOR, ls="--")


def _draw_targets(ax: Axes, targets: pd.DataFrame) -> None:
    if targets.empty:
        return
    for _, tr in targets.groupby("target", sort=True):
        ax.plot(tr["x"], tr["y"], color=TARGET_COLOR, lw=1.4, alpha=0.8, zorder=2)
        ax.plot(tr["est_x"], tr["est_y"], color=TARGET_EST_COLOR, lw=1.0, ls=":", zorder=2)
        ax.plot(
            [tr["x"].iloc[-1]],
            [tr["y"].iloc[-1]],
            marker="*",
            ms=11,
            color=TARGET_COLOR,
            mec="k",
            mew=0.5,
            zorder=4,
        )
        ax.plot(
            [tr["est_x"].iloc[-1]],
            [tr["est_y"].iloc[-1]],
            marker="*",
            ms=8,
            mfc="none",
            mec=TARGET_EST_COLOR,
            zorder=4,
        )
    _legend_proxy(ax, "target truth (★ now)", color=TARGET_COLOR, lw=1.4, marker="*", mec="k")
    _legend_proxy(ax, "target estimate (☆ now)", color=TARGET_EST_COLOR, lw=1.0, ls=":")


def _draw_robots(ax: Axes, robots: pd.DataFrame) -> None:
    if robots.empty:
        return
    for _, tr in robots.groupby("robot", sort=True):
        rid = int(tr["robot"].iloc[0])
        color = robot_color(rid)
        ax.plot(tr["x"], tr["y"], color=color, lw=1.6, zorder=3, label=f"robot {rid}")
        ax.plot(
            [tr["x"].iloc[0]], [tr["y"].iloc[0]], marker="o", ms=7, mfc="white", mec=color, mew=1.5
        )
        ax.plot(
            [tr["x"].iloc[-1]],
            [tr["y"].iloc[-1]],
            marker="o",
            ms=8,
            color=color,
            mec="k",
            mew=0.7,
            zorder=5,
        )
    _legend_proxy(ax, "robot start", marker="o", ms=7, mfc="white", mec="k", ls="none")
    _legend_proxy(ax, "robot now", marker="o", ms=8, color="0.6", mec="k", ls="none")


def _draw_attacks(ax: Axes, attacks: pd.DataFrame) -> None:
    for kind, color, label in (
        ("sensing", SENSING_COLOR, "sensing attack"),
        ("comm", COMM_COLOR, "comm attack"),
    ):
        sel = attacks[(attacks["kind"] == kind) & attacks["x"].notna()]
        if sel.empty:
            continue
        ax.plot(
            sel["x"],
            sel["y"],
            marker="x",
            ms=9,
            mew=2.2,
            color=color,
            ls="none",
            zorder=6,
            label=label,
        )


def _set_limits(ax: Axes, run: RunData) -> None:
    """Workspace box and limits (data bounds when the manifest has no workspace)."""
    ws = run.workspace
    if ws is not None:
        xmin, xmax, ymin, ymax = ws
        ax.add_patch(
            Rectangle(
                (xmin, ymin), xmax - xmin, ymax - ymin, fill=False, edgecolor="k", lw=1.2, zorder=0
            )
        )
    else:
        xs = [run.robots["x"], run.targets["x"], run.zones["true_x"], run.zones["mu_x"]]
        ys = [run.robots["y"], run.targets["y"], run.zones["true_y"], run.zones["mu_y"]]
        xv = pd.concat(xs).to_numpy(dtype=float)
        yv = pd.concat(ys).to_numpy(dtype=float)
        xv, yv = xv[np.isfinite(xv)], yv[np.isfinite(yv)]
        if xv.size == 0 or yv.size == 0:
            return
        xmin, xmax, ymin, ymax = float(xv.min()), float(xv.max()), float(yv.min()), float(yv.max())
    pad = 0.03 * max(xmax - xmin, ymax - ymin, 1e-9)
    ax.set_xlim(xmin - pad, xmax + pad)
    ax.set_ylim(ymin - pad, ymax + pad)


def plot_trajectory_map(
    run: RunData,
    path: Path | None,
    until_step: int | None = None,
    ax: Axes | None = None,
    *,
    legend: bool = True,
    title: str | None = None,
) -> Axes:
    """Draw the run's map up to ``until_step`` (whole run when ``None``) and save it to ``path``.

    Draws the workspace box; the true zones (sensing: light red disk of radius ``size`` at the
    true center; comm: cyan diamond at the true center with the 2σ prior ring); each zone's
    prior mean as a black "+"; the zones as known to the team at ``until_step``
    (:func:`known_zones_at`: dashed 2σ ellipse of the estimate, plus a dashed circle of radius
    ``size`` for sensing zones); robot trajectories (one colour each, hollow start marker,
    filled marker at the current position); target truth paths (grey, ★ at the current
    position) and team estimates (dotted, ☆); attacks as red (sensing) / cyan (comm) "x" at the
    attacked robot's position. Equal aspect.

    With ``ax`` given, draws into it (for multi-panel figures) and saves its figure only when
    ``path`` is given. ``legend=False`` omits the legend (the entries remain available through
    ``ax.get_legend_handles_labels()``); ``title`` overrides the default title. Returns the axes.
    """
    own_figure = ax is None
    if ax is None:
        fig = Figure(figsize=(9.5, 6.5), layout="constrained")
        FigureCanvasAgg(fig)
        ax = fig.add_subplot()

    robots = run.robots
    targets = run.targets
    if until_step is not None:
        robots = robots[robots["step"] <= until_step]
        targets = targets[targets["step"] <= until_step]
    robots = robots.sort_values(["robot", "step"], kind="stable")
    targets = targets.sort_values(["target", "step"], kind="stable")

    _set_limits(ax, run)
    _draw_true_zones(ax, zones_at(run.zones, run.zone_tracks, until_step))
    _draw_zone_tracks(ax, run.zone_tracks, until_step)
    _draw_known_zones(ax, known_zones_at(run.knowledge, until_step))
    _draw_targets(ax, targets)
    _draw_robots(ax, robots)
    _draw_attacks(ax, attack_table(run, until_step))

    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.grid(True, lw=0.4, alpha=0.4)
    if title is None:
        title = run.title()
        if until_step is not None:
            t = float(run.times_of([until_step])[0])
            title += f"\nt = {t:.1f} s (step {until_step})"
    ax.set_title(title, fontsize="medium")
    if legend:
        ax.legend(
            loc="upper left",
            bbox_to_anchor=(1.02, 1.0),
            borderaxespad=0.0,
            fontsize="small",
            framealpha=0.9,
        )
    if path is not None:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        fig_or_sub = ax.figure  # a SubFigure when drawing into a panel of one
        fig_to_save = fig_or_sub if isinstance(fig_or_sub, Figure) else fig_or_sub.figure
        fig_to_save.savefig(path, dpi=DPI, bbox_inches="tight")
        logger.info("wrote %s", path)
    elif own_figure:
        logger.debug("plot_trajectory_map called without path or axes; nothing saved")
    return ax
