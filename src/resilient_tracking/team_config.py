"""What a team knows about itself: time step, velocity bounds, workspace, its sensor model."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from resilient_tracking.models.motion import NearlyConstantVelocity
from resilient_tracking.models.sensor import MeasurementModel, RangeBearingSensor
from resilient_tracking.scenario import Scenario


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

    @classmethod
    def from_scenario(cls, scenario: Scenario) -> TeamConfig:
        """The team a scenario declares: its robots, workspace, sensor and target model."""
        s = scenario.sensor
        return cls(
            dt=scenario.dt,
            u_max=np.array([r.u_max for r in scenario.robots], dtype=float),
            lower=scenario.workspace.lower,
            upper=scenario.workspace.upper,
            sensor=RangeBearingSensor(
                range_peak=s.range.peak,
                range_shape=s.range.shape,
                bearing_peak=s.bearing.peak,
                bearing_shape=s.bearing.shape,
                max_range=s.max_range,
            ),
            target_model=NearlyConstantVelocity(scenario.dt, scenario.estimator.accel_std),
            comm_range=scenario.comm_range,
        )
