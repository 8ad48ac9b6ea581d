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

import math

import numpy as np

from resilient_tracking.belief.knowledge import KnowledgeBase, ZoneEstimate
from resilient_tracking.belief.needs import BeliefNeeds, CircleReading
from resilient_tracking.belief.team_belief import TeamBelief
from resilient_tracking.observation import TeamObservation
from resilient_tracking.planning.adaptation import adaptive_weights, chance_margin
from resilient_tracking.planning.evasion import circle_velocity, evasion_radius
from resilient_tracking.planning.layout import (
    SensingRow,
    comm_row,
    comm_table,
    sensing_row,
    sensing_table,
)
from resilient_tracking.planning.margins import keep_out_values
from resilient_tracking.planning.planner import LeaguePlanner
from resilient_tracking.policies.base import Decision, register_policy
from resilient_tracking.policies.exposure import ExposureLedger
from resilient_tracking.policies.failure_aware_params import FailureAwareParams
from resilient_tracking.policies.planning_helpers import PlanningPolicy
from resilient_tracking.policies.quarantine import QuarantineWatch
from resilient_tracking.policies.suspects import SuspectWatch
from resilient_tracking.team_config import TeamConfig

#: the sensing and the comm zone table of a league problem (``layout.SensingRow``, ``CommRow``),
#: the zone key of each sensing-table row, and how many of those rows are sensing zones'
ZoneRows = tuple[np.ndarray, np.ndarray, list[str], int]


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
    ):
        super().__init__(config, params, planner)
        self.beta1 = chance_margin(params.eps1)
        self.beta2 = chance_margin(params.eps2)
        #: the team is in cool-down while ``step < cooldown_until``
        self.cooldown_until = -1
        #: the weights used at the last tick, ``[w1..w5]`` per robot (for inspection and tests)
        self.last_weights = np.zeros((config.n_robots, 5))
        #: the weights of each situation, computed once (the parameters are fixed at creation)
        self._weights: dict[tuple[bool, bool, float, int], np.ndarray] = {}
        #: the last zone rows made: the zones they came from, what else they depend on, the rows
        self._last_rows: tuple[tuple[ZoneEstimate, ...], tuple[object, ...], ZoneRows] | None = None
        #: robot-steps spent near each known zone (with ``hazard_guard``)
        self.exposure = ExposureLedger(params.exposure_horizon if params.hazard_guard else 0)
        #: circling direction (1 counter-clockwise, −1 clockwise) of each robot in Alg. 4
        self._circling: dict[int, float] = {}
        #: per robot signalling its attacker: its last angle around it and the angle swept
        self._swept: dict[int, tuple[float, float]] = {}
        #: targets each robot suspects of luring it into danger (with ``lure_guard``)
        self.suspects = (
            SuspectWatch(config.n_robots, params.lure, config.dt) if params.lure_guard else None
        )
        #: teammates known to carry a compromise, kept out of radio range (with ``quarantine``)
        self.quarantine = (
            QuarantineWatch(config.n_robots, params.quarantine_keep_out, config.comm_range)
            if params.quarantine
            else None
        )

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
        if self.quarantine is not None:
            self.quarantine.observe(obs)

        for k in self.planning_order(belief.leagues):
            robots = belief.leagues[k]
            # with zone motion, the zones as predicted at the planned step (x⁺)
            knowledge = belief.plan_knowledge(robots, obs.step + 1)
            # a robot whose radio is destroyed circles its attacker (Alg. 4), with signal_turns
            # only until the signal is given; then it tracks alone
            if (
                len(robots) == 1
                and obs.comm_persistence[robots[0]] == "permanent"
                and not self._signalled(robots[0], knowledge, obs)
            ):
                self._circle(robots[0], knowledge, obs, decision)
                continue
            alone = len(robots) == 1
            weights = self._situation_weights(cooling, alone, attacked, m)
            mode = "individual" if alone else "cooldown" if cooling else "league"
            rows = self._zone_rows(knowledge, weights[4], alone, eps_sensing)
            self._record_exposure(rows, robots, obs)
            sensing_rows = rows[0]
            if self.suspects is not None:
                # keep clear of suspect targets as of zones (eq. 7c rows after the zones')
                estimate = belief.estimates[k]
                decision.events += self.suspects.observe(obs.step, robots, estimate, sensing_rows)
                suspect_rows = self.suspects.rows(robots, belief.predicted(k), self.beta1)
                sensing_rows = np.vstack([sensing_rows, suspect_rows])
            if self.quarantine is not None:
                # keep out of radio range of quarantined teammates (eq. 7c rows, last)
                quarantine_rows = self.quarantine.rows(robots, obs, self.beta1)
                sensing_rows = np.vstack([sensing_rows, quarantine_rows])
            sensing = obs.sensing_ok[robots].astype(float)
            q = self.tracking_inputs(
                belief, obs, robots, k, weights[:4], sensing, sensing_rows, rows[1]
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
        """ε1 of eq. 7c; with ``hazard_guard``, ``ε1 · s/M`` for ``s`` of the ``M`` robots still
        sensing (the last sensors are worth more: losing the last one leaves the team blind for
        good)."""
        if not self.params.hazard_guard or sensing >= m:
            return self.params.eps1
        return self.params.eps1 * max(sensing, 1) / m

    def _zone_rows(
        self, knowledge: KnowledgeBase, w5: float, alone: bool, eps_sensing: float
    ) -> ZoneRows:
        """Parameter rows of the known zones (eqs. 7c, 7d with ``r_safe = r + w5``); the last
        tick's rows again when the zones (immutable estimates), ``w5``, ``alone``, the sensing
        risk level and the exposure levels are.

        A robot alone has no teammate to be jammed from; it keeps clear of known comm zones as
        of disks of radius ``comm_clearance`` (plus any observed clearance) instead. With
        ``hazard_guard``, league robots keep clear of that disc (plus ``w5``) too, besides eq. 7d,
        around every comm zone not known to be temporary, at the sensing zones' risk level
        ``ε1``: its hazard can destroy a radio whatever the links (a temporary one costs an
        outage, which eq. 7d and the cool-down already weigh); and each zone's risk level
        halves as the team's exposure to it grows (:mod:`~resilient_tracking.policies.exposure`).
        With ``guard_temporary_jammers`` off, a league has no eq. 7d rows for comm zones known to
        be temporary.
        """
        zones = tuple(knowledge.zones.values())
        levels = tuple(self.exposure.level(z.key) for z in zones)
        last = self._last_rows
        if (
            last is None
            or last[1] != (w5, alone, eps_sensing, levels)
            or len(last[0]) != len(zones)
            or any(z is not known for z, known in zip(zones, last[0], strict=True))
        ):
            rows = self._make_zone_rows(knowledge, w5, alone, eps_sensing)
            last = self._last_rows = (zones, (w5, alone, eps_sensing, levels), rows)
        sensing, comm, keys, n_sensing = last[2]
        return sensing.copy(), comm.copy(), keys, n_sensing

    def _make_zone_rows(
        self, knowledge: KnowledgeBase, w5: float, alone: bool, eps_sensing: float
    ) -> ZoneRows:
        guard = self.params.hazard_guard
        margin = self.exposure.margin if guard else lambda eps, key: chance_margin(eps)
        keys, rows_s = [], []
        for z in knowledge.of_kind("sensing"):
            beta = margin(eps_sensing, z.key)
            rows_s.append(sensing_row(z.mean, z.cov, r_safe=z.size + w5 + z.clearance, beta=beta))
            keys.append(z.key)
        n_sensing = len(rows_s)
        rows_c = []
        for z in knowledge.of_kind("comm"):
            hazard = guard and z.persistence != "temporary"
            beta = margin(self.params.eps1, z.key) if hazard else self.beta2
            if alone:
                radius = self.params.comm_clearance + z.clearance
                rows_s.append(sensing_row(z.mean, z.cov, r_safe=radius, beta=beta))
                keys.append(z.key)
                continue
            if hazard:
                radius = self.params.comm_clearance + w5 + z.clearance
                rows_s.append(sensing_row(z.mean, z.cov, r_safe=radius, beta=beta))
                keys.append(z.key)
            if self.params.guard_temporary_jammers or z.persistence != "temporary":
                rows_c.append(
                    comm_row(z.mean, z.cov, z.size, beta=self.beta2, clearance=z.clearance)
                )
        return sensing_table(rows_s), comm_table(rows_c), keys, n_sensing

    def _record_exposure(self, rows: ZoneRows, robots: list[int], obs: TeamObservation) -> None:
        """A step of exposure for each robot near a keep-out disc that can still harm it: a
        sensing zone's while its sensor works, a comm zone's while its radio does."""
        table, _, keys, n_sensing = rows
        sensing = [i for i in robots if obs.sensing_ok[i]]
        radio = [i for i in robots if obs.comm_ok[i]]
        self.exposure.record(keys[:n_sensing], table[:n_sensing], obs.positions[sensing])
        self.exposure.record(keys[n_sensing:], table[n_sensing:], obs.positions[radio])

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

        direction = self._circling.get(robot, 1.0)
        velocity = along(direction)
        if self.params.hazard_guard and obs.sensing_ok[robot]:
            # a circle that crosses a known sensing zone turns back at its keep-out disc, so
            # the robot's sensor survives the signal (the arc still shows the circle)
            table, _, _, n_sensing = self._make_zone_rows(knowledge, 0.0, True, self.params.eps1)
            rows = table[:n_sensing]
            if len(rows) and _enters(position, velocity * self.config.dt, rows):
                direction = -direction
                velocity = along(direction)
        self._circling[robot] = direction
        lower, upper = self.config.velocity_bounds([robot], obs.positions)
        decision.controls[robot] = np.clip(velocity, lower[0], upper[0])

    def _signalled(self, robot: int, knowledge: KnowledgeBase, obs: TeamObservation) -> bool:
        """Whether the robot has circled its attacker ``signal_turns`` times (never without
        ``signal_turns``: the paper's robot circles for good); the angle it swept around the
        attacker's estimate is summed tick by tick."""
        turns = self.params.signal_turns
        if turns is None:
            return False
        attacker = self._attacker_estimate(knowledge)
        if attacker is None:  # no clue of what hit it: nothing to signal
            return True
        offset = obs.positions[robot] - attacker.mean
        angle = math.atan2(offset[1], offset[0])
        last, swept = self._swept.get(robot, (angle, 0.0))
        swept += abs(math.remainder(angle - last, math.tau))
        self._swept[robot] = (angle, swept)
        return swept >= turns * math.tau

    @staticmethod
    def _attacker_estimate(knowledge: KnowledgeBase) -> ZoneEstimate | None:
        clues = [
            z
            for z in knowledge.of_kind("comm")
            if z.source == "attack" and z.persistence == "permanent"
        ]
        return max(clues, key=lambda z: z.learned_step) if clues else None


def _enters(position: np.ndarray, step: np.ndarray, rows: np.ndarray) -> bool:
    """Whether moving by ``step`` takes ``position`` into, or deeper into, a keep-out disc of
    the sensing rows (eq. 7c's margin falls below zero and keeps falling)."""
    gaussians = rows[:, SensingRow.GAUSSIAN]
    offset, beta = rows[:, SensingRow.R_SAFE], rows[:, SensingRow.BETA]
    now = keep_out_values(position, gaussians, offset, beta)
    then = keep_out_values(position + step, gaussians, offset, beta)
    return bool(np.any((then < 0) & (then < now)))
