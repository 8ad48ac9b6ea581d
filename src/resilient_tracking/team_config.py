"""What a team knows about itself: time step, velocity bounds, workspace, its sensor model."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from resilient_tracking.models.motion import NearlyConstantVelocity
from resilient_tracking.models.sensor import MeasurementModel


@dataclass(frozen=True)
class TeamConfig:
    """What a team knows about itself (module docstring); the same for every policy."""

    dt: float
    u_max: np.ndarray  # (M,)
    lower: np.ndarray  # (2,) workspace corner
    upper: np.ndarray  # (2,)
    sensor: MeasurementModel
    target_model: NearlyConstantVelocity
    #: links beyond this distance are lost without any jammer (None: no range limit)
    comm_range: float | None = None

    @property
    def n_robots(self) -> int:
        """Number of robots ``M``."""
        return len(self.u_max)

    def velocity_bounds(
        self, robots: list[int], positions: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Per-axis bounds on ``u`` that respect ``u_max`` and keep ``x + u dt`` in the box."""
        if len(positions) == len(self.u_max) and list(robots) == list(range(len(positions))):
            umax, x = self.u_max[:, None], positions  # the whole team, in order: no copies
        else:
            umax, x = self.u_max[robots][:, None], positions[robots]
        lower = np.minimum(np.maximum(-umax, (self.lower - x) / self.dt), 0.0)
        upper = np.maximum(np.minimum(umax, (self.upper - x) / self.dt), 0.0)
        return lower, upper
