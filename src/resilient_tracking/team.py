"""``Team``: the robots' side of the loop, usable with or without the simulator.

Each tick it takes what real robots provide — a :class:`TeamObservation` with own positions,
measurements, failure flags, attack clues and link states — updates the team's belief and asks
the policy for velocity commands. The simulator drives this same object; a ROS 2 or
Crazyflie node can wrap it the same way (``docs/team-api.md`` has a complete, tested example)::

    team = Team.from_scenario(builtin_scenarios.load("mission.yaml"), initial_means)
    while running:
        step = team.step(TeamObservation(...))
        send(step.controls)          # (M, 2) velocities
        log(step.events)             # everything that happened this tick

Inputs are checked before anything is updated; a wrong shape or length raises ``ValueError``
naming the field. Lists are accepted wherever arrays are. The policy's decision is checked too
(:mod:`~resilient_tracking.policies.checks`): a robot whose control is not finite or breaks its
velocity bounds (every robot, when the controls are not an ``(M, 2)`` array of numbers) holds its
position instead, events or plans the run cannot record are dropped, each with an
``invalid_decision`` event naming the policy; the first one is logged as a warning.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from typing import NoReturn

import numpy as np

from resilient_tracking.belief.ekf import ExtendedKalmanFilter
from resilient_tracking.belief.estimate import TargetEstimate
from resilient_tracking.belief.estimator import Estimator
from resilient_tracking.belief.settings import BeliefSettings
from resilient_tracking.belief.team_belief import TeamBelief
from resilient_tracking.build import (
    make_estimator,
    make_policy,
    prior_estimate,
    team_config,
    zone_map,
)
from resilient_tracking.events import Event
from resilient_tracking.observation import TeamObservation
from resilient_tracking.planning.planner import FaultHook, LeaguePlanner
from resilient_tracking.policies.base import Decision, Policy
from resilient_tracking.policies.checks import DecisionProblem, decision_problems
from resilient_tracking.scenario import Scenario

log = logging.getLogger(__name__)


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
    """Belief plus policy for ``M`` robots tracking ``N`` targets.

    The belief starts from ``initial_estimate``, keeps what the policy declares it needs
    (:meth:`~resilient_tracking.policies.base.Policy.belief_needs`) with its own ``belief``
    settings (the scenario's ``belief`` section; defaults when ``None``) and estimates with
    ``estimator`` (default: the EKF of the team's target model and sensor).
    """

    def __init__(
        self,
        policy: Policy,
        initial_estimate: TargetEstimate,
        estimator: Estimator | None = None,
        belief: BeliefSettings | None = None,
    ):
        self.policy = policy
        #: the team's own description: robots, bounds, sensor (the policy's)
        self.config = config = policy.config
        self.belief = TeamBelief(
            n_robots=config.n_robots,
            initial=initial_estimate,
            estimator=estimator or ExtendedKalmanFilter(config.target_model, config.sensor),
            needs=policy.belief_needs(),
            settings=belief,
            dt=config.dt,
            sensor=config.sensor,
            comm_range=config.comm_range,
        )
        self.n_targets = int(initial_estimate.mean.shape[0])
        policy.check_targets(self.n_targets)
        #: channels of one measurement of the team's sensor (its ``DIM``)
        self.measurement_dim = config.sensor.DIM
        #: whether an invalid decision was logged as a warning (the first one is; later ones
        #: are events, logged at debug level)
        self._warned_invalid = False

    @classmethod
    def from_scenario(
        cls, scenario: Scenario, initial_means: object, policy: str | None = None
    ) -> Team:
        """A team for a scenario's robots and sensors, starting from the targets' means, an
        ``(N, 4)`` array ``[px, py, vx, vy]`` or ``(N, 2)`` positions (lists accepted), with the
        scenario's declared initial uncertainty and estimator and the zones it marks
        ``known``."""
        means = _initial_means(initial_means, len(scenario.targets))
        spec = scenario.estimator
        config = team_config(scenario)
        team = cls(
            make_policy(policy or scenario.policy.name, scenario, config),
            TargetEstimate.initial(means, spec.initial_position_std, spec.initial_velocity_std),
            make_estimator(scenario, config),
            scenario.belief,
        )
        team.belief.map_zones(zone_map(scenario))
        return team

    def step(self, obs: TeamObservation) -> TeamStep:
        """One tick: update belief with ``obs``, plan, return commands and every event."""
        return self.decide(obs, self.perceive(obs))

    def perceive(self, obs: TeamObservation) -> list[Event]:
        """The first half of a tick: check ``obs``, update the belief with it; return the
        tick's events so far (attacks and recoveries observed, then the belief's)."""
        shape = (self.belief.n_robots, self.n_targets, self.measurement_dim)
        if obs.measurements.shape != shape or len(obs.positions) != shape[0]:
            self._refuse(obs)
        events = [
            Event.attack(
                obs.step,
                a.robot,
                a.clue.kind,
                a.clue.zone_id,
                "temporary" if a.cause == "jamming" else a.clue.persistence,
                a.cause,
            )
            for a in obs.attacks
        ]
        events += [Event.recover(obs.step, robot, kind) for robot, kind in obs.recoveries]
        events += self.belief.update(obs)
        return events

    def _refuse(self, obs: TeamObservation) -> NoReturn:
        """Raise the ``ValueError`` naming what of ``obs`` does not fit the team."""
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
        raise ValueError(  # (the measurements' robots differ from the positions')
            f"TeamObservation.measurements: expected {self.belief.n_robots} robots' rows, "
            f"got {obs.measurements.shape[0]}"
        )

    def decide(
        self,
        obs: TeamObservation,
        events: list[Event],
        decision: Decision | None = None,
        valid: bool = False,
    ) -> TeamStep:
        """The second half of a tick, after :meth:`perceive` gave ``events``: the policy's
        decision (or ``decision``, made elsewhere, e.g. by a learning agent), checked like the
        policy's; returns the commands and every event of the tick. ``valid``: ``decision``
        is valid by construction (finite ``(M, 2)`` controls clipped to
        :meth:`~resilient_tracking.team_config.TeamConfig.velocity_bounds`, a mode per robot),
        so it is not checked again."""
        if decision is None:
            decision, valid = self.policy.act(self.belief, obs), False
        if not valid:
            controls, problems = decision_problems(decision, self.config, obs.positions)
            if problems:
                decision = self._contain(decision, controls, problems, obs)
        events = [*events, *decision.events]  # a tuple of events is fine too
        events += [
            Event.zone_learned(obs.step, robot, z.key, z.kind, z.source, z.zone_id, z.persistence)
            for robot, z in self.belief.learned
        ]
        return TeamStep(controls=decision.controls, decision=decision, events=events)

    def _contain(
        self,
        decision: object,
        controls: np.ndarray | None,
        problems: list[DecisionProblem],
        obs: TeamObservation,
    ) -> Decision:
        """The decision with every robot whose control is wrong holding position (zero velocity,
        always within bounds), without its events or plans when they cannot be recorded, and an
        ``invalid_decision`` event per problem and robot."""
        m, name = obs.n_robots, getattr(self.policy, "name", type(self.policy).__name__)
        held = {p.robot for p in problems if p.robot is not None}
        if controls is None:  # no usable controls at all
            held = set(range(m))
        safe = np.zeros((m, 2)) if controls is None else controls.copy()
        safe[sorted(held)] = 0.0
        given = decision if isinstance(decision, Decision) else Decision(safe, [])
        modes = list(given.modes) if isinstance(given.modes, list | tuple) else []
        if len(modes) != m or not all(isinstance(x, str) for x in modes):
            modes = [name] * m
        for i in held:
            modes[i] = "hold"
        kinds = {p.kind for p in problems}  # events or plans a run cannot record are dropped
        events = [] if "events" in kinds else list(given.events)
        plans = [] if "plans" in kinds else list(given.plans)
        contained = Decision(safe, modes, events=events, plans=plans)
        for p in problems:
            for i in [p.robot] if p.robot is not None else range(m):
                contained.events.append(
                    Event.invalid_decision(obs.step, i, name, p.kind, p.message)
                )
        log.log(
            logging.DEBUG if self._warned_invalid else logging.WARNING,
            "step %d: policy %s: %s; %s%s",
            obs.step,
            name,
            "; ".join(p.message for p in problems[:3]),
            f"robots {sorted(held)} hold position" if held else "no robot holds",
            ""
            if self._warned_invalid
            else " (every invalid decision is an invalid_decision "
            "event; later ones are logged at debug level)",
        )
        self._warned_invalid = True
        return contained


def build_team(
    scenario: Scenario,
    policy_name: str,
    seed: int,
    initial_targets: np.ndarray,
    fault_hook: FaultHook | None = None,
) -> Team:
    """The team of an episode: policy, planner, the seeded prior around ``initial_targets`` and
    the scenario's hazard map. Free of truth: given the targets' starting states, a simulated
    episode and a node on robots build the same team."""
    config = team_config(scenario)
    planner = LeaguePlanner.from_spec(scenario.planner, fault_hook=fault_hook)
    planner.prepare_team(len(scenario.robots), len(scenario.targets), config.sensor)
    team = Team(
        make_policy(policy_name, scenario, config, planner),
        prior_estimate(scenario, initial_targets, seed),
        make_estimator(scenario, config),
        scenario.belief,
    )
    team.belief.map_zones(zone_map(scenario))
    return team
