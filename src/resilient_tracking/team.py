"""``Team``: the robots' side of the loop, usable with or without the simulator.

Each tick it takes what real robots provide — a :class:`TeamObservation` with own positions,
measurements, failure flags, attack clues and link states — updates the team's belief and asks
the policy for velocity commands. The simulator drives this same object; a ROS 2 or
Crazyflie node can wrap it the same way (``docs/team-api.md`` has a complete, tested example)::

    team = Team.from_scenario(scenarios.load("mission.yaml"), initial_means)
    while running:
        step = team.step(TeamObservation(...))
        send(step.controls)          # (M, 2) velocities
        log(step.events)             # everything that happened this tick

Inputs are checked before anything is updated; a wrong shape or length raises ``ValueError``
naming the field. Lists are accepted wherever arrays are.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from resilient_tracking.belief.ekf import ExtendedKalmanFilter
from resilient_tracking.belief.estimate import TargetEstimate
from resilient_tracking.belief.team_belief import TeamBelief
from resilient_tracking.build import make_policy, team_config
from resilient_tracking.events import Event
from resilient_tracking.observation import TeamObservation
from resilient_tracking.policies.base import Decision, Policy
from resilient_tracking.scenario import Scenario


@dataclass
class TeamStep:
    """The result of one tick: commands plus what happened in belief and planning."""

    #: (M, 2) velocity commands, within each robot's bounds
    controls: np.ndarray
    #: the policy's decision: per-robot modes, the league plans, planning time
    decision: Decision
    #: every event of the tick, in order: attacks and recoveries observed, league merges and
    #: splits, covariance repairs, zones learned (clue, broadcast, inference), solver fallbacks
    events: list[Event] = field(default_factory=list)


def _initial_means(value: object, n_targets: int) -> np.ndarray:
    """``(N, 4)`` ``[px, py, vx, vy]`` or ``(N, 2)`` positions (velocities 0), lists accepted."""
    try:
        means = np.array(value, dtype=float)
    except (TypeError, ValueError) as err:
        raise ValueError(f"initial_means: not an array of numbers ({err})") from None
    if means.ndim != 2 or means.shape[1] not in (2, 4):
        raise ValueError(
            f"initial_means: expected shape (N, 4) [px, py, vx, vy] or (N, 2) positions, "
            f"got {means.shape}"
        )
    if means.shape[0] != n_targets:
        raise ValueError(
            f"initial_means: the scenario has {n_targets} targets, got {means.shape[0]} rows"
        )
    if not np.all(np.isfinite(means)):
        raise ValueError("initial_means: must be finite")
    if means.shape[1] == 2:
        means = np.column_stack([means, np.zeros_like(means)])
    return means


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
            silent_robot_watch=policy.silent_robot_watch,
        )
        self.n_targets = int(initial_estimate.mean.shape[0])
        #: channels of one measurement of the team's sensor (its ``DIM``)
        self.measurement_dim = config.sensor.DIM

    @classmethod
    def from_scenario(
        cls, scenario: Scenario, initial_means: object, policy: str | None = None
    ) -> Team:
        """A team for a scenario's robots and sensors, starting from the targets' means, an
        ``(N, 4)`` array ``[px, py, vx, vy]`` or ``(N, 2)`` positions (lists accepted), with the
        scenario's declared initial uncertainty."""
        means = _initial_means(initial_means, len(scenario.targets))
        spec = scenario.estimator
        config = team_config(scenario)
        return cls(
            make_policy(policy or scenario.policy.name, scenario, config),
            TargetEstimate.initial(means, spec.initial_position_std, spec.initial_velocity_std),
        )

    def step(self, obs: TeamObservation) -> TeamStep:
        """One tick: update belief with ``obs``, plan, return commands and every event."""
        if obs.n_robots != self.belief.n_robots:
            raise ValueError(
                f"TeamObservation.positions: the team has {self.belief.n_robots} robots, "
                f"got {obs.n_robots}"
            )
        if obs.n_targets != self.n_targets:
            raise ValueError(
                f"TeamObservation.measurements: the team tracks {self.n_targets} targets, "
                f"got {obs.n_targets}"
            )
        if obs.measurement_dim != self.measurement_dim:
            raise ValueError(
                f"TeamObservation.measurements: the team's sensor measures "
                f"{self.measurement_dim} channel(s), got {obs.measurement_dim}"
            )
        events = [
            Event(
                obs.step,
                a.robot,
                "attack",
                f"{a.clue.kind} zone{a.clue.zone_id} "
                f"{'temporary' if a.cause == 'jamming' else a.clue.persistence} ({a.cause})",
            )
            for a in obs.attacks
        ]
        events += [Event(obs.step, robot, "recover", kind) for robot, kind in obs.recoveries]
        events += self.belief.update(obs)
        decision = self.policy.act(self.belief, obs)
        events += decision.events
        events += [
            Event(obs.step, robot, "zone_learned", f"{z.key} {z.kind} via {z.source}")
            for robot, z in self.belief.learned
        ]
        return TeamStep(controls=decision.controls, decision=decision, events=events)
