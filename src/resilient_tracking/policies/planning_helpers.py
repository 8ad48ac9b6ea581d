"""League-planning helpers for policies that solve the paper's league NLP (docs/model.md §5).

:class:`PlanningPolicy` adds to the :class:`~resilient_tracking.policies.base.Policy` contract a
:class:`~resilient_tracking.planning.planner.LeaguePlanner` and two helpers: the numeric inputs
of a league problem (:meth:`PlanningPolicy.tracking_inputs`) and the shared fallback path
(:meth:`PlanningPolicy.solve`, :meth:`PlanningPolicy.settle`): a plan that failed is replaced by
the safe action of the solver ladder's last rung, with an event per robot. A policy with a
program of its own (SOG) solves it itself and settles the result the same way.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from dataclasses import replace

import numpy as np
from pydantic import BaseModel

from resilient_tracking import interrupts
from resilient_tracking.belief.team_belief import TeamBelief
from resilient_tracking.events import Event
from resilient_tracking.observation import TeamObservation
from resilient_tracking.planning.goals import keep_out_discs, route_rows
from resilient_tracking.planning.layout import ProblemInputs, Weight, comm_table, sensing_table
from resilient_tracking.planning.plan_result import OVER_BUDGET
from resilient_tracking.planning.planner import LeaguePlanner, PlanResult
from resilient_tracking.planning.route import RouteMaps
from resilient_tracking.planning.safe_action import safe_action
from resilient_tracking.planning.spanning import spanning_unlinked
from resilient_tracking.policies.base import Decision, Policy
from resilient_tracking.policies.guards.settings import GuardsSpec
from resilient_tracking.team_config import TeamConfig

log = logging.getLogger(__name__)


class PlanningPolicy(Policy):
    """A policy that plans each league with a :class:`LeaguePlanner`."""

    def __init__(
        self,
        config: TeamConfig,
        params: BaseModel | None = None,
        planner: LeaguePlanner | None = None,
    ):
        super().__init__(config, params)
        #: solves the league problems (the scenario's program and solver ladder)
        self.planner = planner or LeaguePlanner()
        #: route maps of the known keep-out regions, reused while knowledge is unchanged
        self.route_maps = RouteMaps(config.lower, config.upper)

    @classmethod
    def build(
        cls,
        config: TeamConfig,
        params: BaseModel,
        planner: LeaguePlanner | None = None,
        guards: GuardsSpec | None = None,
    ) -> Policy:
        """The policy with the scenario's league planner (``guards`` are the failure-aware
        policy's)."""
        return cls(config, params, planner)

    def planning_order(self, leagues: Sequence[Sequence[int]]) -> list[int]:
        """The order in which the leagues are planned this step: as listed; running free
        against a deadline (:attr:`LeaguePlanner.deadline`), the smaller leagues first. A
        league of at most one sub-team window is always planned, whatever the deadline, so
        planned first it cannot push the step past it; the large league, whose sub-teams stop
        at the deadline, then takes the time that is left."""
        order = list(range(len(leagues)))
        if self.planner.deadline is None:
            return order
        return sorted(order, key=lambda k: len(leagues[k]))

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
        predicted = belief.predicted(league)
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
        if self.planner.skips(len(robots)):  # past the deadline: the league coasts or holds
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
        if route.links == "spanning" and len(comm_zones):
            q.unlinked = spanning_unlinked(positions)
        return q

    def solve(
        self, robots: list[int], q: ProblemInputs, step: int, decision: Decision
    ) -> np.ndarray:
        """Plan the league problem ``q`` for ``robots`` and settle the result (see
        :meth:`settle`)."""
        return self.settle(
            lambda: self.planner.plan(q.structure(), tuple(robots), q), robots, q, step, decision
        )

    def settle(
        self,
        plan: Callable[[], PlanResult],
        robots: list[int],
        safe: ProblemInputs,
        step: int,
        decision: Decision,
    ) -> np.ndarray:
        """Run ``plan``; record the result and any fallback in ``decision``; return controls.

        When no solver attempt succeeded (or the planner itself failed), the robots take the
        :func:`~resilient_tracking.planning.safe_action.safe_action` of ``safe`` (the known
        zones as league rows): escape a known zone whose constraint they violate, else hold.
        A league planned as sub-teams where only some sub-teams failed keeps the others'
        plans (:attr:`PlanResult.safe`). Every fallback is an event per robot.
        """
        try:
            result = plan()
        except Exception as err:  # the ladder must hold even if the planner breaks
            interrupts.reraise(err)
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
        if not np.isfinite(controls).all() or (not result.success and not result.safe):
            controls, actions = safe_action(safe)
            result = replace(result, controls=controls, success=False, fallback="safe")
            for i, action in zip(robots, actions, strict=True):
                decision.events.append(
                    Event.solver_fallback(step, i, "safe", result.status, action)
                )
        elif result.safe:  # some sub-teams failed and took the safe action, the rest planned
            for i, action in result.safe:
                decision.events.append(
                    Event.solver_fallback(step, i, "safe", result.status, action)
                )
        elif result.fallback:
            for i in robots:
                decision.events.append(
                    Event.solver_fallback(step, i, result.fallback, result.status)
                )
        for i in result.held if result.success or result.safe else ():
            decision.events.append(Event.solver_fallback(step, i, "budget", OVER_BUDGET))
        decision.plans.append(result)
        return controls


def _mean_spacing(positions: np.ndarray) -> float:
    """Mean distance (m) from each robot to its nearest teammate (0 for a robot alone)."""
    if len(positions) < 2:
        return 0.0
    gaps = np.linalg.norm(positions[:, None, :] - positions[None, :, :], axis=2)
    np.fill_diagonal(gaps, np.inf)
    return float(np.mean(gaps.min(axis=1)))
