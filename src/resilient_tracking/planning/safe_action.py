"""The last rung of the solver ladder (docs/model.md §9): a safe action when no solve succeeded.

A robot that violates the chance constraint of a known zone (eq. 7c for sensing zones, eq. 7d
with its teammates for comm zones) steps straight away from those zones; every other robot holds
its position. The escape is taken only if it moves away from *every* known zone's mean
(``u · (x − μ) ≥ 0``), otherwise the robot holds too, so the fallback never brings a robot
closer to a zone it knows. The command is scaled, not clipped per axis, into the velocity
bounds (which contain zero), which keeps its direction and hence that guarantee.
"""

from __future__ import annotations

import numpy as np

from resilient_tracking.planning.league_problem import ProblemInputs

#: Below this distance (m) to a zone mean the way out is undefined: hold.
MIN_ESCAPE_DISTANCE = 1e-9


def _spread(offset: np.ndarray, sxx: float, sxy: float, syy: float, dist: float) -> float:
    """``√(2 âᵀ Σ â)`` with ``â`` the unit vector from the robot to the zone mean."""
    a = -offset / dist
    quad = a[0] * a[0] * sxx + 2 * a[0] * a[1] * sxy + a[1] * a[1] * syy
    return float(np.sqrt(max(2.0 * quad, 0.0)))


def constraint_margins(q: ProblemInputs, robot: int) -> np.ndarray:
    """Left minus right side of the robot's zone constraints at its current position (no slack).

    One value per known zone, sensing rows first, then comm rows; negative means violated.
    """
    x = q.positions[robot]
    out = []
    for mx, my, sxx, sxy, syy, r_safe, beta in q.sensing_zones:
        offset = x - np.array([mx, my])
        dist = float(np.linalg.norm(offset))
        spread = _spread(offset, sxx, sxy, syy, dist) if dist > 0 else 0.0
        out.append(dist - r_safe - beta * spread)
    others = np.delete(q.positions, robot, axis=0)
    farthest = float(np.linalg.norm(others - x, axis=1).max()) if len(others) else 0.0
    for mx, my, sxx, sxy, syy, delta2, beta, clearance in q.comm_zones:
        offset = x - np.array([mx, my])
        dist = float(np.linalg.norm(offset))
        spread = _spread(offset, sxx, sxy, syy, dist) if dist > 0 else 0.0
        out.append(dist - delta2 * farthest - clearance - beta * spread)
    return np.array(out, dtype=float)


def _scale_into(direction: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """The longest ``t · direction`` (``t ≥ 0``) inside the box ``[lower, upper]`` (contains 0)."""
    t = np.inf
    for k in range(2):
        if direction[k] > 0:
            t = min(t, upper[k] / direction[k])
        elif direction[k] < 0:
            t = min(t, lower[k] / direction[k])
    return np.zeros(2) if not np.isfinite(t) else max(t, 0.0) * direction


def safe_action(q: ProblemInputs) -> tuple[np.ndarray, list[str]]:
    """Commands ``(n, 2)`` and, per robot, ``"escape"`` or ``"hold"``."""
    n = len(q.positions)
    controls = np.zeros((n, 2))
    actions = ["hold"] * n
    means = np.concatenate([q.sensing_zones[:, :2], q.comm_zones[:, :2]], axis=0)
    if len(means) == 0:
        return controls, actions
    for i in range(n):
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
        direction /= norm
        if np.any(offsets @ direction < 0):  # would approach some known zone: hold instead
            continue
        u = _scale_into(direction, q.u_lower[i], q.u_upper[i])
        if np.any(offsets @ u < 0):  # rounding guard
            continue
        controls[i] = u
        actions[i] = "escape"
    return controls, actions
