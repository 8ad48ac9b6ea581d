"""The robots' motion: single integrators whose velocity is bounded and whose position stays in
the workspace (docs/model.md §1)."""

from __future__ import annotations

import numpy as np

from resilient_tracking.models.numpy_twins import all_finite


def clip_velocities(
    positions: np.ndarray,
    controls: np.ndarray,
    u_max: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    dt: float,
) -> np.ndarray:
    """Velocity bounds per component, then keep the next position inside the workspace.

    A pure function of the robots' own positions, so a robot-side node can apply the same
    clipping to its commands as the simulator does. A robot whose command is not finite (NaN or
    infinite in either component) holds its position: its velocity is 0.
    """
    bound = u_max[:, None]
    return _clip(positions, controls, -bound, bound, lower, upper, dt)


class VelocityClip:
    """:func:`clip_velocities` for one team, its bounds made once as ``(M, 2)`` arrays:
    ``±u_max`` per component and the workspace corners (NumPy combines arrays of one shape
    faster than broadcast ones; the same numbers)."""

    def __init__(self, u_max: np.ndarray, lower: np.ndarray, upper: np.ndarray, dt: float):
        shape = (len(u_max), 2)
        self._high = np.broadcast_to(np.asarray(u_max)[:, None], shape).copy()
        self._low = -self._high
        self._lower = np.broadcast_to(lower, shape).copy()
        self._upper = np.broadcast_to(upper, shape).copy()
        self._dt = dt

    def __call__(self, positions: np.ndarray, controls: np.ndarray) -> np.ndarray:
        """The velocities applied for ``controls`` (M, 2) of robots at ``positions`` (M, 2)."""
        return _clip(positions, controls, self._low, self._high, self._lower, self._upper, self._dt)


def _clip(
    positions: np.ndarray,
    controls: np.ndarray,
    low: np.ndarray,
    high: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    dt: float,
) -> np.ndarray:
    """:func:`clip_velocities` with the velocity bounds ``low = −u_max``, ``high = u_max``."""
    u = controls
    if not all_finite(controls):  # rare: find whose command it is, it holds position
        u = np.where(np.isfinite(controls).all(axis=-1, keepdims=True), controls, 0.0)
    return _to_workspace(positions, np.minimum(np.maximum(u, low), high), lower, upper, dt)


def _to_workspace(
    positions: np.ndarray, u: np.ndarray, lower: np.ndarray, upper: np.ndarray, dt: float
) -> np.ndarray:
    """The velocities ``u`` (within their bounds) cut so the next position stays inside."""
    # (ufuncs called by name: faster than the operators with a Python float, same numbers)
    nxt = np.minimum(np.maximum(positions + np.multiply(u, dt), lower), upper)
    return np.divide(nxt - positions, dt)
