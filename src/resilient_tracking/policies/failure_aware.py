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
zone estimate (Alg. 3) that the league avoids from then on.
"""

from __future__ import annotations

import numpy as np

from resilient_tracking.belief.circle_fit import CircleGates, CircleWatcher, zone_from_circle
from resilient_tracking.belief.knowledge import KnowledgeBase, ZoneEstimate
from resilient_tracking.belief.team_belief import TeamBelief
from resilient_tracking.events import Event
from resilient_tracking.observation import TeamObservation
from resilient_tracking.planning.adaptation import adaptive_weights, as_array, chance_margin
from resilient_tracking.planning.evasion import circle_velocity, evasion_radius
from resilient_tracking.planning.layout import comm_row, comm_table, sensing_row, sensing_table
from resilient_tracking.planning.planner import LeaguePlanner
from resilient_tracking.policies.base import Decision, Policy
from resilient_tracking.scenario import FailureAwareParams
from resilient_tracking.team_config import TeamConfig


class FailureAwarePolicy(Policy):
    name = "failure_aware"
    learns_zones = True

    def __init__(
        self,
        config: TeamConfig,
        params: FailureAwareParams,
        planner: LeaguePlanner | None = None,
    ):
        super().__init__(config, planner)
        self.params = params
        self.beta1 = chance_margin(params.eps1)
        self.beta2 = chance_margin(params.eps2)
        fit = params.circle_fit
        self.watcher = CircleWatcher(
            CircleGates(
                window=fit.window,
                min_samples=fit.min_samples,
                min_arc=fit.min_arc,
                max_residual=fit.max_residual,
                min_radius=fit.min_radius,
                max_radius=fit.max_radius,
            ),
            silent_steps=fit.silent_steps,
        )
        #: the team is in cool-down while ``step < cooldown_until``
        self.cooldown_until = -1
        #: the weights used at the last tick, ``[w1..w5]`` per robot (for inspection and tests)
        self.last_weights = np.zeros((config.n_robots, 5))
        #: robots that had no link at the last tick
        self._silent: set[int] = set()

    # ------------------------------------------------------------------ the tick

    def act(self, belief: TeamBelief, obs: TeamObservation) -> Decision:
        m = obs.n_robots
        decision = Decision(controls=np.zeros((m, 2)), modes=["league"] * m)
        if any(a.clue.persistence == "temporary" or a.cause == "jamming" for a in obs.attacks):
            self.cooldown_until = obs.step + self.params.cooldown_steps
        cooling = obs.step < self.cooldown_until
        attacked = int(np.sum(~obs.sensing_ok | ~obs.comm_ok))
        self._watch_silent_robots(belief, obs, decision)

        for k, robots in enumerate(belief.leagues):
            knowledge = belief.league_knowledge(robots)
            if len(robots) == 1 and obs.comm_persistence[robots[0]] == "permanent":
                self._circle(robots[0], knowledge, obs, decision)
                continue
            if len(robots) == 1:
                weights = as_array(self.params.cooldown if cooling else self.params.safe)
                mode = "individual"
            else:
                weights = (
                    as_array(self.params.cooldown)
                    if cooling
                    else adaptive_weights(self.params.risky, self.params.safe, attacked, m)
                )
                mode = "cooldown" if cooling else "league"
            szones, czones = self._zone_rows(knowledge, weights[4], alone=len(robots) == 1)
            sensing = obs.sensing_ok[robots].astype(float)
            q = self.tracking_inputs(belief, obs, robots, k, weights[:4], sensing, szones, czones)
            decision.controls[robots] = self.solve(robots, q, obs.step, decision)
            self.last_weights[robots] = weights
            for i in robots:
                decision.modes[i] = mode
        return decision

    # ------------------------------------------------------------------ pieces

    def _zone_rows(
        self, knowledge: KnowledgeBase, w5: float, alone: bool
    ) -> tuple[np.ndarray, np.ndarray]:
        """Parameter rows of the known zones (eqs. 7c, 7d with ``r_safe = r + w5``).

        A robot alone has no teammate to be jammed from; it keeps clear of known comm zones as
        of disks of radius ``comm_clearance`` (plus any observed clearance) instead.
        """
        rows_s = [
            sensing_row(z.mean, z.cov, r_safe=z.size + w5 + z.clearance, beta=self.beta1)
            for z in knowledge.of_kind("sensing")
        ]
        rows_c = []
        for z in knowledge.of_kind("comm"):
            if alone:
                radius = self.params.comm_clearance + z.clearance
                rows_s.append(sensing_row(z.mean, z.cov, r_safe=radius, beta=self.beta2))
            else:
                rows_c.append(
                    comm_row(z.mean, z.cov, z.size, beta=self.beta2, clearance=z.clearance)
                )
        return sensing_table(rows_s), comm_table(rows_c)

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
        velocity = circle_velocity(
            obs.positions[robot],
            attacker.mean,
            radius,
            speed=self.params.circle_speed * u_max,
            u_max=u_max,
        )
        lower, upper = self.config.velocity_bounds([robot], obs.positions)
        decision.controls[robot] = np.clip(velocity, lower[0], upper[0])

    @staticmethod
    def _attacker_estimate(knowledge: KnowledgeBase) -> ZoneEstimate | None:
        clues = [
            z
            for z in knowledge.of_kind("comm")
            if z.source == "attack" and z.persistence == "permanent"
        ]
        return max(clues, key=lambda z: z.learned_step) if clues else None

    def _watch_silent_robots(
        self, belief: TeamBelief, obs: TeamObservation, decision: Decision
    ) -> None:
        """EstimateCircleParameters: robots with links observe the ones without."""
        listeners = [i for i in range(obs.n_robots) if obs.links[i].any()]
        for robot in range(obs.n_robots):
            silent = not obs.links[robot].any()
            if silent and robot not in self._silent and listeners:
                self._suspect_jammer(belief, obs, robot, listeners, decision)
            fit = self.watcher.observe(robot, obs.positions[robot], silent)
            if fit is None or not listeners:
                continue
            zone = zone_from_circle(
                fit,
                robot,
                obs.step,
                delta2=self.params.inferred_delta2,
                beta2=self.beta2,
                margin=self.params.circle_margin,
            )
            for i in listeners:
                belief.learn(i, zone)
            decision.events.append(
                Event(
                    obs.step,
                    robot,
                    "zone_inferred",
                    f"center=({fit.center[0]:.3f}, {fit.center[1]:.3f}) radius={fit.radius:.3f}"
                    f" residual={fit.residual:.4f} arc={fit.arc:.2f} n={fit.n_samples}",
                ),
            )
        self._silent = {i for i in range(obs.n_robots) if not obs.links[i].any()}

    def _suspect_jammer(
        self,
        belief: TeamBelief,
        obs: TeamObservation,
        robot: int,
        listeners: list[int],
        decision: Decision,
    ) -> None:
        """A teammate within radio range fell silent: a jammer is near where it is (our
        addition to Alg. 3). Until its circle is fitted, the league keeps clear of a
        provisional comm zone there with spread ``silence_std``, unless one is known nearby.
        """
        std = self.params.silence_std
        where = obs.positions[robot]
        others = obs.positions[listeners]
        reach = self.config.comm_range
        if std <= 0 or (
            reach is not None and np.min(np.linalg.norm(others - where, axis=1)) > reach
        ):
            return
        known = belief.league_knowledge([listeners[0]]).of_kind("comm")
        if any(np.linalg.norm(z.mean - where) < 2 * std for z in known):
            return
        zone = ZoneEstimate(
            key=f"silence{robot}@{obs.step}",
            kind="comm",
            mean=np.array(where, dtype=float),
            cov=std**2 * np.eye(2),
            size=self.params.inferred_delta2,
            persistence="unknown",
            source="silence",
            learned_step=obs.step,
            zone_id=None,
        )
        for i in listeners:
            belief.learn(i, zone)
        decision.events.append(
            Event(obs.step, robot, "zone_suspected", f"at ({where[0]:.3f}, {where[1]:.3f})")
        )
