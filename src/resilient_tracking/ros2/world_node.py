"""The world node: the truth side of the loop over DDS, simulated or from motion capture.

``sim``: it integrates robot and target motion from the commands the tracker publishes, as
``rtrack run`` does, and publishes robot and target poses and the synthesized observation each
tick (software in the loop). In lock-step it waits for every robot's command before stepping, so
the run is deterministic; otherwise it steps at wall-clock rate with the latest commands (a
robot without a recent command stands still).

``mocap``: robot and target poses come from motion-capture topics; the node only synthesizes
measurements, attacks and jamming from the scenario's virtual zones at the measured positions,
as in the paper's hardware experiments.
"""

from __future__ import annotations

import logging
import threading
import time
from collections import deque
from collections.abc import Callable
from typing import Literal

import numpy as np

from resilient_tracking.ros2 import msgs
from resilient_tracking.ros2.convert import (
    MessageError,
    command_velocity,
    observation_to_msg,
    pose_stamped,
    pose_xy,
    stamp_from_ns,
    step_stamp,
)
from resilient_tracking.ros2.topics import OBSERVATION_TOPIC, NodeSettings
from resilient_tracking.ros2.transport import (
    DdsNode,
    default_qos,
    lockstep_qos,
    sensor_data_qos,
    take,
)
from resilient_tracking.scenario import Scenario
from resilient_tracking.world import World

log = logging.getLogger(__name__)

WorldMode = Literal["sim", "mocap"]


class WorldNode:
    """Publishes the world of ``scenario`` and applies the tracker's commands."""

    def __init__(self, scenario: Scenario, seed: int, settings: NodeSettings, mode: WorldMode):
        if mode == "mocap" and settings.lockstep:
            raise ValueError("--lockstep: needs --mode sim (motion capture runs in real time)")
        self.scenario, self.settings, self.mode = scenario, settings, mode
        self.world = World(scenario, seed)
        self.dt = scenario.dt
        s = settings
        self.node = DdsNode(s.domain_id)
        qos = lockstep_qos() if s.lockstep else default_qos()
        self._obs_writer = self.node.publisher(OBSERVATION_TOPIC, msgs.TeamObservation, qos)
        names = s.robots + s.targets
        if mode == "sim":
            self._pose_writers = [
                self.node.publisher(s.pose_topic(n), msgs.PoseStamped, qos) for n in names
            ]
            command_type = msgs.FullState if s.command == "full_state" else msgs.Twist
            self._command_readers = [
                self.node.subscription(s.command_topic(n), command_type, qos) for n in s.robots
            ]
        else:
            self._pose_readers = [
                self.node.subscription(s.pose_topic(n), msgs.PoseStamped, sensor_data_qos())
                for n in names
            ]
            self._latest: list[np.ndarray | None] = [None] * len(names)
            self._seen_at = np.full(len(names), -np.inf)
        self.steps_done = 0

    def run(
        self,
        stop: threading.Event | None = None,
        progress: Callable[[int], object] | None = None,
    ) -> int:
        """Run the scenario's steps; returns how many were completed."""
        stopped = stop if stop is not None else threading.Event()
        if self.mode == "mocap":
            return self._run_mocap(stopped, progress)
        if self.settings.lockstep:
            return self._run_lockstep(stopped, progress)
        return self._run_free(stopped, progress)

    # ------------------------------------------------------------------ sim

    def _publish(self, stamp: msgs.Time) -> None:
        world, s = self.world, self.settings
        positions = list(world.robot_positions) + [t.position for t in world.targets]
        altitudes = [s.altitude] * len(s.robots) + [0.0] * len(s.targets)
        for writer, xy, z in zip(self._pose_writers, positions, altitudes, strict=True):
            writer.write(pose_stamped(xy, z, stamp, s.frame))
        self._obs_writer.write(observation_to_msg(world.observe(), stamp, s.frame))

    def _run_lockstep(self, stop: threading.Event, progress: Callable[[int], object] | None) -> int:
        s = self.settings
        writers = [self._obs_writer, *self._pose_writers]
        if not self.node.wait_matched(writers, self._command_readers, s.startup_timeout):
            raise TimeoutError(
                f"no tracker node appeared within {s.startup_timeout:.0f} s "
                f"(domain {self.node.participant.domain_id})"
            )
        queues: list[deque[np.ndarray]] = [deque() for _ in s.robots]
        for k in range(self.scenario.steps):
            self._publish(step_stamp(k, self.dt))
            commands = self._await_commands(queues, stop)
            if commands is None:
                break
            self._apply(commands)
            self.steps_done = k + 1
            if progress is not None:
                progress(1)
        return self.steps_done

    def _await_commands(
        self, queues: list[deque[np.ndarray]], stop: threading.Event
    ) -> np.ndarray | None:
        """One command per robot, in order; None when the tracker is gone or silent too long."""
        deadline = time.monotonic() + self.settings.give_up
        while not all(queues):
            if stop.is_set():
                return None
            if time.monotonic() > deadline:
                log.warning("no command for %.0f s: stopping", self.settings.give_up)
                return None
            self.node.wait(0.05)
            self._take_commands(lambda i, v: queues[i].append(v))
        return np.array([q.popleft() for q in queues])

    def _take_commands(self, put: Callable[[int, np.ndarray], object]) -> None:
        s = self.settings
        for i, reader in enumerate(self._command_readers):
            for msg in take(reader):
                try:
                    put(i, command_velocity(msg, s.command_topic(s.robots[i])))
                except MessageError as err:
                    log.warning("dropped a malformed command: %s", err)

    def _apply(self, commands: np.ndarray) -> None:
        """Commands already clipped by the tracker are applied as they are (bit for bit)."""
        if self._within_limits(commands):
            self.world.advance(commands)
        else:
            self.world.step(commands)

    def _within_limits(self, commands: np.ndarray) -> bool:
        world, ws = self.world, self.scenario.workspace
        if (np.abs(commands) > world.u_max[:, None]).any():
            return False
        nxt = world.robot_positions + commands * self.dt
        return bool(((nxt >= ws.lower - 1e-9) & (nxt <= ws.upper + 1e-9)).all())

    def _run_free(self, stop: threading.Event, progress: Callable[[int], object] | None) -> int:
        m = len(self.settings.robots)
        latest = np.zeros((m, 2))
        seen_at = np.full(m, -np.inf)

        def put(i: int, v: np.ndarray) -> None:
            latest[i] = v
            seen_at[i] = time.monotonic()

        next_tick = time.monotonic()
        for k in range(self.scenario.steps):
            if stop.is_set():
                break
            self._publish(stamp_from_ns(time.time_ns()))
            next_tick += self.dt
            while (left := next_tick - time.monotonic()) > 0:
                self.node.wait(left)
                self._take_commands(put)
            fresh = time.monotonic() - seen_at <= self.settings.observation_timeout
            self.world.step(np.where(fresh[:, None], latest, 0.0))
            self.steps_done = k + 1
            if progress is not None:
                progress(1)
        return self.steps_done

    # ------------------------------------------------------------------ motion capture

    def _run_mocap(self, stop: threading.Event, progress: Callable[[int], object] | None) -> int:
        s = self.settings
        m = len(s.robots)
        deadline = time.monotonic() + s.startup_timeout
        while any(p is None for p in self._latest):
            if stop.is_set():
                return 0
            if time.monotonic() > deadline:
                names = s.robots + s.targets
                missing = [n for n, p in zip(names, self._latest, strict=True) if p is None]
                raise TimeoutError(f"no motion-capture pose for {', '.join(missing)}")
            self.node.wait(0.05)
            self._take_poses()
        self.world.place(np.array(self._latest[:m]), np.array(self._latest[m:]), first=True)
        next_tick = time.monotonic()
        for k in range(self.scenario.steps):
            if stop.is_set():
                break
            obs = self.world.observe()
            self._obs_writer.write(observation_to_msg(obs, stamp_from_ns(time.time_ns()), s.frame))
            next_tick += self.dt
            while (left := next_tick - time.monotonic()) > 0:
                self.node.wait(left)
                self._take_poses()
            stale = time.monotonic() - self._seen_at > s.pose_timeout
            if stale.any():
                names = [n for n, old in zip(s.robots + s.targets, stale, strict=True) if old]
                log.warning("stale motion-capture pose of %s: using the last one", ", ".join(names))
            self.world.place(np.array(self._latest[:m]), np.array(self._latest[m:]))
            self.steps_done = k + 1
            if progress is not None:
                progress(1)
        return self.steps_done

    def _take_poses(self) -> None:
        names = self.settings.robots + self.settings.targets
        for i, reader in enumerate(self._pose_readers):
            for msg in take(reader):
                try:
                    self._latest[i] = pose_xy(msg, self.settings.pose_topic(names[i]))
                    self._seen_at[i] = time.monotonic()
                except MessageError as err:
                    log.warning("dropped a malformed pose: %s", err)
