"""The team's belief: leagues, one shared target estimate per league, zone knowledge per robot.

Each tick (docs/model.md §3–4):

1. attack clues are learned by their victims (if the team learns zones at all), after the zones
   of a hazard map given before the first tick (:meth:`TeamBelief.map_zones`);
2. leagues are the connected components of the observed link graph;
3. league estimates follow the robots: a league that gathers robots from several previous
   leagues fuses their estimates by covariance intersection, a league that split keeps a copy
   (motion-mode states included, :func:`~resilient_tracking.belief.fusion.fuse_estimates`);
4. each league's estimate is predicted to now (the prediction the policy planned with at the
   last tick, when the league is unchanged: one prediction per step) and updated with its
   sensing members' measurements by the team's estimator (the EKF by default); if the policy
   needs it, each member's measurements are first checked against that prediction for a
   silently degraded sensor, whose noise the update then scales
   (:mod:`resilient_tracking.belief.degradation_watch`);
5. every league covariance is checked (symmetric positive definite) and repaired with a
   ``covariance_repaired`` event if it drifted (:mod:`resilient_tracking.belief.health`; the
   motion modes of a repaired target, if the estimator keeps any, restart at its repair);
6. knowledge is merged within each league;
7. if the policy needs it (:class:`~resilient_tracking.belief.needs.BeliefNeeds`), robots
   with links watch silent ones and learn the comm zones they reveal
   (:mod:`resilient_tracking.belief.silent_robots`, Alg. 3);
8. if the policy needs it, every clue of an identified zone also feeds its victim's track of
   the zone's motion, shared within leagues with the knowledge
   (:mod:`resilient_tracking.belief.zone_motion`; :meth:`TeamBelief.plan_knowledge`).
"""

from __future__ import annotations

import logging
from collections.abc import Iterable
from dataclasses import replace
from typing import Literal, cast

import numpy as np

from resilient_tracking.belief.degradation_watch import DegradationWatch
from resilient_tracking.belief.estimate import TargetEstimate
from resilient_tracking.belief.estimator import Estimator, NoiseScalingEstimator
from resilient_tracking.belief.fusion import fuse_estimates
from resilient_tracking.belief.health import repair_covariances, surely_healthy
from resilient_tracking.belief.knowledge import KnowledgeBase, ZoneEstimate
from resilient_tracking.belief.modes import ModeStates
from resilient_tracking.belief.needs import BeliefNeeds
from resilient_tracking.belief.settings import BeliefSettings
from resilient_tracking.belief.silent_robots import SilentRobotSettings, SilentRobotWatch
from resilient_tracking.belief.zone_motion import ZoneMotionTracker
from resilient_tracking.events import Event
from resilient_tracking.models.graph import components
from resilient_tracking.models.sensor import MeasurementModel
from resilient_tracking.observation import TeamObservation

log = logging.getLogger(__name__)


class TeamBelief:
    """Belief of all robots of a team, organised by league."""

    def __init__(
        self,
        n_robots: int,
        initial: TargetEstimate,
        estimator: Estimator,
        needs: BeliefNeeds | None = None,
        ci_criterion: Literal["trace", "det"] = "trace",
        *,
        settings: BeliefSettings | None = None,
        dt: float | None = None,
        sensor: MeasurementModel | None = None,
        comm_range: float | None = None,
    ):
        """``settings`` are the belief's own (:class:`BeliefSettings`; defaults when ``None``);
        ``dt`` (s) is needed to track zone motion, ``sensor`` (the team's) to watch for degraded
        sensors, ``comm_range`` (m, ``None``: unlimited) to read silent teammates."""
        self.n_robots = n_robots
        #: predicts and updates the league estimates (the EKF of :mod:`~.ekf` by default)
        self.estimator = estimator
        self.needs = needs or BeliefNeeds()
        self.settings = settings = settings or BeliefSettings()
        self.ci_criterion = ci_criterion
        #: infers comm zones from silent teammates at the end of each update (or ``None``)
        reading = self.needs.silent_robots
        self.silent_robot_watch = (
            None
            if reading is None
            else SilentRobotWatch(
                SilentRobotSettings(
                    circle_fit=settings.circle_fit,
                    provisional_zone=settings.provisional_zone,
                    beta2=reading.beta2,
                    circle_margin=reading.circle_margin,
                    comm_range=comm_range,
                )
            )
        )
        #: tracks of the zones' motion from successive clues (or ``None``: zones stay put)
        self.zone_motion = None
        if settings.zone_motion.enabled and self.needs.zones:
            if dt is None:
                raise ValueError("TeamBelief: zone motion needs the time step dt")
            self.zone_motion = ZoneMotionTracker(n_robots, settings.zone_motion, dt)
        #: finds silently degraded sensors and scales their noise (or ``None``)
        watch = settings.degradation_watch
        self.degradation_watch = None
        if watch.enabled:
            if sensor is None:
                raise ValueError("TeamBelief: the degradation watch needs the team's sensor")
            self.degradation_watch = DegradationWatch(n_robots, watch, sensor, self.needs.zones)
        #: whether the estimator's update takes ``noise_scale`` (the EKF and the IMM do)
        self._scales_noise = getattr(estimator, "scales_noise", False) is True
        #: a league with a robot found degraded: the estimator's careful update (the EKF's is
        #: iterated; the IMM's modes already update that way)
        self._degraded_update = estimator.update
        if self.degradation_watch is not None and self._scales_noise:
            scaling = cast(NoiseScalingEstimator, estimator)
            careful = scaling.with_update(watch.update_iterations, watch.second_order)
            self._degraded_update = careful.update
        if self.degradation_watch is not None and not self._scales_noise:
            log.warning(
                "the estimator %s cannot scale a robot's noise: degraded sensors are found, "
                "their noise is not adapted",
                type(estimator).__name__,
            )
        self.leagues: list[list[int]] = [list(range(n_robots))]
        self.league_of = np.zeros(n_robots, dtype=int)
        self.estimates: list[TargetEstimate] = [initial]  # one per league
        #: each league's estimate predicted to the next tick, made once (:meth:`predicted`)
        self._predicted: list[TargetEstimate | None] = [None]
        #: replaces a covariance that stopped being finite (the prior spread of target 0)
        self._prior_block = initial.cov[0].copy()
        self.knowledge: list[KnowledgeBase] = [KnowledgeBase() for _ in range(n_robots)]
        self.sensing_ok = np.ones(n_robots, dtype=bool)
        self.last_step: int | None = None
        #: zone estimates learned this tick: (robot, estimate), for the knowledge table
        self.learned: list[tuple[int, ZoneEstimate]] = []
        #: zones of a hazard map not yet learned (:meth:`map_zones`)
        self._mapped: list[ZoneEstimate] = []
        #: whether a robot learned something or the leagues changed since knowledge was shared
        self._unshared = True
        #: the last link matrix seen (its bytes and shape) and its leagues
        self._links_seen: tuple[bytes, object, list[list[int]]] | None = None

    def map_zones(self, zones: Iterable[ZoneEstimate]) -> None:
        """Zones the team knows before it starts (a hazard map): every robot learns them at the
        next update, as if broadcast; a team that keeps no zone knowledge ignores them."""
        self._mapped.extend(zones)

    # ------------------------------------------------------------------ tick

    def update(self, obs: TeamObservation) -> list[Event]:
        """Take in one tick's observation (steps 1–7 above); return the tick's belief events."""
        events: list[Event] = []
        self.learned = []
        self.sensing_ok = np.asarray(obs.sensing_ok, dtype=bool)
        if self._mapped:
            if self.needs.zones:
                for zone in self._mapped:
                    for robot in range(self.n_robots):
                        self._learn(robot, replace(zone, learned_step=obs.step))
                        if self.zone_motion is not None:
                            self.zone_motion.observe(robot, zone, obs.step)
            self._mapped = []
        if self.needs.zones:
            for attack in obs.attacks:
                for estimate in ZoneEstimate.all_from_clue(attack.clue, obs.step):
                    self._learn(attack.robot, estimate)
                    if self.zone_motion is not None:
                        self.zone_motion.observe(attack.robot, estimate, obs.step)
        events += self._regroup(self._leagues_of(obs.links), obs.step)
        if self.last_step is not None:
            self.estimates = [self.predicted(k) for k in range(len(self.estimates))]
        self.last_step = obs.step
        sensing_ok = self.sensing_ok.tolist()  # (Python bools: quicker to index one by one)
        for k, league in enumerate(self.leagues):
            sensing = [i for i in league if sensing_ok[i]]
            if not sensing:
                continue
            if len(sensing) == len(obs.positions):  # the whole team (leagues are sorted): no copies
                positions, measurements = obs.positions, obs.measurements
            else:
                positions, measurements = obs.positions[sensing], obs.measurements[sensing]
            if self.degradation_watch is None:
                self.estimates[k] = self.estimator.update(
                    self.estimates[k], positions, measurements
                )
                continue
            prior = self.estimates[k]
            events += self.degradation_watch.observe(
                self, obs.step, sensing, prior, positions, measurements
            )
            scale = self.degradation_watch.noise_scale(sensing) if self._scales_noise else None
            if scale is None:
                self.estimates[k] = self.estimator.update(prior, positions, measurements)
            else:  # an estimator that scales its noise (the EKF and the IMM do)
                self.estimates[k] = self._degraded_update(  # type: ignore[call-arg]
                    prior, positions, measurements, noise_scale=scale
                )
        events += self._check_health(obs.step)
        self._predicted = [None] * len(self.estimates)
        if self.needs.zones:
            self._share_knowledge()
            if self.zone_motion is not None:
                self.zone_motion.share(self.leagues)
            if self.silent_robot_watch is not None:
                events += self.silent_robot_watch.observe(self, obs)
        return events

    def _leagues_of(self, links: np.ndarray) -> list[list[int]]:
        """The leagues of ``links`` (:func:`components`), unchanged while the links are."""
        links = np.asarray(links)
        key, shape, seen = links.tobytes(), (links.shape, links.dtype.str), self._links_seen
        if seen is not None and seen[0] == key and seen[1] == shape:
            return [list(league) for league in seen[2]]
        leagues = components(links)
        self._links_seen = (key, shape, [list(league) for league in leagues])
        return leagues

    def _check_health(self, step: int) -> list[Event]:
        """Keep every league covariance symmetric positive definite; an event per repair."""
        events: list[Event] = []
        for k, estimate in enumerate(self.estimates):
            if surely_healthy(estimate.cov):  # the usual tick: nothing to repair, nothing copied
                continue
            cov, repairs = repair_covariances(estimate.cov, fallback=self._prior_block)
            if not repairs:
                continue
            self.estimates[k] = TargetEstimate(
                estimate.mean, cov, _reseated_modes(estimate, cov, [r.index for r in repairs])
            )
            for r in repairs:
                log.warning(
                    "league %s, step %d: repaired covariance, %s",
                    self.leagues[k],
                    step,
                    r.describe(),
                )
                events.append(Event.covariance_repaired(step, self.leagues[k], r.describe()))
        return events

    def learn(self, robot: int, estimate: ZoneEstimate) -> None:
        """Add knowledge found by a robot (e.g. an inferred zone); shared at the next tick."""
        self._learn(robot, estimate)

    def _learn(self, robot: int, estimate: ZoneEstimate) -> None:
        if self.knowledge[robot].learn(estimate):
            self.learned.append((robot, estimate))
            self._unshared = True

    def _regroup(self, leagues: list[list[int]], step: int) -> list[Event]:
        if leagues == self.leagues:  # the usual tick: same leagues, same estimates
            return []
        events: list[Event] = []
        old_of = self.league_of
        # how many new leagues each old league feeds: more than one means it split
        feeds: dict[int, int] = {}
        for league in leagues:
            for old in sorted({int(old_of[i]) for i in league}):
                feeds[old] = feeds.get(old, 0) + 1
        estimates: list[TargetEstimate] = []
        for league in leagues:
            sources = sorted({int(old_of[i]) for i in league})
            estimate = self.estimates[sources[0]]
            for other in sources[1:]:
                estimate, lambdas = fuse_estimates(
                    estimate, self.estimates[other], criterion=self.ci_criterion
                )
                members = [i for i in league if old_of[i] == other]
                events.append(Event.league_merge(step, members, league, lambdas))
            if len(sources) == 1 and feeds[sources[0]] > 1:
                estimate = estimate.copy()
                events.append(Event.league_split(step, league))
            estimates.append(estimate)
        self.leagues = leagues
        self._unshared = True
        self.estimates = estimates
        self._predicted = [None] * len(estimates)
        self.league_of = np.empty(self.n_robots, dtype=int)
        for k, league in enumerate(leagues):
            self.league_of[league] = k
        return events

    def _share_knowledge(self) -> None:
        if not self._unshared:  # every league's members already hold the same knowledge
            return
        self._unshared = False
        for league in self.leagues:
            if len(league) < 2:
                continue
            merged = KnowledgeBase.union([self.knowledge[i] for i in league])
            for i in league:
                for key, zone in merged.zones.items():
                    if key not in self.knowledge[i]:
                        self.learned.append((i, replace(zone, source="broadcast")))
                self.knowledge[i] = merged.copy()

    # ------------------------------------------------------------------ queries

    def predicted(self, league: int) -> TargetEstimate:
        """League ``league``'s estimate predicted one step ahead, to the next tick: what its
        plan is made against, and the prior of its next update (computed once per tick)."""
        found = self._predicted[league]
        if found is None:
            found = self._predicted[league] = self.estimator.predict(self.estimates[league])
        return found

    def league_knowledge(self, league: list[int]) -> KnowledgeBase:
        """Knowledge shared within a league (identical for its members after a tick)."""
        return self.knowledge[league[0]]

    def plan_knowledge(self, league: list[int], step: int) -> KnowledgeBase:
        """The league's knowledge as planned against at ``step``: with zone motion, each
        tracked zone predicted to ``step`` (:meth:`ZoneMotionTracker.predicted`); else as
        learned."""
        knowledge = self.league_knowledge(league)
        if self.zone_motion is None:
            return knowledge
        return self.zone_motion.predicted(league, knowledge, step)

    def team_estimate(self) -> TargetEstimate:
        """The estimate of the league with most sensing robots; ties go to the lower trace."""
        if len(self.leagues) == 1:
            return self.estimates[0]
        best = min(
            range(len(self.leagues)),
            key=lambda k: (
                -int(self.sensing_ok[self.leagues[k]].sum()),
                self.estimates[k].position_trace(),
            ),
        )
        return self.estimates[best]


def _reseated_modes(
    estimate: TargetEstimate, cov: np.ndarray, repaired: list[int]
) -> ModeStates | None:
    """The estimate's mode states with every mode of a repaired target at its repaired
    Gaussian (mode probabilities kept); ``None`` for a single-model estimate."""
    if estimate.modes is None:
        return None
    modes = estimate.modes.copy()
    modes.means[repaired] = estimate.mean[repaired, None, :]
    modes.covs[repaired] = cov[repaired, None, :, :]
    return modes
