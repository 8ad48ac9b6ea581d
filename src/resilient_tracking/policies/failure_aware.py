"""Failure-aware coordination: the paper's Algorithm 1 (docs/model.md §6).

Per league, every tick:

* a robot alone with a **permanent comm failure** enters CircularEvasionMode: it abandons
  tracking and circles its estimated attacker, a signal teammates can read (Alg. 4);
* a robot **alone** for any other reason plans by itself (IndividualAdaptation) with the safe
  weights, its own knowledge and estimate, keeping clear of every zone it knows — known comm
  zones included, so an isolated robot escapes the jammer's influence and can recover;
* a **league** plans jointly (CentralizedAdaptation) with weights interpolated between risky
  and safe by the fraction of attacked robots (eq. 10), ``r_safe = r + w5``; robots that lost
  their sensor stay in the plan without a tracking term;
* for ``cooldown_steps`` after any temporary failure the whole team uses the cool-down weights.

League members also watch silent robots: a circle fitted to one's positions becomes a comm
zone estimate (Alg. 3) that the league avoids from then on. That learning happens in belief
(:mod:`resilient_tracking.belief.silent_robots`); the policy declares it needs it, with how its
robots circle (:meth:`FailureAwarePolicy.belief_needs`).
"""

from __future__ import annotations

from typing import cast

import numpy as np
from pydantic import BaseModel

from resilient_tracking.belief.knowledge import KnowledgeBase, ZoneEstimate
from resilient_tracking.belief.needs import BeliefNeeds, CircleReading
from resilient_tracking.belief.team_belief import TeamBelief
from resilient_tracking.observation import TeamObservation
from resilient_tracking.planning.adaptation import adaptive_weights, chance_margin
from resilient_tracking.planning.evasion import circle_velocity, evasion_radius
from resilient_tracking.planning.layout import (
    comm_row,
    comm_table,
    sensing_row,
    sensing_table,
)
from resilient_tracking.planning.planner import LeaguePlanner
from resilient_tracking.policies.base import Decision, Policy, register_policy
from resilient_tracking.policies.failure_aware_params import FailureAwareParams
from resilient_tracking.policies.guards import Guard, GuardsSpec
from resilient_tracking.policies.guards.base import LeagueRows
from resilient_tracking.policies.planning_helpers import PlanningPolicy
from resilient_tracking.team_config import TeamConfig

#: the sensing and the comm zone table of a league problem (``layout.SensingRow``, ``CommRow``),
#: the zone key of each sensing-table row, how many of those rows are sensing zones', and the
#: zone key of each comm-table row
ZoneRows = tuple[np.ndarray, np.ndarray, list[str], int, list[str]]


@register_policy("failure_aware")
class FailureAwarePolicy(PlanningPolicy):
    """The paper's method, Algorithm 1 (module docstring)."""

    name = "failure_aware"
    Params = FailureAwareParams
    learns_zones = True
    params: FailureAwareParams

    def __init__(
        self,
        config: TeamConfig,
        params: FailureAwareParams,
        planner: LeaguePlanner | None = None,
        guards: GuardsSpec | None = None,
    ):
        super().__init__(config, params, planner)
        self.beta1 = chance_margin(params.eps1)
        self.beta2 = chance_margin(params.eps2)
        #: the mechanisms beyond the paper this team uses (:mod:`~.guards`; the defaults' when
        #: ``guards`` is ``None``)
        self.guards: list[Guard] = (guards or GuardsSpec()).build(config, params)
        #: the team is in cool-down while ``step < cooldown_until``
        self.cooldown_until = -1
        #: the weights used at the last tick, ``[w1..w5]`` per robot (for inspection and tests)
        self.last_weights = np.zeros((config.n_robots, 5))
        #: the weights of each situation, computed once (the parameters are fixed at creation)
        self._weights: dict[tuple[bool, bool, float, int], np.ndarray] = {}
        #: the last zone rows made: the zones they came from, what else they depend on, the rows
        self._last_rows: tuple[tuple[ZoneEstimate, ...], tuple[object, ...], ZoneRows] | None = None
        #: ``β`` of each risk level, computed once
        self._margins: dict[float, float] = {}
        #: circling direction (1 counter-clockwise, −1 clockwise) of each robot in Alg. 4
        self._circling: dict[int, float] = {}

    @classmethod
    def build(
        cls,
        config: TeamConfig,
        params: BaseModel,
        planner: LeaguePlanner | None = None,
        guards: GuardsSpec | None = None,
    ) -> Policy:
        """The policy with the scenario's league planner and guards."""
        return cls(config, cast(FailureAwareParams, params), planner, guards)

    # ------------------------------------------------------------------ the tick

    def belief_needs(self) -> BeliefNeeds:
        """Zone knowledge, and comm zones inferred from silent teammates (Alg. 3), whose
        circles (Alg. 4) read at this policy's ``ε2`` and circle margin."""
        return BeliefNeeds(
            zones=True,
            silent_robots=CircleReading(beta2=self.beta2, circle_margin=self.params.circle_margin),
        )

    def act(self, belief: TeamBelief, obs: TeamObservation) -> Decision:
        """Algorithm 1 for one tick: per league, circle, plan alone or plan together."""
        m = obs.n_robots
        decision = Decision(controls=np.zeros((m, 2)), modes=["league"] * m)
        if any(a.clue.persistence == "temporary" or a.cause == "jamming" for a in obs.attacks):
            self.cooldown_until = obs.step + self.params.cooldown_steps
        cooling = obs.step < self.cooldown_until
        working = obs.sensing_ok & obs.comm_ok
        attacked: float = m - int(np.count_nonzero(working))
        watch = belief.degradation_watch
        if watch is not None:  # a degraded sensor counts as part of an attacked robot
            attacked += round(float(watch.attacked_fraction()[working].sum()), 2)
        eps_sensing = self._sensing_risk(int(np.count_nonzero(obs.sensing_ok)), m)
        for guard in self.guards:
            guard.observe(obs)

        for k in self.planning_order(belief.leagues):
            robots = belief.leagues[k]
            # with zone motion, the zones as predicted at the planned step (x⁺)
            knowledge = belief.plan_knowledge(robots, obs.step + 1)
            # a robot whose radio is destroyed circles its attacker (Alg. 4), until a guard
            # says the signal is given; then it tracks alone
            if (
                len(robots) == 1
                and obs.comm_persistence[robots[0]] == "permanent"
                and not self._stops_circling(robots[0], knowledge, obs)
            ):
                self._circle(robots[0], knowledge, obs, decision)
                continue
            alone = len(robots) == 1
            weights = self._situation_weights(cooling, alone, attacked, m)
            mode = "individual" if alone else "cooldown" if cooling else "league"
            rows = self._zone_rows(knowledge, weights[4], alone, eps_sensing)
            table, comm_rows, keys, n_sensing, comm_keys = rows
            for guard in self.guards:
                guard.after_rows(keys, table, n_sensing, robots, obs)
            for guard in self.guards:  # risk levels priced by what a failure would cost
                guard.price_rows(
                    LeagueRows(table, keys, comm_rows, comm_keys),
                    robots,
                    belief.estimates[k],
                    knowledge,
                    obs,
                )
            sensing_rows = table
            for guard in self.guards:  # the guards' own eq. 7c rows, after the zones'
                own, events = guard.league_rows(
                    obs.step,
                    robots,
                    belief.estimates[k],
                    belief.predicted(k),
                    table,
                    obs,
                    self.beta1,
                )
                decision.events += events
                if len(own):
                    sensing_rows = np.vstack([sensing_rows, own])
            sensing = obs.sensing_ok[robots].astype(float)
            q = self.tracking_inputs(
                belief, obs, robots, k, weights[:4], sensing, sensing_rows, comm_rows
            )
            decision.controls[robots] = self.solve(robots, q, obs.step, decision)
            self.last_weights[robots] = weights
            for i in robots:
                decision.modes[i] = mode
        return decision

    # ------------------------------------------------------------------ pieces

    def _situation_weights(self, cooling: bool, alone: bool, attacked: float, m: int) -> np.ndarray:
        """``[w1..w5]``: alone, the safe weights; a league, eq. 10 between risky and safe by
        the fraction of attacked robots; the cool-down weights while cooling (a copy)."""
        key = (cooling, alone, attacked, m)
        if key not in self._weights:
            p = self.params
            if alone or cooling:
                weights = (p.cooldown if cooling else p.safe).as_array()
            else:
                weights = adaptive_weights(p.risky.as_array(), p.safe.as_array(), attacked, m)
            self._weights[key] = weights
        return self._weights[key].copy()

    def _sensing_risk(self, sensing: int, m: int) -> float:
        """ε1 of the sensing zones' rows (eq. 7c), as the guards set it for ``sensing`` of the
        team's ``m`` robots still sensing."""
        eps = self.params.eps1
        for guard in self.guards:
            eps = guard.sensing_risk(eps, sensing, m)
        return eps

    def _margin(self, eps: float, zone: ZoneEstimate) -> float:
        """``β`` of ``zone``'s keep-out row at base risk level ``eps``, as the guards set it."""
        for guard in self.guards:
            eps = guard.zone_risk(eps, zone)
        if eps not in self._margins:
            self._margins[eps] = chance_margin(eps)
        return self._margins[eps]

    def _zone_rows(
        self, knowledge: KnowledgeBase, w5: float, alone: bool, eps_sensing: float
    ) -> ZoneRows:
        """Parameter rows of the known zones (eqs. 7c, 7d with ``r_safe = r + w5``); the last
        tick's rows again when the zones (immutable estimates), ``w5``, ``alone``, the sensing
        risk level and what the guards' rows depend on are.

        A robot alone has no teammate to be jammed from; it keeps clear of known comm zones as
        of disks of radius ``comm_clearance`` (plus any observed clearance) instead. Guards may
        set the risk levels, add a keep-out disc around a comm zone's hazard, or drop a comm
        zone's eq. 7d rows (:class:`~.guards.base.Guard`).
        """
        zones = tuple(knowledge.zones.values())
        levels = tuple(guard.rows_state(zones) for guard in self.guards)
        last = self._last_rows
        if (
            last is None
            or last[1] != (w5, alone, eps_sensing, levels)
            or len(last[0]) != len(zones)
            or any(z is not known for z, known in zip(zones, last[0], strict=True))
        ):
            rows = self._make_zone_rows(knowledge, w5, alone, eps_sensing)
            last = self._last_rows = (zones, (w5, alone, eps_sensing, levels), rows)
        sensing, comm, keys, n_sensing, comm_keys = last[2]
        return sensing.copy(), comm.copy(), keys, n_sensing, comm_keys

    def _make_zone_rows(
        self, knowledge: KnowledgeBase, w5: float, alone: bool, eps_sensing: float
    ) -> ZoneRows:
        keys, rows_s = [], []
        for z in knowledge.of_kind("sensing"):
            beta = self._margin(eps_sensing, z)
            rows_s.append(sensing_row(z.mean, z.cov, r_safe=z.size + w5 + z.clearance, beta=beta))
            keys.append(z.key)
        n_sensing = len(rows_s)
        rows_c, comm_keys = [], []
        for z in knowledge.of_kind("comm"):
            hazard = any(guard.guards_hazard(z) for guard in self.guards)
            beta = self._margin(self.params.eps1, z) if hazard else self.beta2
            if alone:
                radius = self.params.comm_clearance + z.clearance
                rows_s.append(sensing_row(z.mean, z.cov, r_safe=radius, beta=beta))
                keys.append(z.key)
                continue
            if hazard:
                radius = self.params.comm_clearance + w5 + z.clearance
                rows_s.append(sensing_row(z.mean, z.cov, r_safe=radius, beta=beta))
                keys.append(z.key)
            if all(guard.guards_links(z) for guard in self.guards):
                rows_c.append(
                    comm_row(z.mean, z.cov, z.size, beta=self.beta2, clearance=z.clearance)
                )
                comm_keys.append(z.key)
        return sensing_table(rows_s), comm_table(rows_c), keys, n_sensing, comm_keys

    def _circle(
        self, robot: int, knowledge: KnowledgeBase, obs: TeamObservation, decision: Decision
    ) -> None:
        """CircularEvasionMode around the attacker the robot estimated (its clue)."""
        decision.modes[robot] = "circular"
        attacker = self._attacker_estimate(knowledge)
        if attacker is None:  # no clue of what hit it: hold position
            return
        radius = evasion_radius(attacker.cov, self.beta2, self.params.circle_margin)
        u_max = float(self.config.u_max[robot])
        position = obs.positions[robot]

        def along(direction: float) -> np.ndarray:
            return circle_velocity(
                position,
                attacker.mean,
                radius,
                speed=self.params.circle_speed * u_max,
                u_max=u_max,
                direction=direction,
            )

        def keep_out() -> np.ndarray:  # the sensing zones' keep-out rows at ε1
            table, _, _, n_sensing, _ = self._make_zone_rows(knowledge, 0.0, True, self.params.eps1)
            return table[:n_sensing]

        direction = self._circling.get(robot, 1.0)
        velocity = along(direction)
        step = velocity * self.config.dt
        if any([guard.turns_back(robot, obs, step, keep_out) for guard in self.guards]):
            direction = -direction
            velocity = along(direction)
        self._circling[robot] = direction
        lower, upper = self.config.velocity_bounds([robot], obs.positions)
        decision.controls[robot] = np.clip(velocity, lower[0], upper[0])

    def _stops_circling(self, robot: int, knowledge: KnowledgeBase, obs: TeamObservation) -> bool:
        """Whether a guard says ``robot`` has given its signal (never without one: the paper's
        robot circles for good); every guard is asked every tick."""
        attacker = self._attacker_estimate(knowledge)
        return any([guard.stops_circling(robot, attacker, obs) for guard in self.guards])

    @staticmethod
    def _attacker_estimate(knowledge: KnowledgeBase) -> ZoneEstimate | None:
        clues = [
            z
            for z in knowledge.of_kind("comm")
            if z.source == "attack" and z.persistence == "permanent"
        ]
        return max(clues, key=lambda z: z.learned_step) if clues else None
