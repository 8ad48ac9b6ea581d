"""The episode loop: the only place where truth (world) and belief (team) meet.

Per step ``k``: the world is observed, the team updates its belief and plans, the step's
metrics are recorded (truth at ``k`` against the team's estimate at ``k``), then the world
advances with the commands.
"""

from __future__ import annotations

import logging
import platform
import time
from collections.abc import Callable
from typing import Any

import casadi
import numpy as np

from resilient_tracking import __version__
from resilient_tracking.belief.estimate import TargetEstimate
from resilient_tracking.build import make_policy, team_config, zone_map
from resilient_tracking.events import Event
from resilient_tracking.observation import TeamObservation
from resilient_tracking.planning.planner import FaultHook, LeaguePlanner
from resilient_tracking.rng import stream
from resilient_tracking.scenario import Scenario
from resilient_tracking.sim.kernels import numeric_kernels
from resilient_tracking.sim.metrics import effort, mse
from resilient_tracking.sim.records import ColumnTable, EpisodeResult, frame
from resilient_tracking.team import Team, TeamStep
from resilient_tracking.world import World
from resilient_tracking.world.zones import TrueZone

log = logging.getLogger(__name__)


def initial_estimate(scenario: Scenario, world: World, seed: int) -> TargetEstimate:
    """The team's prior: truth perturbed by the declared initial uncertainty (own stream)."""
    return prior_estimate(scenario, world.target_states, seed)


def prior_estimate(scenario: Scenario, truth: np.ndarray, seed: int) -> TargetEstimate:
    """The prior around the targets' starting states ``truth`` (N, 4), seeded like an episode."""
    spec = scenario.estimator
    std = np.array([spec.initial_position_std] * 2 + [spec.initial_velocity_std] * 2)
    noise = stream(seed, "estimator_init").standard_normal(truth.shape) * std
    return TargetEstimate.initial(
        truth + noise, spec.initial_position_std, spec.initial_velocity_std
    )


INT, FLOAT, BOOL = np.int64, np.float64, np.bool_


def build_team(
    scenario: Scenario,
    policy_name: str,
    seed: int,
    initial_targets: np.ndarray,
    fault_hook: FaultHook | None = None,
) -> Team:
    """The team of an episode: policy, planner, the seeded prior around ``initial_targets`` and
    the scenario's hazard map (:func:`~resilient_tracking.build.zone_map`)."""
    config = team_config(scenario)
    planner = LeaguePlanner.from_spec(scenario.planner, fault_hook=fault_hook)
    policy_obj = make_policy(policy_name, scenario, config, planner)
    team = Team(policy_obj, prior_estimate(scenario, initial_targets, seed))
    team.belief.map_zones(zone_map(scenario))
    return team


class EpisodeRecorder:
    """Collects rows while the episode runs: the per-step tables as compact columns.

    Used by :func:`run_episode` and by anything else that steps a :class:`Team` (the ROS 2
    tracker node), so every run folder has the same tables. ``zones`` are the true zones, kept
    for plots only.
    """

    def __init__(self, n_robots: int, n_targets: int, zones: list[TrueZone], steps: int):
        self.team = ColumnTable(
            {
                "step": INT,
                "time": FLOAT,
                "mse": FLOAT,
                "trace": FLOAT,
                "effort": FLOAT,
                "n_sensing_failed": INT,
                "n_comm_failed": INT,
                "n_leagues": INT,
                "n_solves": INT,
                "n_solver_failures": INT,
                "solver_iterations": INT,
            },
            steps,
        )
        self.robots = ColumnTable(
            {
                "step": INT,
                "robot": INT,
                "x": FLOAT,
                "y": FLOAT,
                "ux": FLOAT,
                "uy": FLOAT,
                "sensing_ok": BOOL,
                "comm_ok": BOOL,
                "league": INT,
                "mode": object,
            },
            steps * n_robots,
        )
        self.targets = ColumnTable(
            {
                "step": INT,
                "target": INT,
                "x": FLOAT,
                "y": FLOAT,
                "est_x": FLOAT,
                "est_y": FLOAT,
                "var_x": FLOAT,
                "var_y": FLOAT,
            },
            steps * n_targets,
        )
        self.timing = ColumnTable({"step": INT, "plan_ms": FLOAT}, steps)
        self.events: list[dict[str, Any]] = []
        self.knowledge: list[dict[str, Any]] = []
        self.zones = [
            {
                "zone": z.id,
                "name": z.spec.name or f"{z.kind[0].upper()}{z.id}",
                "kind": z.kind,
                "persistence": z.spec.persistence,
                "mu_x": z.mu[0],
                "mu_y": z.mu[1],
                "sigma_xx": z.sigma[0, 0],
                "sigma_xy": z.sigma[0, 1],
                "sigma_yy": z.sigma[1, 1],
                "size": z.size,
                "true_x": z.center[0],
                "true_y": z.center[1],
            }
            for z in zones
        ]

    def event(self, e: Event) -> None:
        """Record one event row: step, robot, event and detail."""
        self.events.append({"step": e.step, "robot": e.robot, "event": e.event, "detail": e.detail})

    def step(
        self,
        obs: TeamObservation,
        out: TeamStep,
        applied: np.ndarray,
        truth: np.ndarray,
        team: Team,
    ) -> None:
        """Record one tick: its events and the zones learned, the team row (MSE, trace, effort,
        failures, leagues, solver counts), its planning time, and one row per robot and per target
        (truth, estimate and variances)."""
        k = obs.step
        belief = team.belief
        for e in out.events:  # every event of the tick, attacks and learned zones included
            self.event(e)
        for robot, z in belief.learned:
            self.knowledge.append(
                {
                    "step": k,
                    "robot": robot,
                    "zone": z.zone_id if z.zone_id is not None else -1,
                    "kind": z.kind,
                    "source": z.source,
                    "x": z.mean[0],
                    "y": z.mean[1],
                    "sigma_xx": z.cov[0, 0],
                    "sigma_xy": z.cov[0, 1],
                    "sigma_yy": z.cov[1, 1],
                    "size": z.size,
                }
            )
        est = belief.team_estimate()
        plans = out.decision.plans
        self.team.append_row(
            step=k,
            time=obs.time,
            mse=mse(est.mean[:, :2], truth[:, :2]),
            trace=est.position_trace(),
            effort=effort(applied),
            n_sensing_failed=len(obs.sensing_ok) - int(np.count_nonzero(obs.sensing_ok)),
            n_comm_failed=len(obs.comm_ok) - int(np.count_nonzero(obs.comm_ok)),
            n_leagues=len(belief.leagues),
            n_solves=len(plans),
            n_solver_failures=sum(not p.success for p in plans),
            solver_iterations=sum(p.iterations for p in plans),
        )
        self.timing.append_row(step=k, plan_ms=out.decision.plan_ms)
        n = obs.n_robots
        self.robots.append(
            n,
            step=k,
            robot=np.arange(n),
            x=obs.positions[:, 0],
            y=obs.positions[:, 1],
            ux=applied[:, 0],
            uy=applied[:, 1],
            sensing_ok=obs.sensing_ok,
            comm_ok=obs.comm_ok,
            league=belief.league_of,
            mode=out.decision.modes,
        )
        var = np.diagonal(est.cov, axis1=1, axis2=2)
        self.targets.append(
            len(truth),
            step=k,
            target=np.arange(len(truth)),
            x=truth[:, 0],
            y=truth[:, 1],
            est_x=est.mean[:, 0],
            est_y=est.mean[:, 1],
            var_x=var[:, 0],
            var_y=var[:, 1],
        )

    def result(self, manifest: dict[str, Any]) -> EpisodeResult:
        """The recorded tables, with ``manifest``, as an :class:`EpisodeResult`."""
        tables = {
            "team": self.team.frame(),
            "robots": self.robots.frame(),
            "targets": self.targets.frame(),
            "events": frame(self.events, "events"),
            "zones": frame(self.zones, "zones"),
            "knowledge": frame(self.knowledge, "knowledge"),
            "timing": self.timing.frame(),
        }
        return EpisodeResult(tables=tables, manifest=manifest)


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
    recorder = EpisodeRecorder(world.n_robots, len(world.targets), world.zones, scenario.steps)
    for _ in range(scenario.steps):
        obs = world.observe()
        truth = world.target_states
        out = team.step(obs)
        applied = world.step(out.controls)
        recorder.step(obs, out, applied, truth, team)
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
    return recorder.result(episode_manifest(scenario, seed, policy_name, scenario.steps, wall))


def episode_manifest(
    scenario: Scenario, seed: int, policy_name: str, steps: int, wall: float
) -> dict[str, Any]:
    """The manifest of a run folder: what ran, with which versions, how long it took."""
    return {
        "scenario": scenario.model_dump(mode="json"),
        "seed": seed,
        "policy": policy_name,
        "version": __version__,
        "casadi": casadi.CasadiMeta.version(),
        "numpy": np.__version__,
        "kernels": numeric_kernels(),
        "python": platform.python_version(),
        "steps": steps,
        "wall_time_s": round(wall, 3),
    }
