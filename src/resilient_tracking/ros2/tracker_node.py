"""The tracker node: the team on robots, as a ROS 2-compatible node over DDS.

It subscribes to each robot's pose (``/cfN/pose``), to the synthesized observations
(``/rtrack/observation``) and, for the run tables only, to the targets' poses. For each new
observation it runs ``Team.step``, clips the commands to the robots' limits and the workspace
(as the simulator does), publishes one velocity setpoint per robot and the belief for RViz, and
records the step with the same team recorder as ``rtrack run``; the targets' poses, the truth
of the run tables, go to a truth recorder of their own.

The node never imports the simulated world: the targets' starting states (the team's prior is
drawn around them) and the true zones (for plots only) are handed to it by whoever starts it
(``rtrack node`` takes them from ``sim.episode.start_truth``).

Whatever goes wrong gives a hold-position command and a logged warning, never a crash:

* a robot whose poses stop for longer than ``pose_timeout`` holds its last seen position (its
  measurements are not used, a ``pose_lost`` event is recorded) while the team keeps planning
  for the others; a robot never heard from makes the whole team hold;
* no observation for ``observation_timeout`` (the world node is gone): every robot holds;
* a message that cannot be used is dropped, counted by topic and reason in the run's manifest
  (:mod:`~.drops`): undecodable bytes, a non-finite pose, an observation that does not fit the
  scenario, and, running free, a stamp that is stale, ahead of this computer's clock by more
  than the timeout, or not after the newest one taken on its topic;
* publishers of other types on its topics, or of poses of names the scenario does not have,
  are found from DDS discovery and listed in the manifest;
* a planner exception.

Nothing at all within ``startup_timeout`` (no observation, or no pose of some robot) raises
:class:`StartupTimeout` naming what is missing.

In lock-step the observation of step ``k`` is paired with the poses stamped with the same time
(``k·dt``), so the run sees exactly the arrays a simulated run sees.
"""

from __future__ import annotations

import contextlib
import dataclasses
import gc
import logging
import threading
import time
from collections import OrderedDict, deque
from collections.abc import Callable, Iterator, Sequence

import numpy as np
from cyclonedds.idl import IdlStruct

from resilient_tracking.events import Event
from resilient_tracking.models.robot_motion import clip_velocities
from resilient_tracking.observation import TeamObservation
from resilient_tracking.ros2 import msgs
from resilient_tracking.ros2.bag import BagRecorder
from resilient_tracking.ros2.convert import (
    MessageError,
    check_stamp,
    full_state,
    observation_from_msg,
    pose_xy,
    stamp_from_ns,
    stamp_ns,
    twist,
)
from resilient_tracking.ros2.drops import DropLog, PublicationWatch
from resilient_tracking.ros2.markers import BeliefView, markers_of
from resilient_tracking.ros2.topics import BELIEF_TOPIC, OBSERVATION_TOPIC, NodeSettings
from resilient_tracking.ros2.transport import (
    BackgroundWriter,
    DdsNode,
    default_qos,
    lockstep_qos,
    sensor_data_qos,
    take,
)
from resilient_tracking.runs.manifest import episode_manifest
from resilient_tracking.runs.records import EpisodeResult, join_tables
from resilient_tracking.runs.team_recorder import TeamRecorder
from resilient_tracking.runs.truth_recorder import TruthRecorder, ZoneTruth
from resilient_tracking.scenario import Scenario
from resilient_tracking.team import TeamStep, build_team

log = logging.getLogger(__name__)

_POSES_KEPT = 64  # poses remembered per body for lock-step pairing


@contextlib.contextmanager
def _frozen_heap(enabled: bool) -> Iterator[None]:
    """Keep what exists now out of the garbage collector's sight while the block runs.

    A full collection over everything a planner holds (problems, solvers, the warm-up's run)
    paused a 10×10 tick for about 50 ms; frozen, the collector looks only at what the loop
    creates. Leftovers are collected first, and the heap is unfrozen afterwards. Frozen objects
    are still freed by reference counting; only cycles among them wait for the unfreeze."""
    if not enabled:
        yield
        return
    gc.collect()
    gc.freeze()
    try:
        yield
    finally:
        gc.unfreeze()


class StartupTimeout(TimeoutError):
    """Nothing to track with within ``startup_timeout``; the message says what is missing."""


class _Body:
    """The poses received for one robot or target."""

    def __init__(self, name: str, topic: str):
        self.name, self.topic = name, topic
        self.by_stamp: OrderedDict[int, np.ndarray] = OrderedDict()
        self.latest: np.ndarray | None = None
        self.received_at = -np.inf
        self.newest: int | None = None  # stamp (ns) of the newest pose taken

    def add(self, msg: msgs.PoseStamped, now: float, wall_ns: int, tolerance: float | None) -> None:
        """Take a pose received at ``now`` (monotonic s), or raise :class:`MessageError`.
        Running free (``tolerance`` in s) its stamp is checked against this computer's clock
        ``wall_ns`` and the newest pose taken; in lock-step a stamp is a step's key."""
        xy = pose_xy(msg, self.topic)
        stamp = stamp_ns(msg.header.stamp)
        if tolerance is not None:
            check_stamp(stamp, wall_ns, self.newest, tolerance, self.topic)
        self.newest = stamp if self.newest is None else max(self.newest, stamp)
        self.by_stamp[stamp] = xy
        while len(self.by_stamp) > _POSES_KEPT:
            self.by_stamp.popitem(last=False)
        self.latest, self.received_at = xy, now


class TrackerNode:
    """Runs the team of ``scenario`` against DDS topics; :meth:`run` returns the run's tables.

    ``initial_targets`` are the targets' starting states (N, 4) ``[px, py, vx, vy]``, around
    which the team's prior is drawn with ``seed``; ``zones`` the true zones recorded in the
    zones table for plots (none: an empty table).
    """

    def __init__(
        self,
        scenario: Scenario,
        seed: int,
        policy: str,
        settings: NodeSettings,
        initial_targets: np.ndarray,
        bag: BagRecorder | None = None,
        zones: Sequence[ZoneTruth] = (),
    ):
        self.scenario, self.seed, self.policy, self.settings = scenario, seed, policy, settings
        self.bag = bag
        self.dt = scenario.dt
        self.team = build_team(scenario, policy, seed, np.asarray(initial_targets, dtype=float))
        #: the policy's planner; running free, it builds new league structures in the
        #: background (the robots take the safe action meanwhile) and stops planning sub-teams
        #: at ``plan_budget`` of the period into a tick (the rest coast or hold), rather than
        #: miss periods
        self.planner = getattr(self.team.policy, "planner", None)
        if self.planner is not None and not settings.lockstep:
            self.planner.background_builds = True
        n_robots, n_targets, steps = len(scenario.robots), len(scenario.targets), scenario.steps
        self.team_rows = TeamRecorder(n_robots, n_targets, steps)
        # the targets' poses and the zones are recorded for plots only; the team never sees them
        self.truth_rows = TruthRecorder(n_targets, steps, zones)
        self.u_max = np.array([r.u_max for r in scenario.robots], dtype=float)
        #: running free: how long into a tick (s) sub-teams may plan (None: no limit)
        self.plan_budget = (
            None
            if settings.lockstep
            or settings.plan_budget is None
            or not hasattr(self.planner, "deadline")
            else settings.plan_budget * self.dt
        )
        self._tick_started = time.perf_counter()
        self.steps_done = 0
        self.holds = 0
        #: what was dropped and why, and the publishers never heard (the manifest's account)
        self.drops = DropLog()
        #: robots whose poses stopped: they hold while the team plans for the others
        self.lost: set[int] = set()
        self._holding: str | None = None  # the kind of hold since the last step
        self._heard = -np.inf  # when the last usable observation arrived (monotonic s)
        self._observations = 0  # observations taken (startup is over with the first, and poses)
        self._newest_obs: int | None = None  # stamp (ns) of the last observation used

        s = settings
        self.node = DdsNode(s.domain_id)
        pose_qos = lockstep_qos() if s.lockstep else sensor_data_qos()
        out_qos = lockstep_qos() if s.lockstep else default_qos()
        self.robots = [_Body(n, s.pose_topic(n)) for n in s.robots]
        self.targets = [_Body(n, s.pose_topic(n)) for n in s.targets]
        self._pose_readers = [
            (
                body,
                self.node.subscription(body.topic, msgs.PoseStamped, pose_qos),
                self._undecodable_on(body.topic),
            )
            for body in self.robots + self.targets
        ]
        self._obs_reader = self.node.subscription(
            OBSERVATION_TOPIC, msgs.TeamObservation, lockstep_qos() if s.lockstep else default_qos()
        )
        self._obs_undecodable = self._undecodable_on(OBSERVATION_TOPIC)
        self._watch = PublicationWatch(
            self.node.participant,
            {r.topic.name: r.topic.get_type_name() for r in self.node.readers},
            s.robots + s.targets,
        )
        command_type = msgs.FullState if s.command == "full_state" else msgs.Twist
        self._command_writers = [
            self.node.publisher(s.command_topic(name), command_type, out_qos) for name in s.robots
        ]
        self._belief_writer = self.node.publisher(BELIEF_TOPIC, msgs.MarkerArray, default_qos(1))
        #: running free, the belief markers are serialized and written off the control path
        self._belief_out: BackgroundWriter | None = (
            None
            if s.lockstep
            else BackgroundWriter(
                self._belief_writer, "rtrack-markers", lambda m: self._record(BELIEF_TOPIC, m)
            )
        )
        self._pending: deque[msgs.TeamObservation] = deque()

    def warm_up(self) -> None:
        """Build (and compile) the league problems the mission is likely to need, before the
        loop starts: the scenario is run once in simulation with this node's policy and seed,
        and every structure it meets stays in the process-wide cache. The node's own solvers
        are still created at first use (1-13 ms each at 20 robots on compiled code)."""
        from resilient_tracking.planning.nlp_cache import wait_for_compilers
        from resilient_tracking.sim.episode import run_episode

        run_episode(self.scenario, policy=self.policy, seed=self.seed)
        wait_for_compilers()

    # ------------------------------------------------------------------ loop

    def run(
        self,
        stop: threading.Event | None = None,
        progress: Callable[[int], object] | None = None,
    ) -> EpisodeResult:
        """Step the team on every observation until the scenario's steps are done.

        Returns early, with the steps recorded so far, when ``stop`` is set or when no
        observation came for ``give_up`` seconds; raises :class:`StartupTimeout` when no
        observation, or no pose of some robot, came within ``startup_timeout`` of the start.
        """
        s = self.settings
        started = time.perf_counter()
        try:
            with _frozen_heap(not s.lockstep):
                self._loop(stop, progress)
        finally:
            if self.planner is not None:
                self.planner.close()
            if self._belief_out is not None:
                self._belief_out.close()
        wall = time.perf_counter() - started
        manifest = episode_manifest(self.scenario, self.seed, self.policy, self.steps_done, wall)
        manifest["transport"] = {
            "kind": "ros2-dds",
            "lockstep": s.lockstep,
            "command": s.command,
            "pose_timeout": s.pose_timeout,
            "observation_timeout": s.observation_timeout,
            "holds": self.holds,
            "dropped_messages": self.dropped,
            **self.drops.manifest(),
            # belief marker sets replaced by a newer one before they were written (free running)
            "markers_dropped": self._belief_out.dropped if self._belief_out is not None else 0,
        }
        return EpisodeResult(
            join_tables(self.team_rows.tables(), self.truth_rows.tables()), manifest
        )

    @property
    def dropped(self) -> int:
        """Messages dropped so far (by topic and reason: :attr:`drops`)."""
        return self.drops.total

    def _loop(self, stop: threading.Event | None, progress: Callable[[int], object] | None) -> None:
        s = self.settings
        started = self._heard = time.monotonic()
        last_hold = -np.inf
        ready = False
        while self.steps_done < self.scenario.steps and not (stop is not None and stop.is_set()):
            self.node.wait(min(self.dt, 0.05))
            now = time.monotonic()
            self._drain(now)
            if not ready:
                ready = self._observations > 0 and all(b.latest is not None for b in self.robots)
                if not ready and now - started > s.startup_timeout:
                    raise StartupTimeout(self._missing())
            if self._pending and self._process_next(now):
                if progress is not None:
                    progress(1)
                continue
            silent = now - self._heard
            if ready and silent > s.give_up:
                log.warning("no observation for %.1f s: giving up", silent)
                break
            if silent > s.observation_timeout and now - last_hold >= self.dt:
                self.hold(
                    f"no observation for {silent:.1f} s (is the world node running?)",
                    "no observation",
                )
                last_hold = now

    def _missing(self) -> str:
        """One line: what did not arrive within the startup timeout, and what was heard
        instead."""
        s = self.settings
        parts = []
        if not self._observations:
            parts.append(f"no observation on {OBSERVATION_TOPIC} (is rtrack world running?)")
        silent = [b.topic for b in self.robots if b.latest is None]
        if silent:
            parts.append(f"no pose on {', '.join(silent)}")
        unknown = self.drops.unknown_names()
        if unknown:
            parts.append(
                f"poses were published for {', '.join(unknown)}, which this scenario does not "
                "have (see --robot-prefix and --target-prefix)"
            )
        parts += [
            f"{topic} has a publisher of {type_name}, which is not heard"
            for (topic, type_name), reason in self.drops.ignored.items()
            if reason == "wrong_type"
        ]
        return (
            f"nothing to track with after {s.startup_timeout:g} s on DDS domain "
            f"{self.node.participant.domain_id}: {'; '.join(parts)}"
        )

    def _drain(self, now: float) -> None:
        self._tick_started = time.perf_counter()
        s = self.settings
        wall = time.time_ns()
        tolerance = None if s.lockstep else s.pose_timeout
        for body, reader, undecodable in self._pose_readers:
            for msg in take(reader, undecodable=undecodable):
                self._record(body.topic, msg)
                try:
                    body.add(msg, now, wall, tolerance)
                except MessageError as err:
                    self._drop(body.topic, err)
        for msg in take(self._obs_reader, undecodable=self._obs_undecodable):
            self._record(OBSERVATION_TOPIC, msg)
            if not s.lockstep:
                try:
                    self._check_order(msg, wall)
                except MessageError as err:
                    self._drop(OBSERVATION_TOPIC, err)
                    continue
            self._pending.append(msg)
            self._observations += 1
        for topic, type_name, reason in self._watch.poll():
            self.drops.ignore(topic, type_name, reason)

    def _check_order(self, msg: msgs.TeamObservation, wall_ns: int) -> None:
        """Running free: an observation's stamp must be within ``observation_timeout`` of this
        computer's clock and after that of the last observation used (not merely taken: an
        unusable one stamped later must not make the next good one look out of order)."""
        stamp = stamp_ns(msg.header.stamp)
        timeout = self.settings.observation_timeout
        check_stamp(stamp, wall_ns, self._newest_obs, timeout, OBSERVATION_TOPIC)

    def _process_next(self, now: float) -> bool:
        """Use the next observation; returns whether a step was taken."""
        if self.settings.lockstep:
            self._heard = now  # the world is there; the poses may still be on their way
            while self._pending and self._pending[0].step < self.steps_done:
                self._pending.popleft()  # a repeat of a step already taken
            if not self._pending:
                return False
            msg = self._pending[0]
            key = stamp_ns(msg.header.stamp)
            if not all(key in b.by_stamp for b in self.robots + self.targets):
                return False  # its poses are still on their way
            self._pending.popleft()
            positions = np.array([b.by_stamp[key] for b in self.robots])
            truth_xy = np.array([b.by_stamp[key] for b in self.targets])
            obs = self._observation(msg, positions)
            return obs is not None and self._step(msg, obs, positions, truth_xy)
        never = [b.name for b in self.robots if b.latest is None]
        if never:
            self._pending.clear()
            self._heard = now
            self.hold(f"no pose yet of {', '.join(never)}", "no pose yet")
            return False
        positions = np.array([b.latest for b in self.robots])
        # running late, only the newest usable observation counts; older ones are passed over
        waiting = sorted(self._pending, key=lambda m: stamp_ns(m.header.stamp), reverse=True)
        self._pending.clear()
        for msg in waiting:
            obs = self._observation(msg, positions)
            if obs is not None:
                break
        else:
            return False  # none usable: as if none came (no observation for long: hold)
        self._heard = now
        self._newest_obs = stamp_ns(msg.header.stamp)
        lost = {
            i for i, b in enumerate(self.robots) if now - b.received_at > self.settings.pose_timeout
        }
        truth_xy = np.array(
            [b.latest if b.latest is not None else [np.nan, np.nan] for b in self.targets]
        )
        return self._step(msg, obs, positions, truth_xy, lost, now)

    def _observation(
        self, msg: msgs.TeamObservation, positions: np.ndarray
    ) -> TeamObservation | None:
        """The team's observation of ``msg``, or None when it was dropped."""
        try:
            return observation_from_msg(
                msg, positions, len(self.targets), self.team.measurement_dim
            )
        except MessageError as err:
            self._drop(OBSERVATION_TOPIC, err)
            return None

    def _step(
        self,
        msg: msgs.TeamObservation,
        obs: TeamObservation,
        positions: np.ndarray,
        truth_xy: np.ndarray,
        lost: set[int] | None = None,
        now: float = 0.0,
    ) -> bool:
        lost = lost or set()
        if lost:  # measurements placed at a position no longer known are not used
            z = obs.measurements.copy()
            z[sorted(lost)] = np.nan
            obs = dataclasses.replace(obs, measurements=z)
        if self.plan_budget is not None and self.planner is not None:
            self.planner.deadline = self._tick_started + self.plan_budget
        try:
            out = self.team.step(obs)
        except Exception as err:  # a planner that fails must not stop the robots' safety
            log.warning("step %d: team step failed (%s: %s)", obs.step, type(err).__name__, err)
            self.hold("team step failed")
            return False
        ws = self.scenario.workspace
        applied = clip_velocities(
            obs.positions, out.controls, self.u_max, ws.lower, ws.upper, self.dt
        )
        if not np.isfinite(applied).all():
            self.hold(f"step {obs.step}: non-finite command", "non-finite command")
            return False
        if lost or self.lost:
            out, applied = self._hold_lost(obs.step, out, applied, lost, now)
        self._publish_commands(positions, applied, msg.header.stamp)
        self.team_rows.step(obs, out, applied, self.team.belief)
        estimate = self.team.belief.team_estimate()
        self.truth_rows.step(obs.step, truth_xy, estimate.mean[:, :2], estimate.cov[:, :2, :2])
        header = msgs.Header(stamp=msg.header.stamp, frame_id=self.settings.frame)
        view = BeliefView.of(self.team.belief, positions, out.decision.modes)
        altitude = self.settings.altitude
        if self._belief_out is not None:  # built, written and recorded in the worker thread
            self._belief_out.write(lambda: markers_of(view, header, altitude))
        else:
            markers = markers_of(view, header, altitude)
            self._belief_writer.write(markers)
            self._record(BELIEF_TOPIC, markers)
        self.steps_done += 1
        self._holding = None
        return True

    def _hold_lost(
        self, step: int, out: TeamStep, applied: np.ndarray, lost: set[int], now: float
    ) -> tuple[TeamStep, np.ndarray]:
        """The tick with every robot in ``lost`` holding its last seen position (zero velocity,
        mode ``hold``), and a ``pose_lost`` or ``pose_regained`` event for each robot that
        changed."""
        events = list(out.events)
        timeout = self.settings.pose_timeout
        for i in sorted(lost - self.lost):
            silent = now - self.robots[i].received_at
            events.append(Event.pose_lost(step, i, silent, timeout))
            log.warning(
                "step %d: no pose of %s for %.2f s: it holds position, the team plans for the "
                "others",
                step,
                self.robots[i].name,
                silent,
            )
        for i in sorted(self.lost - lost):
            events.append(Event.pose_regained(step, i))
            log.info("step %d: poses of %s arrive again", step, self.robots[i].name)
        self.lost = set(lost)
        held = sorted(lost)
        applied = applied.copy()
        applied[held] = 0.0
        modes = list(out.decision.modes)
        for i in held:
            modes[i] = "hold"
        decision = dataclasses.replace(out.decision, modes=modes)
        return dataclasses.replace(out, decision=decision, events=events), applied

    # ------------------------------------------------------------------ commands

    def _publish_commands(
        self, positions: np.ndarray, velocities: np.ndarray, stamp: msgs.Time
    ) -> None:
        s = self.settings
        for i, writer in enumerate(self._command_writers):
            command: msgs.FullState | msgs.Twist
            if s.command == "full_state":
                command = full_state(
                    positions[i], velocities[i], s.altitude, self.dt, stamp, s.frame
                )
            else:
                command = twist(velocities[i])
            writer.write(command)
            self._record(s.command_topic(s.robots[i]), command)

    def hold(self, reason: str, kind: str | None = None) -> None:
        """Command every robot to stay where it was last seen, and say why: a warning for the
        first hold of a ``kind`` (default: the reason) since the last step, then at debug level
        (the node holds every period while, say, no observation comes)."""
        self.holds += 1
        kind = reason if kind is None else kind
        repeated = kind == self._holding
        self._holding = kind
        log.log(logging.DEBUG if repeated else logging.WARNING, "holding position: %s", reason)
        positions = [b.latest for b in self.robots]
        stamp = stamp_from_ns(time.time_ns())
        s = self.settings
        for i, writer in enumerate(self._command_writers):
            xy = positions[i]
            if s.command == "full_state":
                if xy is None:
                    continue  # never seen: no position to hold
                command: msgs.FullState | msgs.Twist = full_state(
                    xy, np.zeros(2), s.altitude, self.dt, stamp, s.frame
                )
            else:
                command = twist(np.zeros(2))
            writer.write(command)
            self._record(s.command_topic(s.robots[i]), command)

    def _drop(self, topic: str, err: MessageError) -> None:
        self.drops.drop(topic, err.reason, str(err))

    def _undecodable_on(self, topic: str) -> Callable[[Exception], None]:
        def undecodable(err: Exception) -> None:
            self.drops.drop(topic, "undecodable", f"{topic}: {type(err).__name__}: {err}")

        return undecodable

    def _record(self, topic: str, msg: IdlStruct) -> None:
        if self.bag is not None:
            self.bag.write(topic, msg, time.time_ns())
