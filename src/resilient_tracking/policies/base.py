"""The policy contract: belief and observation in, velocity commands out."""

from __future__ import annotations

import logging
from abc import ABC, abstractmethod
from dataclasses import dataclass, field, replace

import numpy as np

from resilient_tracking.belief.team_belief import TeamBelief
from resilient_tracking.events import Event
from resilient_tracking.observation import TeamObservation
from resilient_tracking.planning.goals import keep_out_discs, route_rows
from resilient_tracking.planning.layout import ProblemInputs, Weight, comm_table, sensing_table
from resilient_tracking.planning.planner import LeaguePlanner, PlanResult
from resilient_tracking.planning.route import RouteMaps
from resilient_tracking.planning.safe_action import safe_action
from resilient_tracking.team_config import TeamConfig

log = logging.getLogger(__name__)


@dataclass
class Decision:
    """What a policy returns for one tick."""

    controls: np.ndarray  # (M, 2)
    modes: list[str]
    events: list[Event] = field(default_factory=list)
    plans: list[PlanResult] = field(default_factory=list)

    @property
    def plan_ms(self) -> float:
        return float(sum(p.solve_ms for p in self.plans))


class Policy(ABC):
    """Decides velocities from belief; ``learns_zones`` says whether the team keeps zone
    knowledge at all (the vanilla team does not)."""

    name: str = "policy"
    learns_zones: bool = True

    def __init__(self, config: TeamConfig, planner: LeaguePlanner | None = None):
        self.config = config
        self.planner = planner or LeaguePlanner()
        #: route maps of the known keep-out regions, reused while knowledge is unchanged
        self.route_maps = RouteMaps(config.lower, config.upper)

    @abstractmethod
    def act(self, belief: TeamBelief, obs: TeamObservation) -> Decision: ...

    # ------------------------------------------------------------------ shared helpers

    def tracking_inputs(
        self,
        belief: TeamBelief,
        obs: TeamObservation,
        robots: list[int],
        league: int,
        weights: np.ndarray,
        sensing: np.ndarray,
        sensing_zones: np.ndarray | None = None,
        comm_zones: np.ndarray | None = None,
        with_route: bool = True,
    ) -> ProblemInputs:
        """Numeric inputs of a league problem: predicted targets, bounds, zones, and with the
        route program each robot's route row."""
        sensing_zones = sensing_table() if sensing_zones is None else sensing_zones
        comm_zones = comm_table() if comm_zones is None else comm_zones
        predicted = belief.ekf.predict(belief.estimates[league])
        lower, upper = self.config.velocity_bounds(robots, obs.positions)
        q = ProblemInputs(
            positions=obs.positions[robots],
            sensing=sensing.astype(float),
            targets=predicted.mean[:, :2],
            prior_info=np.linalg.inv(predicted.cov[:, :2, :2]),
            weights=weights,
            sensor=self.config.sensor.parameters,
            dt=self.config.dt,
            u_lower=lower,
            u_upper=upper,
            sensing_zones=sensing_zones,
            comm_zones=comm_zones,
            sensor_model=type(self.config.sensor),
        )
        route = self.planner.route
        if route is None or not with_route:  # the one-step program, or a program of its own
            return q
        positions = obs.positions[robots]
        discs = keep_out_discs(sensing_zones, comm_zones, _mean_spacing(positions))
        q.route = route_rows(
            positions,
            sensing,
            predicted.mean[:, :2],
            predicted.mean[:, 2:4],
            self.route_maps.get(discs),
            self.config.u_max[robots],
            float(weights[Weight.EFFORT]),
            self.config.dt,
            route,
        )
        q.standoff = route.standoff
        return q

    def solve(
        self, robots: list[int], q: ProblemInputs, step: int, decision: Decision
    ) -> np.ndarray:
        """Plan for ``robots``; record the result and any fallback in ``decision``.

        When no solver attempt succeeded (or the planner itself failed), the robots take the
        :func:`~resilient_tracking.planning.safe_action.safe_action`: escape a known zone whose
        constraint they violate, else hold. Every fallback is an event per robot.
        """
        try:
            result = self.planner.plan(q.structure(), tuple(robots), q)
        except Exception as err:  # the ladder must hold even if the planner breaks
            log.warning("league %s: planner raised %s: %s", robots, type(err).__name__, err)
            result = PlanResult(
                controls=np.zeros((len(robots), 2)),
                status=f"planner exception: {type(err).__name__}",
                success=False,
                iterations=0,
                solve_ms=0.0,
                fallback="safe",
            )
        controls = result.controls
        if not result.success or not np.all(np.isfinite(controls)):
            controls, actions = safe_action(q)
            result = replace(result, controls=controls, success=False, fallback="safe")
            for i, action in zip(robots, actions, strict=True):
                decision.events.append(
                    Event(step, i, "solver_fallback", f"safe ({action}): {result.status}")
                )
        elif result.fallback:
            for i in robots:
                decision.events.append(
                    Event(step, i, "solver_fallback", f"{result.fallback}: {result.status}")
                )
        decision.plans.append(result)
        return controls


def _mean_spacing(positions: np.ndarray) -> float:
    """Mean distance (m) from each robot to its nearest teammate (0 for a robot alone)."""
    if len(positions) < 2:
        return 0.0
    gaps = np.linalg.norm(positions[:, None, :] - positions[None, :, :], axis=2)
    np.fill_diagonal(gaps, np.inf)
    return float(np.mean(gaps.min(axis=1)))
