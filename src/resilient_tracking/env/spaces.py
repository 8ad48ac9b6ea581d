"""Gymnasium spaces of the environments: a robot's view and its velocity."""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium import spaces

from resilient_tracking.belief.agent_view import FIELDS, ViewShape

#: Fields holding masks (0 or 1); every other field is unbounded.
MASKS = ("teammates_mask", "zones_mask")


def view_space(shape: ViewShape, robots: int | None = None) -> spaces.Dict:
    """The space of one robot's view, or with ``robots`` given, of every robot's view stacked
    (a leading axis of that length)."""
    lead = () if robots is None else (robots,)
    fields: dict[str, spaces.Space[Any]] = {}
    for name in FIELDS:
        dims = lead + shape.shapes()[name]
        low, high = (0.0, 1.0) if name in MASKS else (-np.inf, np.inf)
        fields[name] = spaces.Box(low, high, dims, dtype=np.float32)
    return spaces.Dict(fields)


def velocity_space(u_max: np.ndarray) -> spaces.Box:
    """Velocities within ``±u_max`` per component: ``(2,)`` for one robot (a scalar bound),
    ``(M, 2)`` for a team (``M`` bounds)."""
    bound = np.asarray(u_max, dtype=np.float64)
    high = np.broadcast_to(bound[..., None], bound.shape + (2,)).copy()
    return spaces.Box(-high, high, dtype=np.float64)
