"""The last rung of the solver ladder (docs/model.md §9): a safe action when no solve succeeded.

A robot that violates the chance constraint of a known zone (eq. 7c for sensing zones, eq. 7d
with its teammates for comm zones) steps straight away from those zones; every other robot holds
its position. The escape never approaches a known zone's mean (``u · (x − μ) ≥ 0`` for every
zone): when the straight way out would, the robot takes the nearest direction that does not
(along the edge of some zone's half-plane), and holds when there is none, so the fallback
never brings a robot closer to a zone it knows. The command is scaled, not clipped per axis,
into the velocity bounds (which contain zero), which keeps its direction and hence that
guarantee.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from resilient_tracking.planning.layout import CommRow, ProblemInputs, SensingRow
from resilient_tracking.planning.margins import keep_out_values, pair_distances

#: Below this distance (m) to a zone mean the way out is undefined: hold.
MIN_ESCAPE_DISTANCE = 1e-9
#: How far an escape along a zone's half-plane edge is tilted away from that zone (so that
#: rounding cannot make it approach the zone).
EDGE_TILT = 1e-6


def constraint_margins(q: ProblemInputs, robot: int) -> np.ndarray:
    """The keep-out margins of the robot's zone constraints at its current position (no
    slack; comm rows with its farthest teammate, the row that binds first).

    One value per known zone, sensing rows first, then comm rows; negative means violated.
    """
    x = q.positions[robot]
    zs, zc = q.sensing_zones, q.comm_zones
    sensing = keep_out_values(
        x, zs[:, SensingRow.GAUSSIAN], zs[:, SensingRow.R_SAFE], zs[:, SensingRow.BETA]
    )
    others = np.delete(q.positions, robot, axis=0)
    if q.unlinked is not None:  # the route program's kept links only
        others = others[np.delete(np.asarray(q.unlinked)[robot], robot) < 0.5]
    farthest = float(pair_distances(x, others).max()) if len(others) else 0.0
    comm = keep_out_values(
        x, zc[:, CommRow.GAUSSIAN], zc[:, CommRow.CLEARANCE], zc[:, CommRow.BETA]
    )
    comm = comm - zc[:, CommRow.DELTA2] * farthest
    return np.concatenate([sensing, comm]).astype(float)


def _scale_into(direction: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """The longest ``t · direction`` (``t ≥ 0``) inside the box ``[lower, upper]`` (contains 0)."""
    t = np.inf
    for k in range(2):
        if direction[k] > 0:
            t = min(t, upper[k] / direction[k])
        elif direction[k] < 0:
            t = min(t, lower[k] / direction[k])
    return np.zeros(2) if not np.isfinite(t) else max(t, 0.0) * direction


def _away_from_every_zone(direction: np.ndarray, offsets: np.ndarray) -> np.ndarray | None:
    """``direction`` itself when it approaches no zone (``offsets @ d ≥ 0``), else the nearest
    unit vector to it that does (one on the edge of some zone's half-plane) if it still points
    along ``direction``, else None."""
    if np.all(offsets @ direction >= 0):
        return direction
    lengths = np.linalg.norm(offsets, axis=1, keepdims=True)
    if np.any(lengths < MIN_ESCAPE_DISTANCE):  # on some zone's mean: no edge is defined
        return None
    unit = offsets / lengths
    edges = np.column_stack([-unit[:, 1], unit[:, 0]])
    candidates = np.concatenate([edges, -edges]) + EDGE_TILT * np.concatenate([unit, unit])
    candidates /= np.linalg.norm(candidates, axis=1, keepdims=True)
    allowed = np.all(candidates @ offsets.T >= 0, axis=1) & (candidates @ direction > 0)
    if not allowed.any():
        return None
    return candidates[allowed][np.argmax(candidates[allowed] @ direction)]


def safe_action(
    q: ProblemInputs, robots: Sequence[int] | np.ndarray | None = None
) -> tuple[np.ndarray, list[str]]:
    """Commands ``(n, 2)`` and, per robot, ``"escape"`` or ``"hold"``; with ``robots``, only
    those robots are decided (the others get 0 and ``"hold"``)."""
    n = len(q.positions)
    controls = np.zeros((n, 2))
    actions = ["hold"] * n
    means = np.concatenate(
        [q.sensing_zones[:, SensingRow.MEAN], q.comm_zones[:, CommRow.MEAN]], axis=0
    )
    if len(means) == 0:
        return controls, actions
    for i in range(n) if robots is None else robots:
        margins = constraint_margins(q, i)
        offsets = q.positions[i] - means
        dists = np.linalg.norm(offsets, axis=1)
        violated = margins < 0
        if not violated.any() or np.any(dists[violated] < MIN_ESCAPE_DISTANCE):
            continue
        away = offsets[violated] / dists[violated, None]
        direction = (away * (-margins[violated])[:, None]).sum(axis=0)
        norm = float(np.linalg.norm(direction))
        if norm < MIN_ESCAPE_DISTANCE:
            continue
        direction = _away_from_every_zone(direction / norm, offsets)
        if direction is None:  # every way out approaches some known zone: hold instead
            continue
        u = _scale_into(direction, q.u_lower[i], q.u_upper[i])
        if np.any(offsets @ u < 0):  # rounding guard
            continue
        controls[i] = u
        actions[i] = "escape"
    return controls, actions
