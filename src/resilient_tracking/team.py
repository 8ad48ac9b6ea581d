"""``Team``: the robots' side of the loop, usable with or without the simulator.

Each tick it takes what real robots provide — a :class:`TeamObservation` with own positions,
measurements, failure flags, attack clues and link states — updates the team's belief and asks
the policy for velocity commands. The simulator drives this same object; a ROS 2 or
Crazyflie node can wrap it the same way::

    team = Team.from_scenario(load_scenario("mission.yaml"), initial_means)
    while running:
        commands = team.step(TeamObservation(...)).controls   # (M, 2) velocities
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from resilient_tracking.belief.ekf import ExtendedKalmanFilter
from resilient_tracking.belief.estimate import TargetEstimate
from resilient_tracking.belief.team_belief import TeamBelief
from resilient_tracking.events import Event
from resilient_tracking.observation import TeamObservation
from resilient_tracking.policies.base import Decision, Policy
from resilient_tracking.scenario import Scenario
from resilient_tracking.team_config import TeamConfig


@dataclass
class TeamStep:
    """The result of one tick: commands plus what happened in belief and planning."""

    controls: np.ndarray
    decision: Decision
    events: list[Event] = field(default_factory=list)


class Team:
    """Belief plus policy for ``M`` robots tracking ``N`` targets."""

    def __init__(self, policy: Policy, initial_estimate: TargetEstimate):
        self.policy = policy
        config = policy.config
        self.belief = TeamBelief(
            n_robots=config.n_robots,
            initial=initial_estimate,
            ekf=ExtendedKalmanFilter(config.target_model, config.sensor),
            learns_zones=policy.learns_zones,
        )

    @classmethod
    def from_scenario(
        cls, scenario: Scenario, initial_means: np.ndarray, policy: str | None = None
    ) -> Team:
        """A team for a scenario's robots and sensors, starting from the target means (N, 4)
        ``[px, py, vx, vy]`` with the scenario's declared initial uncertainty."""
        from resilient_tracking.policies import make_policy

        spec = scenario.estimator
        config = TeamConfig.from_scenario(scenario)
        return cls(
            make_policy(policy or scenario.policy.name, scenario, config),
            TargetEstimate.initial(
                np.asarray(initial_means, dtype=float),
                spec.initial_position_std,
                spec.initial_velocity_std,
            ),
        )

    def step(self, obs: TeamObservation) -> TeamStep:
        if obs.n_robots != self.belief.n_robots:
            raise ValueError(
                f"observation.positions: expected {self.belief.n_robots} robots, got {obs.n_robots}"
            )
        events = self.belief.update(obs)
        decision = self.policy.act(self.belief, obs)
        return TeamStep(
            controls=decision.controls, decision=decision, events=events + decision.events
        )
