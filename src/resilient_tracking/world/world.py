"""The world: truth of robots, targets, zones, failures and links, advanced one step at a time.

Per step (``World.step``): robots move with clipped velocities, targets move, every zone draws an
attack for every robot at its new position (a failure, or a degradation where the zone's
effect is ``degrade``: :mod:`~resilient_tracking.world.degradation`), compromised radios of
zones that spread pass the compromise on over links, temporary failures and degradations
recover outside the zone's influence region, and links are recomputed. ``World.observe`` gives
the robots what they can know: measurements, their own failures, attack clues and link states.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import cast

import numpy as np

from resilient_tracking.events import Event
from resilient_tracking.models.geometry import row_norms
from resilient_tracking.models.numpy_twins import all_finite
from resilient_tracking.models.robot_motion import VelocityClip
from resilient_tracking.observation import Attack, FailureKind, TeamObservation
from resilient_tracking.rng import stream
from resilient_tracking.scenario import CommZone, Scenario
from resilient_tracking.world.degradation import Degradations
from resilient_tracking.world.links import jammed_by, link_matrix
from resilient_tracking.world.target_motion import Surroundings, ZoneTruth
from resilient_tracking.world.targets import TargetTruth
from resilient_tracking.world.zones import TrueZone

log = logging.getLogger(__name__)


@dataclass
class Failure:
    """An active failure of one capability of one robot."""

    persistence: str  # "temporary" | "permanent"
    zone_id: int
    since_step: int
    cause: str = "hazard"  # "hazard" | "jamming" | "spread"
    #: the robot that passed the compromise on (``cause == "spread"``), else -1
    source: int = -1


def zone_truth(zone: TrueZone) -> ZoneTruth:
    """What a reacting target motion sees of a zone: its truth (and its hazard disk's radius,
    a sensing zone's ``r`` or a comm zone's ``m_recover · √λmax(Σ)``)."""
    if "sensing" in zone.kinds:
        radius = float(zone.sizes["sensing"])
    else:
        radius = float(zone.spec.m_recover * np.sqrt(np.linalg.eigvalsh(zone.sigma).max()))
    center, mu, sigma = (np.array(a, dtype=float) for a in (zone.center, zone.mu, zone.sigma))
    for a in (center, mu, sigma):
        a.setflags(write=False)  # seen by every reacting target: nobody moves the zone
    return ZoneTruth(zone.spec.name, zone.kind, center, mu, sigma, float(zone.size), radius)


def spread_probability(zone: TrueZone) -> float:
    """Per step, the probability that a radio ``zone`` compromised passes the compromise to
    each teammate it has a link to; 0 for a zone that does not spread."""
    spread = zone.spec.spread if isinstance(zone.spec, CommZone) else None
    return 0.0 if spread is None else spread.probability


def make_zones(scenario: Scenario, seed: int) -> list[TrueZone]:
    """The episode's zones with their true centres, drawn from the ``zone_centers`` stream."""
    centers_rng = stream(seed, "zone_centers")
    return [TrueZone(k, spec, centers_rng) for k, spec in enumerate(scenario.zones)]


class World:
    """Ground truth of one episode. Only the simulator holds it."""

    def __init__(self, scenario: Scenario, seed: int):
        self.scenario = scenario
        self.dt = scenario.dt
        self.step_index = 0
        self.sensor = scenario.sensor.model()
        #: no range limit: observe needs no distances to know what a working sensor measures
        self._in_range_everywhere = self.sensor.in_range_everywhere()
        self._rng_attacks = stream(seed, "attacks")
        self._rng_measurements = stream(seed, "measurements")
        self._rng_targets = stream(seed, "target_motion")
        self.zones = make_zones(scenario, seed)
        #: the zones with a motion, and the stream their random motions draw from
        self._moving = [z for z in self.zones if z.moves]
        self._rng_zones = stream(seed, "zone_motion")
        self.robot_positions = np.array([r.start for r in scenario.robots], dtype=float)
        self.u_max = np.array([r.u_max for r in scenario.robots], dtype=float)
        ws = scenario.workspace
        #: clip_velocities with this team's bounds, made once
        self._clip = VelocityClip(self.u_max, ws.lower, ws.upper, self.dt)
        self.targets = [TargetTruth(t) for t in scenario.targets]
        #: the targets whose motion reacts to the world, and the zones as they see them
        self._reacting = [t for t in self.targets if t.reacts]
        self._zone_truths = tuple(zone_truth(z) for z in self.zones)
        m = len(scenario.robots)
        self.failures: dict[FailureKind, list[Failure | None]] = {
            "sensing": [None] * m,
            "comm": [None] * m,
        }
        self._pending_attacks: list[Attack] = []
        self._pending_recoveries: list[tuple[int, FailureKind]] = []
        self._comm_zones = [z for z in self.zones if "comm" in z.kinds]
        # the comm zones' true centres (unless they move) and δ2 never change: arrays once
        self._jammer_centers = np.array([z.center for z in self._comm_zones]).reshape(-1, 2)
        self._jammer_deltas = np.array([z.sizes["comm"] for z in self._comm_zones], dtype=float)
        #: what link_matrix is given for the links as possible without jamming: no jammer
        self._no_jamming = np.zeros((0, m, m), dtype=bool)
        #: partial degradations by zones whose effect is ``degrade`` (truth only)
        self.degradations = Degradations(scenario, seed)
        #: spread probability per step of each zone's compromise (0: it does not spread)
        self._spread = np.array([spread_probability(z) for z in self.zones], dtype=float)
        # its own stream, made only when a zone spreads: no other draw changes
        self._rng_spread = stream(seed, "spread") if self._spread.any() else None
        #: observe's failure flags and the links without jamming or range (they depend on the
        #: failures alone), each with the failure lists' contents they were made for: made
        #: again only when a failure begins or ends (the lists are compared, so a list
        #: replaced from outside counts too)
        self._flags_for: tuple[Failure | None, ...] | None = None
        self._flags: tuple[np.ndarray, np.ndarray, tuple[str, ...], tuple[str, ...], bool] = (
            np.empty(0, dtype=bool),
            np.empty(0, dtype=bool),
            (),
            (),
            False,
        )
        self._links_for: tuple[Failure | None, ...] | None = None
        self._possible = np.empty((0, 0), dtype=bool)
        self.links = self._compute_links()

    # ------------------------------------------------------------------ read-only truth

    @property
    def time(self) -> float:
        """Simulated time (s) of the current step: ``step_index · dt``."""
        return self.step_index * self.dt

    @property
    def n_robots(self) -> int:
        """Number of robots ``m``."""
        return len(self.robot_positions)

    @property
    def target_states(self) -> np.ndarray:
        """(N, 4) true ``[px, py, vx, vy]``."""
        motions = [t.motion for t in self.targets]
        states = np.empty((len(motions), 4))
        states[:, :2] = [m.position for m in motions]
        states[:, 2:] = [m.velocity for m in motions]
        return states

    def capability_ok(self, kind: FailureKind) -> np.ndarray:
        """``(m,)`` bool: whose sensor (``kind="sensing"``) or radio (``"comm"``) works now."""
        return np.array([f is None for f in self.failures[kind]])

    def persistence(self, kind: FailureKind) -> tuple[str, ...]:
        """Per robot, the persistence of its current failure of ``kind`` (``temporary`` or
        ``permanent``); ``""`` when it has none."""
        return tuple("" if f is None else f.persistence for f in self.failures[kind])

    def surroundings(self) -> Surroundings:
        """The truth a reacting target motion sees now: robots, zones, workspace, time."""
        ws = self.scenario.workspace
        return Surroundings(
            time=self.time,
            robots=self.robot_positions.copy(),
            zones=self._zone_truths,
            lower=ws.lower,
            upper=ws.upper,
        )

    # ------------------------------------------------------------------ observation

    def observe(self) -> TeamObservation:
        """Measurements and self-knowledge at the current step; clears pending events."""
        positions = self.robot_positions
        targets = np.array([t.motion.position for t in self.targets])
        # Noise is drawn for every pair every step so the stream stays aligned across policies.
        z = self.sensor.sample(positions[:, None, :], targets[None, :, :], self._rng_measurements)
        z = self.degradations.measure(z, self.sensor, positions, targets)
        sensing_ok, comm_ok, sensing_persistence, comm_persistence, blind = self._failure_flags()
        if self._in_range_everywhere:  # no range limit: a working sensor measures every target
            if blind:  # some sensor is down: its whole row
                z[~sensing_ok] = np.nan
        else:
            distance = row_norms(targets[None, :, :] - positions[:, None, :])
            lost = ~(sensing_ok[:, None] & self.sensor.in_range(distance))
            if lost.any():
                z[lost] = np.nan
        obs = TeamObservation.from_simulator(
            step=self.step_index,
            time=self.time,
            positions=positions.copy(),
            measurements=z,
            sensing_ok=sensing_ok.copy(),
            comm_ok=comm_ok.copy(),
            sensing_persistence=sensing_persistence,
            comm_persistence=comm_persistence,
            links=self.links.copy(),
            attacks=tuple(self._pending_attacks),
            recoveries=tuple(self._pending_recoveries),
        )
        self._pending_attacks = []
        self._pending_recoveries = []
        return obs

    def _failure_flags(
        self,
    ) -> tuple[np.ndarray, np.ndarray, tuple[str, ...], tuple[str, ...], bool]:
        """:meth:`capability_ok` and :meth:`persistence` of both kinds, and whether any sensor
        is down; made again only when the failures changed since the last call (the flags'
        arrays are the cache's own: copy before handing them out)."""
        now = (*self.failures["sensing"], *self.failures["comm"])
        if now != self._flags_for:
            sensing_ok = self.capability_ok("sensing")
            self._flags = (
                sensing_ok,
                self.capability_ok("comm"),
                self.persistence("sensing"),
                self.persistence("comm"),
                not sensing_ok.all(),
            )
            self._flags_for = now
        return self._flags

    def take_truth_events(self) -> list[Event]:
        """Truth's events since the last call (degradations begun and ended): for the truth
        recorder, never for the team."""
        return self.degradations.take_events()

    # ------------------------------------------------------------------ dynamics

    def clip_controls(self, controls: np.ndarray) -> np.ndarray:
        """Velocity bounds per component, then keep the next position inside the workspace
        (:func:`~resilient_tracking.models.robot_motion.clip_velocities`)."""
        return self._clip(self.robot_positions, controls)

    def step(self, controls: np.ndarray) -> np.ndarray:
        """Advance one step with velocity ``controls`` (M, 2); returns the controls applied.

        Controls of another shape are refused (``ValueError``); a robot whose control is not
        finite holds its position, with a warning (the team has already made such a control an
        ``invalid_decision`` event, so in an episode this never happens)."""
        u = np.asarray(controls, dtype=float)
        if u.shape != (self.n_robots, 2):
            raise ValueError(f"controls have shape {u.shape}, expected ({self.n_robots}, 2)")
        if not all_finite(u):  # (the clip holds such a robot)
            log.warning(
                "step %d: the controls of robots %s are not finite; they hold position",
                self.step_index,
                np.flatnonzero(~np.isfinite(u).all(axis=1)).tolist(),
            )
        applied = self.clip_controls(u)
        self.advance(applied)
        return applied

    def advance(self, applied: np.ndarray) -> None:
        """Advance one step with velocities already clipped by
        :func:`~resilient_tracking.models.robot_motion.clip_velocities`."""
        self.robot_positions = self.robot_positions + np.multiply(applied, self.dt)
        if self._reacting:
            around = self.surroundings()
            for target in self._reacting:
                target.sense(around)
        for target in self.targets:
            target.step(self.dt, self._rng_targets)
        self._after_move()

    def place(self, robots: np.ndarray, targets: np.ndarray, first: bool = False) -> None:
        """Motion capture: set the true robot and target positions (M, 2), (N, 2) as measured.

        The zones then act as after a simulated step (attacks, recoveries, links); ``first``
        places the starting positions of step 0 instead, recomputing only the links.
        """
        self.robot_positions = np.array(robots, dtype=float).reshape(self.n_robots, 2)
        for target, position in zip(self.targets, np.asarray(targets, dtype=float), strict=True):
            if not first:
                target.velocity = (position - target.position) / self.dt
            target.position = position.copy()
        if first:
            self.links = self._compute_links()
        else:
            self._after_move()

    def _after_move(self) -> None:
        self.step_index += 1
        if self._moving:
            self._move_zones()
        self._draw_attacks()
        if self._rng_spread is not None:
            self._pass_on(self._rng_spread)
        self._recover()
        self.links = self._compute_links()

    def _move_zones(self) -> None:
        """Advance the moving zones (draws from the ``zone_motion`` stream, zones in order) and
        refresh what depends on where they are."""
        for zone in self._moving:
            zone.move(self.dt, self._rng_zones, self.step_index)
        self._zone_truths = tuple(zone_truth(z) for z in self.zones)
        self._jammer_centers = np.array([z.center for z in self._comm_zones]).reshape(-1, 2)

    def _draw_attacks(self) -> None:
        # One uniform per (zone, robot) every step, whatever the state: common random numbers.
        draws = self._rng_attacks.random((len(self.zones), self.n_robots))
        for zone, row in zip(self.zones, draws, strict=True):
            hit = row < zone.hazard.probability(self.robot_positions, self.step_index, self.dt)
            if np.logical_or.reduce(hit, axis=None):  # (ndarray.any's reduction, sans wrapper)
                for robot in np.flatnonzero(hit).tolist():
                    if zone.spec.effect.type == "degrade":
                        self._degrade(robot, zone)
                    else:
                        for kind in zone.kinds:  # one draw disables every capability it attacks
                            self._fail(robot, zone, "hazard", kind)

    def _degrade(self, robot: int, zone: TrueZone) -> None:
        """A degrading zone's attack; announced, the robot learns of it as of a failure."""
        if self.degradations.start(robot, zone, self.step_index) and zone.spec.effect.announced:
            self._pending_attacks.append(Attack(robot=robot, clue=zone.clue(), cause="degradation"))

    def radio_links(self, radio: np.ndarray) -> np.ndarray:
        """(M, M) bool: the links there would be now if exactly the robots ``radio`` had
        working radios (within range, not jammed by any comm zone)."""
        jammed = jammed_by(self.robot_positions, self._jammer_centers, self._jammer_deltas)
        return link_matrix(self.robot_positions, radio, jammed, self.scenario.comm_range)

    def _pass_on(self, rng: np.random.Generator) -> None:
        """Spreading compromise: a robot whose radio a spreading zone compromised before this
        step passes it to each robot its radio still reaches (a link, were its radio its own)
        whose radio works, with the zone's probability per step; one uniform per ordered pair
        every step (common random numbers). The first source hit in index order infects."""
        m = self.n_robots
        draws = rng.random((m, m))
        rate = np.zeros(m)
        for robot, f in enumerate(self.failures["comm"]):
            if f is not None and f.persistence == "permanent" and f.since_step < self.step_index:
                rate[robot] = self._spread[f.zone_id]
        if not rate.any():
            return
        open_radio = self._radio()
        reach = self.radio_links(open_radio | (rate > 0))
        hit = reach & (rate > 0)[:, None] & open_radio[None, :] & (draws < rate[:, None])
        for target in np.flatnonzero(hit.any(axis=0)).tolist():
            source = int(np.flatnonzero(hit[:, target])[0])
            zone = self.zones[cast(Failure, self.failures["comm"][source]).zone_id]
            self._fail(target, zone, "spread", "comm", source)
            log.debug(
                "step %d: robot %d compromised robot %d's radio", self.step_index, source, target
            )

    def _fail(
        self, robot: int, zone: TrueZone, cause: str, kind: FailureKind, source: int = -1
    ) -> None:
        current = self.failures[kind][robot]
        persistence = zone.spec.persistence if cause != "jamming" else "temporary"
        if current is not None:
            if current.persistence == "permanent":
                return
            replaces_jamming = cause == "hazard" and current.cause == "jamming"
            if persistence == "temporary" and not replaces_jamming:
                return  # a temporary hit on a capability that is already down changes nothing
        self.failures[kind][robot] = Failure(persistence, zone.id, self.step_index, cause, source)
        self._pending_attacks.append(Attack(robot=robot, clue=zone.clue(kind), cause=cause))  # type: ignore[arg-type]

    def _recover(self) -> None:
        for kind in ("sensing", "comm"):
            for robot, failure in enumerate(self.failures[kind]):  # type: ignore[index]
                if failure is None or failure.persistence == "permanent":
                    continue
                if failure.cause == "jamming":
                    continue  # jamming isolation ends with the geometry, in _compute_links
                if failure.since_step >= self.step_index:
                    continue  # lasts at least one step
                zone = self.zones[failure.zone_id]
                if not zone.in_influence(self.robot_positions[robot]):
                    self.failures[kind][robot] = None  # type: ignore[index]
                    self._pending_recoveries.append((robot, kind))  # type: ignore[arg-type]
        ended = self.degradations.recover(self.robot_positions, self.zones, self.step_index)
        for robot, kind in ended:  # announced: the robot's own check reports it, unless down
            if self.failures[kind][robot] is None and (robot, kind) not in self._pending_recoveries:
                self._pending_recoveries.append((robot, kind))

    def _radio(self) -> np.ndarray:
        """``(m,)`` bool: whose radio can link (working, or only isolated by jamming)."""
        return np.array(
            [f is None or f.cause == "jamming" for f in self.failures["comm"]], dtype=bool
        )

    def _compute_links(self) -> np.ndarray:
        """Links now, and jamming isolation: a robot whose every possible link is jammed."""
        positions = self.robot_positions
        comm_range = self.scenario.comm_range
        if not self._comm_zones and comm_range is None:
            # no jammer and no range: the links follow the radios alone, so they are made again
            # only when a radio fails or recovers (a copy of them: the links are handed out)
            radios = tuple(self.failures["comm"])
            if radios != self._links_for:
                self._possible = link_matrix(positions, self._radio(), self._no_jamming, comm_range)
                self._links_for = radios
            return self.degradations.drop_links(self._possible.copy())
        possible = link_matrix(positions, self._radio(), self._no_jamming, comm_range)
        if not self._comm_zones:  # no jammer: no robot is isolated by jamming, none recovers
            return self.degradations.drop_links(possible)
        jammed = jammed_by(positions, self._jammer_centers, self._jammer_deltas)
        links = possible & ~jammed.any(axis=0)
        any_possible = cast(list[bool], possible.any(axis=1).tolist())
        any_link = cast(list[bool], links.any(axis=1).tolist())
        for robot in range(self.n_robots):
            failure = self.failures["comm"][robot]
            isolated = any_possible[robot] and not any_link[robot]
            if isolated and failure is None:
                worst = int(np.argmax(jammed[:, robot, :].sum(axis=1)))
                self._fail(robot, self._comm_zones[worst], "jamming", "comm")
            elif not isolated and failure is not None and failure.cause == "jamming":
                self.failures["comm"][robot] = None
                self._pending_recoveries.append((robot, "comm"))
        return self.degradations.drop_links(links)
