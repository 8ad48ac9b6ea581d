"""The episode loop: the only place where truth (world) and belief (team) meet.

Per step ``k`` (:class:`EpisodeStepper`, which :func:`run_episode` drives and the learning
environments of :mod:`resilient_tracking.env` share): the world is observed and the team updates
its belief (:meth:`EpisodeStepper.sense`); then (:meth:`EpisodeStepper.act`) the team decides,
by its policy or with a decision made elsewhere, the step's rows are recorded (the team's by a
:class:`~resilient_tracking.runs.team_recorder.TeamRecorder`, truth at ``k`` against the team's
estimate at ``k`` by a :class:`~resilient_tracking.runs.truth_recorder.TruthRecorder`), and the
world advances with the commands. Each step's numbers are checked to be finite
(:func:`check_finite`): a run that meets NaN or infinity stops with :class:`NonFiniteError`
naming the quantity and the step, so no table ever holds one.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from resilient_tracking.belief.estimate import TargetEstimate
from resilient_tracking.build import prior_estimate
from resilient_tracking.events import Event
from resilient_tracking.models.numpy_twins import all_finite
from resilient_tracking.observation import TeamObservation
from resilient_tracking.planning import codegen, codegen_status
from resilient_tracking.planning.planner import FaultHook
from resilient_tracking.plugin_guard import contained
from resilient_tracking.policies.base import Decision
from resilient_tracking.runs.bound import PositionBound
from resilient_tracking.runs.manifest import episode_manifest
from resilient_tracking.runs.metrics import mse
from resilient_tracking.runs.records import EpisodeResult, join_tables
from resilient_tracking.runs.team_recorder import TeamRecorder
from resilient_tracking.runs.truth_recorder import TruthRecorder
from resilient_tracking.scenario import Scenario
from resilient_tracking.team import TeamStep, build_team
from resilient_tracking.world import World
from resilient_tracking.world.targets import TargetTruth
from resilient_tracking.world.world import make_zones
from resilient_tracking.world.zones import TrueZone

log = logging.getLogger(__name__)


class NonFiniteError(ArithmeticError):
    """An episode met a number that is not finite; the message names the quantity and the step.

    The bounds of the scenario schema keep every run finite; this stops one that is not anyway
    (a plug-in's motion or sensor, a numerical bug) before a table holds NaN or infinity."""


#: What :meth:`EpisodeStepper.act` checks each step, by name, in order.
_CHECKED = (
    "a robot's position",
    "a robot's applied control",
    "a target's true state",
    "the team's target estimate",
    "the team's target covariance",
    "the MSE of the team's estimate",
)


def check_finite(step: int, quantities: dict[str, Any]) -> None:
    """Raise :class:`NonFiniteError` naming the first of ``quantities`` (name: number or
    array) that holds a number that is not finite."""
    for name, value in quantities.items():
        finite = math.isfinite(value) if isinstance(value, float) else all_finite(np.asarray(value))
        if not finite:
            raise NonFiniteError(f"step {step}: {name} is not finite")


def initial_estimate(scenario: Scenario, world: World, seed: int) -> TargetEstimate:
    """The team's prior: truth perturbed by the declared initial uncertainty (own stream)."""
    return prior_estimate(scenario, world.target_states, seed)


def start_truth(scenario: Scenario, seed: int) -> tuple[np.ndarray, list[TrueZone]]:
    """The targets' starting states (N, 4) and the zones with their drawn centres, as an episode
    of ``scenario`` at ``seed`` starts: what a node on robots is given for its prior and for
    the plots, so that its run can equal the simulated one."""
    states = np.array([TargetTruth(t).state for t in scenario.targets])
    return states, make_zones(scenario, seed)


class EpisodeStepper:
    """One episode, a step at a time: the world, the team, and the records of both.

    Each step is :meth:`sense` (the world is observed, the team's belief takes it in), then
    :meth:`act` (the team's decision, recorded, then the world advances); :func:`run_episode`
    alternates the two ``scenario.steps`` times, and :meth:`result` gives its tables."""

    def __init__(
        self,
        scenario: Scenario,
        policy: str,
        seed: int,
        fault_hook: FaultHook | None = None,
        record: bool = True,
        bound: bool = False,
    ):
        self.scenario = scenario
        self.policy_name = policy
        self.seed = seed
        #: whether compiled code is on, decided before the episode (a cache that cannot be
        #: used turns it off here, with one warning; a setting not allowed raises)
        self.compiled_code = codegen.prepare()
        self._codegen_mark = codegen_status.mark()
        self.world = World(scenario, seed)
        self.team = build_team(scenario, policy, seed, self.world.target_states, fault_hook)
        n_targets = len(self.world.targets)
        #: the recorders of the team's rows and of truth's (``None`` when not recording)
        self.rows = (
            (
                TeamRecorder(self.world.n_robots, n_targets, scenario.steps),
                TruthRecorder(n_targets, scenario.steps, self.world.zones),
            )
            if record
            else None
        )
        #: the posterior Cramér–Rao bound, step by step, when asked (and recording)
        self.bound = position_bound(scenario, self.world) if bound and record else None
        self._bound_now: float | None = None
        #: the MSE of the team's estimate at the last step acted (NaN before the first)
        self.last_mse = float("nan")
        #: steps acted (and recorded) so far
        self.steps_done = 0
        #: the observation of the current step, once sensed
        self.obs: TeamObservation | None = None
        self._truth: np.ndarray | None = None
        self._events: list[Event] = []

    @property
    def record(self) -> bool:
        """Whether each step's rows are recorded (``False``: no tables, for a caller that reads
        none, such as a learning environment that never renders)."""
        return self.rows is not None

    def sense(self) -> TeamObservation:
        """Observe the world at the current step and update the team's belief with it."""
        self.obs = obs = self.world.observe()
        self._truth = truth = self.world.target_states
        truth_events = self.world.take_truth_events()
        if self.rows is not None and truth_events:
            self.rows[1].record_events(truth_events)
        if self.bound is not None:
            world = self.world
            factors = np.array([world.degradations.noise_factor(i) for i in range(obs.n_robots)])
            measured = np.asarray(~np.isnan(obs.measurements).any(axis=2))
            self._bound_now = self.bound.step(obs.positions, measured, factors, truth[:, :2])
        self._events = self.team.perceive(obs)
        return obs

    def act(self, decision: Decision | None = None, valid: bool = False) -> TeamStep:
        """The team's decision for the sensed step (its policy's, or ``decision``: checked,
        unless ``valid`` by construction, see :meth:`~resilient_tracking.team.Team.decide`),
        recorded; then the world advances with its commands."""
        obs, truth = self.obs, self._truth
        if obs is None or truth is None:
            raise RuntimeError("EpisodeStepper.act: sense the step first")
        out = self.team.decide(obs, self._events, decision, valid)
        applied = self.world.step(out.controls)
        estimate = self.team.belief.team_estimate()
        if self.rows is not None:
            team_rows, truth_rows = self.rows
            team_rows.step(obs, out, applied, self.team.belief)
            truth_rows.step(
                obs.step,
                truth[:, :2],
                estimate.mean[:, :2],
                estimate.cov[:, :2, :2],
                self._bound_now,
            )
            self.last_mse = float(truth_rows.team.last("mse"))
        else:
            self.last_mse = mse(estimate.mean[:, :2], truth[:, :2])
        arrays = (obs.positions, applied, truth, estimate.mean, estimate.cov)
        if not (math.isfinite(self.last_mse) and all(map(all_finite, arrays))):
            check_finite(obs.step, dict(zip(_CHECKED, (*arrays, self.last_mse), strict=True)))
        self.obs, self._truth, self._events = None, None, []
        self.steps_done += 1
        return out

    def result(self, wall: float = float("nan")) -> EpisodeResult:
        """The tables of the steps acted so far, with the manifest (``wall``: seconds taken)."""
        if self.rows is None:
            raise RuntimeError("this episode records no tables (record=False)")
        compiled = {
            "on": self.compiled_code,
            "failures": codegen_status.failures_since(self._codegen_mark),
        }
        manifest = episode_manifest(
            self.scenario, self.seed, self.policy_name, self.steps_done, wall, compiled
        )
        team_rows, truth_rows = self.rows
        return EpisodeResult(join_tables(team_rows.tables(), truth_rows.tables()), manifest)


def position_bound(scenario: Scenario, world: World) -> PositionBound:
    """The posterior Cramér–Rao bound of an episode of ``scenario`` in ``world``
    (:mod:`~resilient_tracking.runs.bound`), with the team's prior and estimator model."""
    spec = scenario.estimator
    return PositionBound(
        world.sensor,
        scenario.dt,
        [t.motion for t in scenario.targets],
        spec.accel_std,
        spec.initial_position_std,
        spec.initial_velocity_std,
    )


def run_episode(
    scenario: Scenario,
    policy: str | None = None,
    seed: int | None = None,
    progress: Callable[[int], object] | None = None,
    fault_hook: FaultHook | None = None,
    bound: bool = False,
) -> EpisodeResult:
    """Run one episode; ``progress`` is called with the number of steps done.

    ``fault_hook`` is handed to the planner (see :mod:`resilient_tracking.planning.faults`);
    ``bound``: also compute the posterior Cramér–Rao bound (the ``bound`` table, else
    empty). A plug-in that exits or raises anything but an ``Exception`` or an interrupt
    fails the run with :class:`~resilient_tracking.plugin_guard.PluginError` naming it.
    """
    seed = scenario.seed if seed is None else seed
    policy_name = policy or scenario.policy.name
    started = time.perf_counter()
    with contained("while running"):
        stepper = EpisodeStepper(scenario, policy_name, seed, fault_hook, bound=bound)
        for _ in range(scenario.steps):
            stepper.sense()
            stepper.act()
            if progress is not None:
                progress(1)
    wall = time.perf_counter() - started
    log.info(
        "episode %s/%s seed %d: %d steps in %.2f s",
        scenario.name,
        policy_name,
        seed,
        scenario.steps,
        wall,
    )
    return stepper.result(wall)
