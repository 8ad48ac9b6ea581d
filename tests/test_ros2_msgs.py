"""ROS 2 message types match ROS 2's definitions (the ``rosbags`` type store), on the wire too."""

from __future__ import annotations

import dataclasses
import typing

import numpy as np
import pytest
from cyclonedds.idl import IdlStruct
from rosbags.typesys.store import Nodetype

from helpers import shipped
from resilient_tracking.observation import Attack, TeamObservation
from resilient_tracking.ros2 import msgs
from resilient_tracking.ros2.bag import typestore
from resilient_tracking.ros2.convert import (
    MessageError,
    command_velocity,
    full_state,
    observation_from_msg,
    observation_to_msg,
    step_stamp,
)
from resilient_tracking.ros2.transport import dds_topic
from resilient_tracking.world import World

STORE = typestore()


def _describe_idl(annotation: object) -> tuple:
    """An IDL field type in the type store's terms: ('base', name), ('name', ros name), ..."""
    if annotation is str:
        return ("base", "string")
    if annotation is bool:
        return ("base", "bool")
    if isinstance(annotation, type) and issubclass(annotation, IdlStruct):
        return ("name", msgs.ros_name(annotation))
    holder = typing.get_args(annotation)[1]
    if isinstance(holder, str):  # Annotated[float, "float64"] and the like
        return ("base", holder)
    if type(holder).__name__ == "array":
        return ("array", _describe_idl(holder.subtype), holder.length)
    return ("sequence", _describe_idl(holder.subtype), 0)


def _describe_store(node: tuple) -> tuple:
    kind, detail = node
    if kind == Nodetype.BASE:
        return ("base", detail[0])
    if kind == Nodetype.NAME:
        return ("name", detail)
    sub, length = detail
    return (
        "array" if kind == Nodetype.ARRAY else "sequence",
        _describe_store(sub),
        length if kind == Nodetype.ARRAY else 0,
    )


@pytest.mark.parametrize("name", sorted(msgs.MESSAGE_TYPES))
def test_fields_match_ros2_definition(name: str) -> None:
    cls = msgs.MESSAGE_TYPES[name]
    package, _, base = name.split("/")
    assert cls.__idl_typename__ == f"{package}::msg::dds_::{base}_"
    ours = [
        (f.name, _describe_idl(typing.get_type_hints(cls, include_extras=True)[f.name]))
        for f in dataclasses.fields(cls)
    ]
    theirs = [(f, _describe_store(t)) for f, t in STORE.fielddefs[name][1]]
    assert ours == theirs


def _eventful_observation() -> TeamObservation:
    """A combined-zone observation with unmeasured targets, an attack of each kind and a
    recovery, so every field of the message carries something."""
    scenario = shipped("combined-temp")
    world = World(scenario, 3)
    for _ in range(5):
        world.step(np.full((len(scenario.robots), 2), 0.3))
    obs = world.observe()
    attacks = tuple(
        Attack(robot=i, clue=zone.clue(), cause=cause)  # type: ignore[arg-type]
        for i, (zone, cause) in enumerate(zip(world.zones[:2], ("hazard", "jamming"), strict=True))
    )
    obs = dataclasses.replace(obs, attacks=attacks, recoveries=((2, "comm"),))
    obs.measurements[1, 2] = np.nan
    return obs


def _filled_observation() -> msgs.TeamObservation:
    obs = _eventful_observation()
    return observation_to_msg(obs, step_stamp(obs.step, 0.1), "world")


def test_cdr_round_trip_between_cyclonedds_and_rosbags() -> None:
    samples: list[IdlStruct] = [
        _filled_observation(),
        full_state(np.array([1.25, -0.5]), np.array([0.1, 0.2]), 0.5, 0.1, step_stamp(7, 0.1), "w"),
        msgs.MarkerArray(
            markers=[msgs.Marker(ns="t", id=3, points=[msgs.Point(1, 2, 3)], text="x")]
        ),
        msgs.PoseStamped(pose=msgs.Pose(position=msgs.Point(1.5, -2.0, 0.5))),
    ]
    for sample in samples:
        name = msgs.ros_name(type(sample))
        wire = sample.serialize()
        assert wire[:4] == b"\x00\x01\x00\x00"  # plain CDR, little endian, as ROS 2 sends
        theirs = STORE.deserialize_cdr(wire, name)
        assert STORE.serialize_cdr(theirs, name) == wire
        back = type(sample).deserialize(STORE.serialize_cdr(theirs, name))
        assert back.serialize() == wire


def test_observation_survives_the_message_exactly() -> None:
    obs = _eventful_observation()
    msg = msgs.TeamObservation.deserialize(
        observation_to_msg(obs, step_stamp(1, 0.1), "w").serialize()
    )
    back = observation_from_msg(msg, obs.positions, obs.measurements.shape[1], 2)
    np.testing.assert_array_equal(back.measurements, obs.measurements)  # NaN where unmeasured
    np.testing.assert_array_equal(back.links, obs.links)
    assert back.time == obs.time and back.step == obs.step
    assert back.sensing_persistence == obs.sensing_persistence
    assert back.recoveries == obs.recoveries
    assert len(back.attacks) == len(obs.attacks) == 2
    for a, b in zip(back.attacks, obs.attacks, strict=True):
        assert (a.robot, a.cause, a.clue.kind, a.clue.size) == (
            b.robot,
            b.cause,
            b.clue.kind,
            b.clue.size,
        )
        np.testing.assert_array_equal(a.clue.sigma, b.clue.sigma)


def test_a_one_channel_observation_survives_the_message_exactly() -> None:
    obs = World(shipped("bearing-only"), 2).observe()
    assert obs.measurements.shape == (3, 3, 1)
    obs.measurements[0, 1] = np.nan
    msg = msgs.TeamObservation.deserialize(
        observation_to_msg(obs, step_stamp(0, 0.1), "w").serialize()
    )
    assert len(msg.measurements) == 9
    back = observation_from_msg(msg, obs.positions, 3, 1)
    np.testing.assert_array_equal(back.measurements, obs.measurements)
    with pytest.raises(MessageError, match="observation.measurements: expected 18 values"):
        observation_from_msg(msg, obs.positions, 3, 2)  # a range-bearing team's size


@pytest.mark.parametrize(
    ("change", "field"),
    [
        ({"measurements": [0.0] * 5}, "observation.measurements"),
        ({"n_robots": 2}, "observation.n_robots"),
        ({"links": [True] * 4}, "observation.links"),
        ({"sensing_persistence": ["", "forever", ""]}, "observation.persistence"),
        ({"recovered_robots": [9], "recovered_kinds": ["comm"]}, "observation.recovered_robots"),
        ({"measurements": [float("inf")] * 18}, "observation.measurements"),
    ],
)
def test_malformed_observation_names_the_field(change: dict, field: str) -> None:
    scenario = shipped("sensing-temp")
    obs = World(scenario, 1).observe()
    msg = dataclasses.replace(observation_to_msg(obs, step_stamp(0, 0.1), "w"), **change)
    with pytest.raises(MessageError, match=field):
        observation_from_msg(msg, obs.positions, len(scenario.targets), 2)


def test_commands_and_topic_names() -> None:
    cmd = full_state(
        np.array([1.0, 2.0]), np.array([0.5, -0.25]), 0.7, 0.1, step_stamp(3, 0.1), "w"
    )
    assert (cmd.pose.position.x, cmd.pose.position.y, cmd.pose.position.z) == (1.05, 1.975, 0.7)
    np.testing.assert_array_equal(command_velocity(cmd, "c"), [0.5, -0.25])
    bad = msgs.Twist(linear=msgs.Vector3(float("nan"), 0.0, 0.0))
    with pytest.raises(MessageError, match="cf1/cmd_vel"):
        command_velocity(bad, "/cf1/cmd_vel")
    assert dds_topic("/cf1/pose") == "rt/cf1/pose"
    with pytest.raises(ValueError, match="topic name"):
        dds_topic("/a//b")
