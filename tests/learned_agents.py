"""Functions from a robot's view to its velocity, for the tests of learned policies."""

from __future__ import annotations

import numpy as np


def chase(view: dict[str, np.ndarray]) -> np.ndarray:
    """Full speed towards the nearest target estimate, each axis."""
    own = view["own"]
    gaps = view["targets"][:, :2] - own[:2]
    nearest = gaps[np.argmin(np.hypot(gaps[:, 0], gaps[:, 1]))]
    return np.clip(nearest, -own[2], own[2])


def broken(view: dict[str, np.ndarray]) -> np.ndarray:
    """NaN for the robot that starts highest in ``sensing-temp`` (robot 0, y = 0.8), which it
    never leaves: the others stand still."""
    return np.array([np.nan, 0.0]) if view["own"][1] > 0.5 else np.zeros(2)
