"""The tracker and world nodes over DDS on the loopback interface (no ROS 2 install needed).

Every test uses its own DDS domain and CycloneDDS restricted to 127.0.0.1, so parallel runs do
not hear each other; every process a test starts is killed and reaped before it ends.
"""

from __future__ import annotations

import dataclasses
import itertools
import logging
import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from cyclonedds.builtin import BuiltinDataReader, BuiltinTopicDcpsPublication
from rosbags.rosbag2 import Reader

from helpers import SCENARIOS, shipped
from resilient_tracking import cli
from resilient_tracking.ros2 import msgs
from resilient_tracking.ros2.bag import typestore
from resilient_tracking.ros2.convert import observation_to_msg, pose_stamped, stamp_from_ns
from resilient_tracking.ros2.topics import OBSERVATION_TOPIC, NodeSettings
from resilient_tracking.ros2.tracker_node import StartupTimeout, TrackerNode
from resilient_tracking.ros2.transport import DdsNode, default_qos, loopback_config, take
from resilient_tracking.runs.records import EpisodeResult
from resilient_tracking.runs.schema import REPRODUCIBLE
from resilient_tracking.sim.episode import run_episode, start_truth
from resilient_tracking.world import World

ROOT = Path(__file__).resolve().parents[1]
_domains = itertools.count()


@pytest.fixture
def domain(monkeypatch: pytest.MonkeyPatch) -> int:
    """A DDS domain of this test alone, on loopback (also for DDS used inside the test)."""
    monkeypatch.setenv("CYCLONEDDS_URI", loopback_config())
    return 1 + (os.getpid() * 7 + next(_domains)) % 230


@pytest.fixture
def spawn(tmp_path: Path, domain: int) -> Iterator:
    """Start ``rtrack`` commands; all of them are killed and reaped when the test ends."""
    started: list[subprocess.Popen[bytes]] = []

    def start(name: str, *args: str) -> subprocess.Popen[bytes]:
        log = open(tmp_path / f"{name}.log", "wb")  # noqa: SIM115 - closed with the process
        proc = subprocess.Popen(
            [sys.executable, "-m", "resilient_tracking.cli", *args, "--domain", str(domain), "-q"],
            stdout=log,
            stderr=subprocess.STDOUT,
            env={**os.environ, "CYCLONEDDS_URI": loopback_config()},
            cwd=tmp_path,
        )
        log.close()
        started.append(proc)
        return proc

    yield start
    for proc in started:
        if proc.poll() is None:
            proc.kill()
        proc.wait(timeout=30)


def _hash(df: pd.DataFrame) -> bytes:
    return (
        pd.util.hash_pandas_object(df, index=True).to_numpy().tobytes()
        + repr(list(df.dtypes.items())).encode()
    )


@pytest.mark.slow
def test_lockstep_run_between_two_processes_equals_rtrack_run(spawn, tmp_path: Path) -> None:
    scenario = str(SCENARIOS / "sensing-temp.yaml")
    world = spawn("world", "world", scenario, "--seed", "3", "--lockstep")
    node = spawn("node", "node", scenario, "--seed", "3", "--lockstep", "--out", "N", "--bag", "B")
    assert node.wait(timeout=120) == 0, (tmp_path / "node.log").read_text()
    assert world.wait(timeout=30) == 0, (tmp_path / "world.log").read_text()
    reference = run_episode(shipped("sensing-temp"), seed=3)
    for name in REPRODUCIBLE:
        over_dds = pd.read_parquet(tmp_path / "N" / f"{name}.parquet")
        assert _hash(over_dds) == _hash(reference[name]), name
    # the bag holds what travelled, decodable with ROS 2's definitions
    store = typestore()
    with Reader(tmp_path / "B") as bag:
        counts = {c.topic: c.msgcount for c in bag.connections}
        assert counts["/cf1/cmd_full_state"] == 300
        assert counts["/rtrack/observation"] == 300
        assert counts["/rtrack/belief"] == 300
        conn = next(c for c in bag.connections if c.topic == "/cf2/cmd_full_state")
        first = next(bag.messages(connections=[conn]))
        cmd = store.deserialize_cdr(first[2], conn.msgtype)
    robots = reference["robots"]
    ux0 = robots[(robots.step == 0) & (robots.robot == 1)].ux.item()
    assert cmd.twist.linear.x == ux0
    assert cmd.pose.position.z == 0.5


@pytest.mark.slow
def test_world_exiting_mid_run_makes_the_tracker_hold(spawn, tmp_path: Path, domain) -> None:
    scenario = str(SCENARIOS / "sensing-temp.yaml")
    listener = DdsNode(domain)
    commands = listener.subscription("/cf1/cmd_full_state", msgs.FullState, default_qos(100))
    world = spawn("world", "world", scenario)
    node = spawn("node", "node", scenario, "--out", "N", "--observation-timeout", "0.3")
    received: list[msgs.FullState] = []

    def collect(seconds: float, until: int | None = None) -> None:
        end = time.monotonic() + seconds
        while time.monotonic() < end and (until is None or len(received) < until):
            listener.wait(0.1)
            received.extend(take(commands))

    collect(60, until=10)  # free running at 10 Hz: a second of commands
    assert len(received) >= 10, (tmp_path / "node.log").read_text()
    world.kill()
    world.wait(timeout=10)
    flying = len(received)
    collect(2.0)
    holds = received[flying:]
    assert holds and all(c.twist.linear.x == 0.0 and c.twist.linear.y == 0.0 for c in holds[-3:])
    last = holds[-1].pose.position
    assert np.isfinite([last.x, last.y]).all() and last.z == 0.5
    node.send_signal(signal.SIGTERM)
    assert node.wait(timeout=30) == 3  # stopped before the scenario's steps were done
    log = (tmp_path / "node.log").read_text()
    assert "holding position: no observation" in log
    steps = len(pd.read_parquet(tmp_path / "N" / "team.parquet"))
    assert 0 < steps < 300


class _InProcess:
    """A free-running tracker node in a thread, fed by hand-written messages stamped with this
    computer's clock (as a free-running world stamps them); it must never stop with an error
    (checked on leaving), and :attr:`result` holds its run."""

    def __init__(self, domain: int, **options: float):
        self.scenario = shipped("sensing-temp")
        settings = NodeSettings.for_scenario(
            self.scenario,
            domain_id=domain,
            **{"pose_timeout": 5.0, "observation_timeout": 60.0, **options},  # type: ignore[arg-type]
        )
        self.settings = settings
        initial, zones = start_truth(self.scenario, 1)
        self.node = TrackerNode(self.scenario, 1, "failure_aware", settings, initial, zones=zones)
        self.feed = DdsNode(domain)
        self.poses = {
            n: self.feed.publisher(settings.pose_topic(n), msgs.PoseStamped, default_qos())
            for n in settings.robots + settings.targets
        }
        self.obs = self.feed.publisher(OBSERVATION_TOPIC, msgs.TeamObservation, default_qos())
        self.world = World(self.scenario, 1)
        self.k = 0  # the step of the next observation
        self.stop = threading.Event()
        self.result: EpisodeResult | None = None
        self.thread = threading.Thread(target=self._run)

    def _run(self) -> None:
        self.result = self.node.run(stop=self.stop)

    def __enter__(self) -> _InProcess:
        readers = self.node.node.readers
        assert self.feed.wait_matched(self.feed.writers, [], 10.0)
        assert all(r.get_subscription_matched_status().current_count for r in readers)
        self.thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop.set()
        self.thread.join(timeout=10)
        assert not self.thread.is_alive()
        assert self.result is not None, "the node stopped with an error"

    def send_poses(self, names: list[str], xy: np.ndarray | None = None) -> int:
        """Poses of ``names`` stamped now (robot ``i``'s start or ``xy``); returns the stamp."""
        stamp = time.time_ns()
        for i, name in enumerate(names):
            point = self.world.robot_positions[i % 3] if xy is None else xy
            self.poses[name].write(pose_stamped(point, 0.5, stamp_from_ns(stamp), "world"))
        return stamp

    def taken(self, names: list[str], stamp: int) -> bool:
        """Whether the node has taken the poses of ``names`` stamped ``stamp``."""
        bodies = {b.name: b for b in self.node.robots + self.node.targets}
        return all(bodies[n].newest == stamp for n in names)

    def send_all_poses(self) -> None:
        """Poses of every robot and target, and wait until the node has taken them."""
        names = self.settings.robots + self.settings.targets
        stamp = self.send_poses(names)
        assert self.wait_for(lambda: self.taken(names, stamp))

    def observation(self, **change: object) -> msgs.TeamObservation:
        """The next observation message, stamped now."""
        msg = observation_to_msg(self.world.observe(), stamp_from_ns(time.time_ns()), "world")
        self.k += 1
        return dataclasses.replace(msg, step=self.k - 1, **change)

    def send_observation(self, **change: object) -> None:
        self.obs.write(self.observation(**change))

    def wait_for(self, condition, seconds: float = 10.0) -> bool:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            if condition():
                return True
            time.sleep(0.01)
        return False


def test_a_robot_never_heard_from_makes_the_team_hold(domain, caplog) -> None:
    caplog.set_level(logging.WARNING)
    with _InProcess(domain) as run:
        names = ["cf1", "cf2", "target1", "target2", "target3"]  # cf3 never reported
        stamp = run.send_poses(names)
        assert run.wait_for(lambda: run.taken(names, stamp))
        run.send_observation()
        assert run.wait_for(lambda: run.node.holds > 0)
        assert run.node.steps_done == 0
        stamp = run.send_poses(["cf3"])
        assert run.wait_for(lambda: run.taken(["cf3"], stamp))
        run.send_observation()
        assert run.wait_for(lambda: run.node.steps_done == 1)
    assert "holding position: no pose yet of cf3" in caplog.text


def test_malformed_messages_are_dropped_with_the_field_named(domain, caplog) -> None:
    caplog.set_level(logging.DEBUG, "resilient_tracking.ros2.drops")  # a warning for the first
    with _InProcess(domain) as run:
        run.send_all_poses()
        for bad in ([np.nan, 0.0], [np.inf, 0.0]):
            stamp = stamp_from_ns(time.time_ns())
            run.poses["cf2"].write(pose_stamped(np.array(bad), 0.5, stamp, "world"))
        run.send_observation(measurements=[1.0] * 5)
        links = np.eye(3, dtype=bool)
        links[0, 1] = True  # a link that works one way only
        run.send_observation(links=links.ravel().tolist())
        assert run.wait_for(lambda: run.node.dropped == 4)
        assert run.node.steps_done == 0
        run.send_observation()
        assert run.wait_for(lambda: run.node.steps_done == 1)
    assert "/cf2/pose: pose.position is not finite" in caplog.text
    assert "observation.measurements: expected 18 values, got 5" in caplog.text
    assert "TeamObservation.links: must be symmetric" in caplog.text
    transport = run.result.manifest["transport"]
    assert transport["drops"] == {"invalid": 2, "not_finite": 2}
    assert transport["drops_by_topic"] == {
        "/cf2/pose": {"not_finite": 2},
        "/rtrack/observation": {"invalid": 2},
    }


def _not_utf8(msg: msgs.PoseStamped | msgs.TeamObservation) -> bytes:
    """``msg`` (its ``header.frame_id`` "é") as CDR bytes whose frame_id is not UTF-8: framing
    that cyclonedds' own check lets through, a string Python cannot decode."""
    data = msg.serialize()
    at = data.index(b"\x03\x00\x00\x00\xc3\xa9\x00")  # length 3, "é", NUL
    return data[: at + 4] + b"\xff\xfe" + data[at + 6 :]


def _raw(msg_type: type, data: bytes) -> object:
    """A sample of ``msg_type`` that a DDS writer sends as ``data``, as a peer might."""

    class Raw(msg_type):  # type: ignore[misc, valid-type]
        def serialize(self, *args: object, **kwargs: object) -> bytes:
            return data

    return Raw()


def test_undecodable_payloads_are_dropped_and_the_rest_of_their_batch_kept(domain) -> None:
    with _InProcess(domain) as run:
        run.send_all_poses()
        stamp = stamp_from_ns(time.time_ns())
        bad_pose = _not_utf8(pose_stamped(np.array([9.0, 9.0]), 0.5, stamp, "\xe9"))
        run.poses["cf1"].write(_raw(msgs.PoseStamped, bad_pose))
        good = run.send_poses(["cf1"], np.array([0.25, 0.75]))  # after it, in the same batch
        bad_obs = dataclasses.replace(run.observation(), header=msgs.Header(stamp, "\xe9"))
        run.obs.write(_raw(msgs.TeamObservation, _not_utf8(bad_obs)))
        assert run.wait_for(lambda: run.node.dropped == 2 and run.taken(["cf1"], good))
        assert run.node.robots[0].latest.tolist() == [0.25, 0.75]
        run.send_observation()
        assert run.wait_for(lambda: run.node.steps_done == 1)
    assert run.result.manifest["transport"]["drops_by_topic"] == {
        "/cf1/pose": {"undecodable": 1},
        "/rtrack/observation": {"undecodable": 1},
    }


def test_stale_future_and_out_of_order_stamps_are_dropped(domain) -> None:
    with _InProcess(domain, pose_timeout=1.0, observation_timeout=1.0) as run:
        run.send_all_poses()
        good = run.send_poses(["cf1"], np.array([0.25, 0.75]))
        far = np.array([4.0, 4.0])
        for stamp in (good - 1000, good - 5 * 10**9, good + 5 * 10**9):  # older, stale, future
            run.poses["cf1"].write(pose_stamped(far, 0.5, stamp_from_ns(stamp), "world"))
        for shift in (-5 * 10**9, 5 * 10**9):  # a stale and a future observation
            msg = run.observation()
            late = stamp_from_ns(time.time_ns() + shift)
            run.obs.write(dataclasses.replace(msg, header=msgs.Header(late, "world")))
        assert run.wait_for(lambda: run.node.dropped == 5)
        assert run.node.robots[0].latest.tolist() == [0.25, 0.75]
        early = run.observation()  # stamped before the next one, sent after it
        run.send_observation()
        assert run.wait_for(lambda: run.node.steps_done == 1)
        run.obs.write(early)
        assert run.wait_for(lambda: run.node.dropped == 6)
    assert run.node.steps_done == 1
    assert run.result.manifest["transport"]["drops_by_topic"] == {
        "/cf1/pose": {"future": 1, "out_of_order": 1, "stale": 1},
        "/rtrack/observation": {"future": 1, "out_of_order": 1, "stale": 1},
    }


def test_an_unusable_observation_stamped_later_does_not_hold_back_the_next_good_one(
    domain,
) -> None:
    with _InProcess(domain, observation_timeout=1.0) as run:
        run.send_all_poses()
        good = run.observation()
        ahead = stamp_from_ns(time.time_ns() + 200_000_000)  # within the timeout
        bad = run.observation(measurements=[1.0] * 5, header=msgs.Header(ahead, "world"))
        run.obs.write(bad)
        assert run.wait_for(lambda: run.node.dropped == 1)
        run.obs.write(good)
        assert run.wait_for(lambda: run.node.steps_done == 1)
    assert run.result.manifest["transport"]["drops"] == {"invalid": 1}


def test_a_robot_whose_poses_stop_holds_while_the_team_plans_for_the_others(domain) -> None:
    listener = DdsNode(domain)
    commands = listener.subscription("/cf3/cmd_full_state", msgs.FullState, default_qos(100))
    with _InProcess(domain, pose_timeout=1.0) as run:
        assert listener.wait_matched([], [commands], 10.0)
        run.send_all_poses()
        run.send_observation()
        assert run.wait_for(lambda: run.node.steps_done == 1)
        cf3 = run.node.robots[2]
        last_seen = cf3.latest.copy()
        others = ["cf1", "cf2", "target1", "target2", "target3"]
        # cf3's poses stop: wait out its pose timeout, then the others report and a tick comes
        assert run.wait_for(lambda: time.monotonic() - cf3.received_at > 1.0)
        stamp = run.send_poses(others)
        assert run.wait_for(lambda: run.taken(others, stamp))
        run.send_observation()
        assert run.wait_for(lambda: run.node.steps_done == 2)
        assert run.node.lost == {2}
        run.send_all_poses()  # cf3 is back
        run.send_observation()
        assert run.wait_for(lambda: run.node.steps_done == 3)
        assert run.node.lost == set()
        assert run.node.holds == 0  # never the whole team
    events = run.result["events"]
    lost = events[events.event.isin(["pose_lost", "pose_regained"])]
    assert list(zip(lost.step, lost.robot, lost.event, lost.action, strict=True)) == [
        (1, 2, "pose_lost", "hold"),
        (2, 2, "pose_regained", ""),
    ]
    robots = run.result["robots"].set_index(["step", "robot"])
    assert robots.loc[(1, 2), "mode"] == "hold"
    assert robots.loc[(1, 2), ["ux", "uy"]].tolist() == [0.0, 0.0]
    assert robots.loc[(1, 2), ["x", "y"]].tolist() == last_seen.tolist()
    assert (robots.loc[[(1, 0), (1, 1), (2, 2)], "mode"] != "hold").all()
    assert listener.wait_matched([], [commands], 1.0)
    held = [c for c in take(commands) if c.twist.linear.x == c.twist.linear.y == 0.0]
    assert any([c.pose.position.x, c.pose.position.y] == last_seen.tolist() for c in held)


def test_publishers_of_other_types_or_unknown_names_are_listed(domain) -> None:
    other = DdsNode(domain)  # a participant of its own: one topic has one type in each
    with _InProcess(domain) as run:
        other.publisher("/cf1/pose", msgs.Twist, default_qos())  # a velocity, not a pose
        other.publisher("/cf7/pose", msgs.PoseStamped, default_qos())
        assert run.wait_for(lambda: len(run.node.drops.ignored) == 2)
        run.send_all_poses()
        run.send_observation()
        assert run.wait_for(lambda: run.node.steps_done == 1)
    assert run.result.manifest["transport"]["ignored_publishers"] == [
        {"topic": "/cf1/pose", "type": "geometry_msgs/msg/Twist", "reason": "wrong_type"},
        {"topic": "/cf7/pose", "type": "geometry_msgs/msg/PoseStamped", "reason": "unknown_name"},
    ]


@pytest.fixture
def signal_handlers() -> Iterator[None]:
    """Restores SIGINT and SIGTERM handlers that a command run in this process installs."""
    saved = {sig: signal.getsignal(sig) for sig in (signal.SIGINT, signal.SIGTERM)}
    yield
    for sig, handler in saved.items():
        signal.signal(sig, handler)


def test_the_node_stops_after_the_startup_timeout_naming_what_is_missing(
    domain, tmp_path: Path, capsys, signal_handlers
) -> None:
    scenario = str(SCENARIOS / "sensing-temp.yaml")
    out = tmp_path / "N"
    args = ["--startup-timeout", "0.5", "--give-up", "5", "--domain", str(domain), "-q"]
    assert cli.main(["node", scenario, "--out", str(out), *args]) == 1
    printed = capsys.readouterr()
    assert printed.out == ""
    assert printed.err.splitlines() == [
        f"error: --startup-timeout: nothing to track with after 0.5 s on DDS domain {domain}: "
        "no observation on /rtrack/observation (is rtrack world running?); "
        "no pose on /cf1/pose, /cf2/pose, /cf3/pose"
    ]
    assert not out.exists()


def test_the_startup_error_names_poses_published_under_other_names(domain) -> None:
    scenario = shipped("sensing-temp")
    settings = NodeSettings.for_scenario(scenario, domain_id=domain, startup_timeout=0.3)
    initial, _ = start_truth(scenario, 1)
    node = TrackerNode(scenario, 1, "failure_aware", settings, initial)
    feed = DdsNode(domain)
    feed.publisher("/cf01/pose", msgs.PoseStamped, default_qos())  # named otherwise than cf1
    announced = BuiltinDataReader(node.node.participant, BuiltinTopicDcpsPublication)
    end = time.monotonic() + 10.0
    while not any(p.topic_name == "rt/cf01/pose" for p in announced.read(N=64)):
        assert time.monotonic() < end, "the publisher was not discovered"
        time.sleep(0.01)
    with pytest.raises(StartupTimeout) as stopped:
        node.run()
    assert str(stopped.value).endswith(
        "no pose on /cf1/pose, /cf2/pose, /cf3/pose; poses were published for cf01, which this "
        "scenario does not have (see --robot-prefix and --target-prefix)"
    )


def test_without_the_extra_the_verbs_say_how_to_install_it(monkeypatch, capsys) -> None:
    monkeypatch.setitem(sys.modules, "cyclonedds", None)  # import fails as if not installed
    for verb in ("node", "world"):
        assert cli.main([verb, str(SCENARIOS / "sensing-temp.yaml")]) == 1
        assert 'pip install "resilient-tracking[ros2]"' in capsys.readouterr().err


@pytest.mark.slow
def test_base_package_does_not_import_dds() -> None:
    code = (
        "import sys, resilient_tracking.cli, resilient_tracking.sim.episode;"
        "from resilient_tracking.cli.parser import build_parser; build_parser();"
        "assert 'cyclonedds' not in sys.modules and 'rosbags' not in sys.modules"
    )
    subprocess.run([sys.executable, "-c", code], check=True, timeout=120)


def test_a_free_running_node_builds_in_the_background_and_warm_up_fills_the_cache(
    domain, monkeypatch
):
    from resilient_tracking.planning import nlp_cache as cache_module
    from resilient_tracking.planning.cache import LruCache

    monkeypatch.setattr(cache_module, "_NLPS", LruCache(cache_module.NLP_BUDGET))  # empty
    scenario = shipped("sensing-temp").with_overrides(steps=40)
    free = NodeSettings.for_scenario(scenario, domain_id=domain)
    initial, _ = start_truth(scenario, 1)
    node = TrackerNode(scenario, 1, "failure_aware", free, initial)
    assert node.planner is not None and node.planner.background_builds
    node.warm_up()  # the mission once in simulation: its structures are built now
    assert cache_module.nlp_cache().builds > 0
    locked = dataclasses.replace(free, lockstep=True)
    locked_node = TrackerNode(scenario, 1, "failure_aware", locked, initial)
    assert not locked_node.planner.background_builds
    assert locked_node.plan_budget is None and node.plan_budget is not None  # no deadline


def test_a_free_running_swarm_node_plans_its_sub_teams_by_a_deadline(domain, monkeypatch):
    """Each tick's team step runs with the planner's deadline at the budget's share of the
    period after the tick started (a lock-step node has none: the test above)."""
    scenario = shipped("swarm-40x20").with_overrides(steps=5)
    free = NodeSettings.for_scenario(scenario, domain_id=domain)
    initial, _ = start_truth(scenario, 1)
    node = TrackerNode(scenario, 1, "failure_aware", free, initial)
    assert node.plan_budget == pytest.approx(free.plan_budget * scenario.dt)
    seen = []

    def step(obs):
        seen.append(node.planner.deadline)
        raise RuntimeError("stop here")

    stub = dataclasses.make_dataclass("Obs", [("step", int)])(3)
    monkeypatch.setattr(node.team, "step", step)
    node._tick_started = 100.0
    assert not node._step(msgs.TeamObservation(), stub, np.zeros((40, 2)), np.zeros((20, 2)))
    assert seen == [pytest.approx(100.0 + free.plan_budget * scenario.dt)]


def test_a_background_writer_writes_the_newest_message_and_drops_stale_ones():
    from resilient_tracking.ros2.transport import BackgroundWriter

    class Slow:
        def __init__(self):
            self.gate, self.started, self.written = threading.Event(), threading.Event(), []

        def write(self, msg):
            self.started.set()
            assert self.gate.wait(10)
            self.written.append(msg)

    slow = Slow()
    out = BackgroundWriter(slow)  # type: ignore[arg-type]
    out.write("first")
    assert slow.started.wait(10)  # "first" is being written; the next two wait their turn
    out.write("stale")
    out.write("newest")
    slow.gate.set()
    out.close()
    assert slow.written == ["first", "newest"] and out.dropped == 1


def test_a_background_writer_builds_messages_in_its_thread_and_reports_them():
    from resilient_tracking.ros2.transport import BackgroundWriter

    written = threading.Event()

    class Sink:
        def __init__(self):
            self.written = []

        def write(self, msg):
            self.written.append(msg)
            written.set()

    sink, built_in, recorded = Sink(), [], []

    def build():
        built_in.append(threading.current_thread().name)
        return "markers"

    out = BackgroundWriter(sink, "markers-thread", recorded.append)  # type: ignore[arg-type]
    out.write(build)
    assert written.wait(10)
    out.write(lambda: 1 / 0)  # a broken build is logged, never raised into the loop
    out.close()
    assert sink.written == recorded == ["markers"]
    assert built_in == ["markers-thread"] and out.dropped == 0


@pytest.mark.slow
def test_the_free_running_loop_freezes_the_heap_and_always_unfreezes_it():
    import gc

    from resilient_tracking.ros2.tracker_node import _frozen_heap

    kept = [object() for _ in range(10)]
    with _frozen_heap(True):
        assert gc.get_freeze_count() >= len(kept)
    assert gc.get_freeze_count() == 0
    with pytest.raises(RuntimeError), _frozen_heap(True):
        raise RuntimeError("the loop failed")
    assert gc.get_freeze_count() == 0
    with _frozen_heap(False):
        assert gc.get_freeze_count() == 0
