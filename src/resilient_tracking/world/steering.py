"""Bounded steering for the target motions that react to the world (``evasive``, ``lure``):
turning a velocity toward a wanted one with bounded acceleration, moving inside the workspace
by sliding along its walls, and chasing a moving point (the base motion's shadow) until on it.
"""

from __future__ import annotations

import numpy as np

from resilient_tracking.models.geometry import vector_length

#: Time constant (s) of the approach to a point: the wanted velocity closes the gap at
#: ``gap / APPROACH_TIME`` (capped at the top speed), so the gap shrinks geometrically.
APPROACH_TIME = 0.5
#: A chase ends when the target is this close (m) to the point it chases.
ON_POINT = 0.01


def capped(v: np.ndarray, limit: float) -> np.ndarray:
    """``v`` scaled down to length ``limit`` if longer."""
    length = vector_length(v)
    return v * (limit / length) if length > limit else v


def turn_toward(
    velocity: np.ndarray, wanted: np.ndarray, speed: float, max_accel: float, dt: float
) -> np.ndarray:
    """The velocity after one step of turning toward ``wanted``: a change of at most
    ``max_accel · dt``, and at most ``speed`` long (the cap wins over the acceleration bound
    when ``velocity`` itself is faster than ``speed``)."""
    return capped(velocity + capped(wanted - velocity, max_accel * dt), speed)


def move_inside(
    position: np.ndarray, velocity: np.ndarray, dt: float, lower: np.ndarray, upper: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Position and velocity after moving ``dt`` at ``velocity`` inside the box: a component
    that would cross a wall stops on it (the target slides along the wall). A target already
    outside (its base motion left the box) is not pulled in, only kept from going further."""
    moved = position + velocity * dt
    inside = np.clip(moved, np.minimum(lower, position), np.maximum(upper, position))
    if (inside == moved).all():
        return moved, velocity
    blocked = inside != moved
    velocity = np.where(blocked, (inside - position) / dt, velocity)
    return inside, velocity


def approach(
    position: np.ndarray,
    goal: np.ndarray,
    goal_velocity: np.ndarray,
    speed: float,
) -> np.ndarray:
    """The velocity wanted to close on a point at ``goal`` moving at ``goal_velocity``: its
    velocity plus the gap over :data:`APPROACH_TIME`, at most ``speed``."""
    return capped(goal_velocity + (goal - position) / APPROACH_TIME, speed)


def on_point(
    position: np.ndarray,
    velocity: np.ndarray,
    goal: np.ndarray,
    goal_velocity: np.ndarray,
    max_accel: float,
    dt: float,
) -> bool:
    """Whether a chase of ``goal`` can end: within :data:`ON_POINT` of it, and at its velocity
    up to one step's acceleration."""
    return (
        vector_length(goal - position) <= ON_POINT
        and vector_length(goal_velocity - velocity) <= max_accel * dt
    )


def free_run(
    position: np.ndarray, heading: np.ndarray, lower: np.ndarray, upper: np.ndarray
) -> float:
    """How far (m) the box lets a target at ``position`` go along the unit ``heading``."""
    run = np.inf
    for axis in range(2):
        h = heading[axis]
        if h > 0:
            run = min(run, (upper[axis] - position[axis]) / h)
        elif h < 0:
            run = min(run, (lower[axis] - position[axis]) / h)
    return float(max(run, 0.0))
