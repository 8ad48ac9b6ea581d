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
    #: the mission's length in steps, when the team is told it (None: not known)
    mission_steps: int | None = None

    @property
    def n_robots(self) -> int:
        """Number of robots ``M``."""
        return len(self.u_max)

    def velocity_bounds(
        self, robots: list[int], positions: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Per-axis bounds on ``u`` of the ``robots`` at their rows of ``positions``: within
        ``±u_max`` and keeping ``x + u dt`` in the box (each bound's sign includes 0)."""
        umax, x = self.u_max[robots][:, None], positions[robots]
        lower = np.minimum(np.maximum(-umax, (self.lower - x) / self.dt), 0.0)
        upper = np.maximum(np.minimum(umax, (self.upper - x) / self.dt), 0.0)
        return lower, upper

    def clip(self, controls: np.ndarray, positions: np.ndarray) -> np.ndarray:
        """``controls`` (robots in order, one row each) clipped to :meth:`velocity_bounds` at
        ``positions``; NaN stays NaN."""
        lower, upper = self.velocity_bounds(list(range(len(controls))), positions)
        return np.minimum(np.maximum(controls, lower), upper)
