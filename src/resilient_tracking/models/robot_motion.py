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
    clipping to its commands as the simulator does.
    """
    bound = u_max[:, None]
    nan = np.isnan(controls)
    u = np.where(nan, 0.0, controls) if nan.any() else controls  # ±inf: clipped below
    u = np.minimum(np.maximum(u, -bound), bound)
    nxt = np.minimum(np.maximum(positions + u * dt, lower), upper)
    return (nxt - positions) / dt
