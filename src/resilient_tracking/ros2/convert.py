"""Between the team's arrays and ROS 2 messages, checking every received field.

A received message that does not fit the scenario (wrong sizes, non-finite poses, unknown
labels, a time stamp out of place) raises :class:`MessageError` naming the field and the reason;
the nodes log it and drop the message. Numbers travel as float64, so a lock-step run over DDS
sees exactly the arrays of a simulated one.
"""

from __future__ import annotations

import math

import numpy as np

from resilient_tracking.observation import Attack, TeamObservation, ZoneClue
from resilient_tracking.ros2 import msgs

KINDS = ("sensing", "comm")
PERSISTENCES = ("", "temporary", "permanent")
CAUSES = ("hazard", "jamming", "degradation", "spread")


class MessageError(ValueError):
    """A received message that cannot be used; the message names the field, ``reason`` says
    why in one word (the key it is counted under in a run's manifest): ``not_finite``,
    ``invalid`` (does not fit the scenario), ``stale``, ``future`` or ``out_of_order``."""

    def __init__(self, message: str, reason: str = "invalid"):
        super().__init__(message)
        self.reason = reason


# --------------------------------------------------------------------------- time stamps


def stamp_from_ns(ns: int) -> msgs.Time:
    """A ROS 2 ``Time`` stamp from nanoseconds."""
    return msgs.Time(sec=int(ns // 1_000_000_000), nanosec=int(ns % 1_000_000_000))


def stamp_ns(stamp: msgs.Time) -> int:
    """Nanoseconds of a ROS 2 ``Time`` stamp."""
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def step_stamp(step: int, dt: float) -> msgs.Time:
    """The simulated time of ``step`` as a ROS 2 stamp: the key that pairs a lock-step tick."""
    return stamp_from_ns(round(step * dt * 1e9))


def check_stamp(stamp: int, now: int, newest: int | None, tolerance: float, name: str) -> None:
    """Raise :class:`MessageError` unless a message stamped ``stamp`` (ns) can be used at wall
    time ``now`` (ns) on a topic whose newest message taken so far was stamped ``newest``:
    stamped more than ``tolerance`` seconds before ``now`` (``stale``) or after it (``future``:
    a clock that is off, which would otherwise make every later message look out of order),
    or not after ``newest`` (``out_of_order``: a late or repeated message)."""
    limit = round(tolerance * 1e9)
    if stamp < now - limit:
        age = (now - stamp) / 1e9
        raise MessageError(
            f"{name}: header.stamp is {age:.3g} s old (over {tolerance:g} s)", "stale"
        )
    if stamp > now + limit:
        ahead = (stamp - now) / 1e9
        raise MessageError(
            f"{name}: header.stamp is {ahead:.3g} s ahead of this computer's clock "
            f"(over {tolerance:g} s)",
            "future",
        )
    if newest is not None and stamp <= newest:
        raise MessageError(
            f"{name}: header.stamp is not after the newest one taken ({(newest - stamp) / 1e9:.3g} "
            "s older or the same)",
            "out_of_order",
        )


# --------------------------------------------------------------------------- poses


def pose_stamped(xy: np.ndarray, z: float, stamp: msgs.Time, frame: str) -> msgs.PoseStamped:
    """A ``PoseStamped`` at position ``(xy[0], xy[1], z)`` (m), identity orientation, in
    ``frame``."""
    return msgs.PoseStamped(
        header=msgs.Header(stamp=stamp, frame_id=frame),
        pose=msgs.Pose(position=msgs.Point(float(xy[0]), float(xy[1]), float(z))),
    )


def pose_xy(msg: msgs.PoseStamped, name: str) -> np.ndarray:
    """The horizontal position of a pose; the tracker works in the plane (paper's model)."""
    p = msg.pose.position
    if not (math.isfinite(p.x) and math.isfinite(p.y) and math.isfinite(p.z)):
        raise MessageError(
            f"{name}: pose.position is not finite ({p.x}, {p.y}, {p.z})", "not_finite"
        )
    return np.array([p.x, p.y], dtype=float)


# --------------------------------------------------------------------------- observations


def observation_to_msg(obs: TeamObservation, stamp: msgs.Time, frame: str) -> msgs.TeamObservation:
    """The tick's :class:`TeamObservation` as a message: step and time, measurements ``(m, N, D)``
    flattened (D the sensor's ``DIM``), capability flags and persistences, links, attacks with
    their clues, and recoveries (float64 numbers throughout)."""
    attacks = [
        msgs.ZoneAttack(
            robot=int(a.robot),
            zone_id=int(a.clue.zone_id),
            kind=a.clue.kind,
            mu=[float(v) for v in np.ravel(a.clue.mu)],
            sigma=[float(v) for v in np.ravel(a.clue.sigma)],
            size=float(a.clue.size),
            persistence=a.clue.persistence,
            cause=a.cause,
        )
        for a in obs.attacks
    ]
    m, n = obs.measurements.shape[:2]
    return msgs.TeamObservation(
        header=msgs.Header(stamp=stamp, frame_id=frame),
        step=int(obs.step),
        time=float(obs.time),
        n_robots=int(m),
        n_targets=int(n),
        measurements=obs.measurements.astype(float).ravel().tolist(),
        sensing_ok=[bool(v) for v in obs.sensing_ok],
        comm_ok=[bool(v) for v in obs.comm_ok],
        sensing_persistence=list(obs.sensing_persistence),
        comm_persistence=list(obs.comm_persistence),
        links=[bool(v) for v in np.ravel(obs.links)],
        attacks=attacks,
        recovered_robots=[int(r) for r, _ in obs.recoveries],
        recovered_kinds=[k for _, k in obs.recoveries],
    )


def _sized(values: list, size: int, name: str) -> list:  # type: ignore[type-arg]
    if len(values) != size:
        raise MessageError(f"observation.{name}: expected {size} values, got {len(values)}")
    return values


def _label(value: str, allowed: tuple[str, ...], name: str) -> str:
    if value not in allowed:
        raise MessageError(f"observation.{name}: {value!r} is not one of {allowed}")
    return value


def observation_from_msg(
    msg: msgs.TeamObservation, positions: np.ndarray, n_targets: int, dim: int
) -> TeamObservation:
    """The team's observation from a message and the robots' own positions (M, 2);
    ``dim`` is the channels of one measurement (the team's sensor's ``DIM``)."""
    m = len(positions)
    if msg.n_robots != m or msg.n_targets != n_targets:
        raise MessageError(
            f"observation.n_robots/n_targets: expected {m}x{n_targets}, "
            f"got {msg.n_robots}x{msg.n_targets}"
        )
    if not math.isfinite(msg.time):
        raise MessageError(f"observation.time: not finite ({msg.time})")
    size = m * n_targets * dim
    z = np.array(_sized(msg.measurements, size, "measurements"), dtype=np.float64)
    if np.isinf(z).any():
        raise MessageError("observation.measurements: infinite value (NaN marks 'not measured')")
    attacks = []
    for i, a in enumerate(msg.attacks):
        if a.robot >= m:
            raise MessageError(f"observation.attacks[{i}].robot: {a.robot} is not a robot index")
        sigma = np.array(a.sigma, dtype=float).reshape(2, 2)
        if not (np.isfinite(a.mu).all() and np.isfinite(sigma).all() and math.isfinite(a.size)):
            raise MessageError(f"observation.attacks[{i}]: mu, sigma and size must be finite")
        if a.size <= 0 or sigma[0, 1] != sigma[1, 0] or np.linalg.eigvalsh(sigma)[0] <= 0:
            raise MessageError(
                f"observation.attacks[{i}]: size must be positive and sigma symmetric positive "
                "definite"
            )
        clue = ZoneClue(
            zone_id=int(a.zone_id),
            kind=_label(a.kind, KINDS, f"attacks[{i}].kind"),  # type: ignore[arg-type]
            mu=np.array(a.mu, dtype=float),
            sigma=sigma,
            size=float(a.size),
            persistence=_label(  # type: ignore[arg-type]
                a.persistence, PERSISTENCES[1:], f"attacks[{i}].persistence"
            ),
        )
        cause = _label(a.cause, CAUSES, f"attacks[{i}].cause")
        attacks.append(Attack(robot=int(a.robot), clue=clue, cause=cause))  # type: ignore[arg-type]
    recovered = _sized(msg.recovered_kinds, len(msg.recovered_robots), "recovered_kinds")
    recoveries = []
    for i, (robot, kind) in enumerate(zip(msg.recovered_robots, recovered, strict=True)):
        if robot >= m:
            raise MessageError(f"observation.recovered_robots[{i}]: {robot} is not a robot index")
        recoveries.append((int(robot), _label(kind, KINDS, f"recovered_kinds[{i}]")))
    sensing_p = _sized(msg.sensing_persistence, m, "sensing_persistence")
    comm_p = _sized(msg.comm_persistence, m, "comm_persistence")
    for i, p in enumerate(sensing_p + comm_p):
        _label(p, PERSISTENCES, f"persistence[{i}]")
    sensing_ok = np.array(_sized(msg.sensing_ok, m, "sensing_ok"), dtype=np.bool_)
    comm_ok = np.array(_sized(msg.comm_ok, m, "comm_ok"), dtype=np.bool_)
    links = np.array(_sized(msg.links, m * m, "links"), dtype=np.bool_).reshape(m, m)
    try:
        return TeamObservation(
            step=int(msg.step),
            time=float(msg.time),
            positions=np.array(positions, dtype=float),
            measurements=z.reshape(m, n_targets, dim),
            sensing_ok=sensing_ok,
            comm_ok=comm_ok,
            sensing_persistence=tuple(sensing_p),
            comm_persistence=tuple(comm_p),
            links=links,
            attacks=tuple(attacks),
            recoveries=tuple(recoveries),  # type: ignore[arg-type]
        )
    except ValueError as err:  # what an observation checks itself (symmetric links...)
        raise MessageError(f"observation: {err}") from None


# --------------------------------------------------------------------------- commands


def full_state(
    xy: np.ndarray, velocity: np.ndarray, altitude: float, dt: float, stamp: msgs.Time, frame: str
) -> msgs.FullState:
    """Crazyswarm2's ``cmd_full_state``: a world-frame velocity at a fixed altitude.

    The position setpoint is where the robot should be one tick later (``xy + v·dt``) at
    ``altitude``, the velocity is the feed-forward; yaw stays 0, acceleration 0.
    """
    target = np.asarray(xy, dtype=float) + np.asarray(velocity, dtype=float) * dt
    return msgs.FullState(
        header=msgs.Header(stamp=stamp, frame_id=frame),
        pose=msgs.Pose(position=msgs.Point(float(target[0]), float(target[1]), float(altitude))),
        twist=msgs.Twist(linear=msgs.Vector3(float(velocity[0]), float(velocity[1]), 0.0)),
    )


def twist(velocity: np.ndarray) -> msgs.Twist:
    """A plain ``geometry_msgs/Twist`` with the world-frame velocity in ``linear``."""
    return msgs.Twist(linear=msgs.Vector3(float(velocity[0]), float(velocity[1]), 0.0))


def command_velocity(msg: msgs.FullState | msgs.Twist, name: str) -> np.ndarray:
    """The horizontal velocity of a received command."""
    linear = msg.twist.linear if isinstance(msg, msgs.FullState) else msg.linear
    v = np.array([linear.x, linear.y], dtype=float)
    if not np.isfinite(v).all():
        raise MessageError(f"{name}: velocity is not finite ({linear.x}, {linear.y})")
    return v
