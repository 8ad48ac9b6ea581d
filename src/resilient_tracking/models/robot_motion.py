"""The robots' motion: single integrators whose velocity is bounded and whose position stays in
the workspace (docs/model.md §1)."""

from __future__ import annotations

import numpy as np


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
    finite = np.isfinite(controls).all(axis=-1, keepdims=True)
    u = controls if finite.all() else np.where(finite, controls, 0.0)
    u = np.minimum(np.maximum(u, -bound), bound)
    # (ufuncs called by name: faster than the operators with a Python float, same numbers)
    nxt = np.minimum(np.maximum(positions + np.multiply(u, dt), lower), upper)
    return np.divide(nxt - positions, dt)
