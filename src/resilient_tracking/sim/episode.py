"""The episode loop: the only place where truth (world) and belief (team) meet.

Per step ``k``: the world is observed, the team updates its belief and plans, the step's
rows are recorded (the team's by a :class:`~resilient_tracking.runs.team_recorder.TeamRecorder`,
truth at ``k`` against the team's estimate at ``k`` by a
:class:`~resilient_tracking.runs.truth_recorder.TruthRecorder`), then the world advances with
the commands. Each step's numbers are checked to be finite (:func:`check_finite`): a run that
meets NaN or infinity stops with :class:`NonFiniteError` naming the quantity and the step, so
no table ever holds one.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from resilient_tracking.belief.estimate import TargetEstimate
from resilient_tracking.build import prior_estimate
from resilient_tracking.planning.planner import FaultHook
from resilient_tracking.runs.manifest import episode_manifest
from resilient_tracking.runs.records import EpisodeResult, join_tables
from resilient_tracking.runs.team_recorder import TeamRecorder
from resilient_tracking.runs.truth_recorder import TruthRecorder
from resilient_tracking.scenario import Scenario
from resilient_tracking.team import build_team
from resilient_tracking.world import World
from resilient_tracking.world.targets import TargetTruth
from resilient_tracking.world.world import make_zones
from resilient_tracking.world.zones import TrueZone

log = logging.getLogger(__name__)


class NonFiniteError(ArithmeticError):
    """An episode met a number that is not finite; the message names the quantity and the step.

    The bounds of the scenario schema keep every run finite; this stops one that is not anyway
    (a plug-in's motion or sensor, a numerical bug) before a table holds NaN or infinity."""


def check_finite(step: int, quantities: dict[str, Any]) -> None:
    """Raise :class:`NonFiniteError` naming the first of ``quantities`` (name: number or
    array) that holds a number that is not finite."""
    for name, value in quantities.items():
        if not np.isfinite(value).all():
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


def run_episode(
    scenario: Scenario,
    policy: str | None = None,
    seed: int | None = None,
    progress: Callable[[int], object] | None = None,
    fault_hook: FaultHook | None = None,
) -> EpisodeResult:
    """Run one episode; ``progress`` is called with the number of steps done.

    ``fault_hook`` is handed to the planner (see :mod:`resilient_tracking.planning.faults`).
    """
    seed = scenario.seed if seed is None else seed
    policy_name = policy or scenario.policy.name
    started = time.perf_counter()
    world = World(scenario, seed)
    team = build_team(scenario, policy_name, seed, world.target_states, fault_hook)
    team_rows = TeamRecorder(world.n_robots, len(world.targets), scenario.steps)
    truth_rows = TruthRecorder(len(world.targets), scenario.steps, world.zones)
    for _ in range(scenario.steps):
        obs = world.observe()
        truth = world.target_states
        out = team.step(obs)
        applied = world.step(out.controls)
        team_rows.step(obs, out, applied, team.belief)
        estimate = team.belief.team_estimate()
        truth_rows.step(obs.step, truth[:, :2], estimate.mean[:, :2])
        check_finite(
            obs.step,
            {
                "a robot's position": obs.positions,
                "a robot's applied control": applied,
                "a target's true state": truth,
                "the team's target estimate": estimate.mean,
                "the team's target covariance": estimate.cov,
                "the MSE of the team's estimate": truth_rows.team.last("mse"),
            },
        )
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
    manifest = episode_manifest(scenario, seed, policy_name, scenario.steps, wall)
    return EpisodeResult(join_tables(team_rows.tables(), truth_rows.tables()), manifest)
