"""ROS 2 message types as DDS (IDL) structs, wire-compatible with ROS 2 nodes.

A ROS 2 message ``pkg/msg/Name`` travels in DDS as the struct ``pkg::msg::dds_::Name_``,
serialized as plain (XCDR1) CDR, with the fields of its ``.msg`` definition in order (by
:mod:`~.cdr`'s codecs, which give cyclonedds' bytes faster). The standard ones below follow
the definitions of ROS 2 Humble and Jazzy (identical for these types);
``tests/test_ros2_msgs.py`` checks every field against the ``rosbags`` type store and
round-trips CDR between the two.

Two packages are not in a standard ROS 2 install: ``crazyflie_interfaces`` (Crazyswarm2's
commands, built with Crazyswarm2) and ``resilient_tracking_msgs`` (this project's synthesized
observations). Their ``.msg`` definitions are in :data:`MSG_DEFINITIONS`; build them as a ROS 2
interface package to ``ros2 topic echo`` them (``docs/robots.md``).
"""

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from cyclonedds.idl import IdlStruct
from cyclonedds.idl.annotations import final
from cyclonedds.idl.types import array, float32, float64, int32, uint8, uint32

from resilient_tracking.ros2.cdr import fast_cdr

if TYPE_CHECKING:  # type checkers see IDL sequences and fixed arrays as lists
    from builtins import list as sequence

    Float64x2 = list[float]
    Float64x4 = list[float]
else:
    from cyclonedds.idl.types import sequence

    Float64x2 = array[float64, 2]
    Float64x4 = array[float64, 4]


def _dds(name: str) -> str:
    """``pkg/msg/Name`` → ``pkg::msg::dds_::Name_``, ROS 2's DDS type name."""
    package, kind, base = name.split("/")
    return f"{package}::{kind}::dds_::{base}_"


# --------------------------------------------------------------------------- builtin / std


@fast_cdr
@dataclass
@final
class Time(IdlStruct, typename=_dds("builtin_interfaces/msg/Time")):
    sec: int32 = 0
    nanosec: uint32 = 0


@fast_cdr
@dataclass
@final
class Duration(IdlStruct, typename=_dds("builtin_interfaces/msg/Duration")):
    sec: int32 = 0
    nanosec: uint32 = 0


@fast_cdr
@dataclass
@final
class Header(IdlStruct, typename=_dds("std_msgs/msg/Header")):
    stamp: Time = field(default_factory=Time)
    frame_id: str = ""


@fast_cdr
@dataclass
@final
class ColorRGBA(IdlStruct, typename=_dds("std_msgs/msg/ColorRGBA")):
    r: float32 = 0.0
    g: float32 = 0.0
    b: float32 = 0.0
    a: float32 = 0.0


# --------------------------------------------------------------------------- geometry_msgs


@fast_cdr
@dataclass
@final
class Point(IdlStruct, typename=_dds("geometry_msgs/msg/Point")):
    x: float64 = 0.0
    y: float64 = 0.0
    z: float64 = 0.0


@fast_cdr
@dataclass
@final
class Vector3(IdlStruct, typename=_dds("geometry_msgs/msg/Vector3")):
    x: float64 = 0.0
    y: float64 = 0.0
    z: float64 = 0.0


@fast_cdr
@dataclass
@final
class Quaternion(IdlStruct, typename=_dds("geometry_msgs/msg/Quaternion")):
    x: float64 = 0.0
    y: float64 = 0.0
    z: float64 = 0.0
    w: float64 = 1.0


@fast_cdr
@dataclass
@final
class Pose(IdlStruct, typename=_dds("geometry_msgs/msg/Pose")):
    position: Point = field(default_factory=Point)
    orientation: Quaternion = field(default_factory=Quaternion)


@fast_cdr
@dataclass
@final
class PoseStamped(IdlStruct, typename=_dds("geometry_msgs/msg/PoseStamped")):
    header: Header = field(default_factory=Header)
    pose: Pose = field(default_factory=Pose)


@fast_cdr
@dataclass
@final
class Twist(IdlStruct, typename=_dds("geometry_msgs/msg/Twist")):
    linear: Vector3 = field(default_factory=Vector3)
    angular: Vector3 = field(default_factory=Vector3)


# --------------------------------------------------------------------------- visualization_msgs


@fast_cdr
@dataclass
@final
class CompressedImage(IdlStruct, typename=_dds("sensor_msgs/msg/CompressedImage")):
    header: Header = field(default_factory=Header)
    format: str = ""
    data: sequence[uint8] = field(default_factory=list)


@fast_cdr
@dataclass
@final
class UVCoordinate(IdlStruct, typename=_dds("visualization_msgs/msg/UVCoordinate")):
    u: float32 = 0.0
    v: float32 = 0.0


@fast_cdr
@dataclass
@final
class MeshFile(IdlStruct, typename=_dds("visualization_msgs/msg/MeshFile")):
    filename: str = ""
    data: sequence[uint8] = field(default_factory=list)


@fast_cdr
@dataclass
@final
class Marker(IdlStruct, typename=_dds("visualization_msgs/msg/Marker")):
    header: Header = field(default_factory=Header)
    ns: str = ""
    id: int32 = 0
    type: int32 = 0
    action: int32 = 0
    pose: Pose = field(default_factory=Pose)
    scale: Vector3 = field(default_factory=Vector3)
    color: ColorRGBA = field(default_factory=ColorRGBA)
    lifetime: Duration = field(default_factory=Duration)
    frame_locked: bool = False
    points: sequence[Point] = field(default_factory=list)
    colors: sequence[ColorRGBA] = field(default_factory=list)
    texture_resource: str = ""
    texture: CompressedImage = field(default_factory=CompressedImage)
    uv_coordinates: sequence[UVCoordinate] = field(default_factory=list)
    text: str = ""
    mesh_resource: str = ""
    mesh_file: MeshFile = field(default_factory=MeshFile)
    mesh_use_embedded_materials: bool = False


# Marker.type and Marker.action constants (visualization_msgs/msg/Marker)
SPHERE, CYLINDER, LINE_STRIP, TEXT_VIEW_FACING = 2, 3, 4, 9
ADD, DELETEALL = 0, 3


@fast_cdr
@dataclass
@final
class MarkerArray(IdlStruct, typename=_dds("visualization_msgs/msg/MarkerArray")):
    markers: sequence[Marker] = field(default_factory=list)


# --------------------------------------------------------------------------- crazyflie_interfaces


@fast_cdr
@dataclass
@final
class FullState(IdlStruct, typename=_dds("crazyflie_interfaces/msg/FullState")):
    """Crazyswarm2's full-state setpoint: world-frame position, velocity, acceleration."""

    header: Header = field(default_factory=Header)
    pose: Pose = field(default_factory=Pose)
    twist: Twist = field(default_factory=Twist)
    acc: Vector3 = field(default_factory=Vector3)


# ----------------------------------------------------------------- resilient_tracking_msgs


@fast_cdr
@dataclass
@final
class ZoneAttack(IdlStruct, typename=_dds("resilient_tracking_msgs/msg/ZoneAttack")):
    """An attack a robot felt, with the attacking zone's prior (its clue)."""

    robot: uint32 = 0
    zone_id: uint32 = 0
    kind: str = ""
    mu: Float64x2 = field(default_factory=lambda: [0.0, 0.0])
    sigma: Float64x4 = field(default_factory=lambda: [0.0, 0.0, 0.0, 0.0])
    size: float64 = 0.0
    persistence: str = ""
    cause: str = ""


@fast_cdr
@dataclass
@final
class TeamObservation(IdlStruct, typename=_dds("resilient_tracking_msgs/msg/TeamObservation")):
    """One tick of synthesized measurements, failure flags and links for the whole team."""

    header: Header = field(default_factory=Header)
    step: uint32 = 0
    time: float64 = 0.0
    n_robots: uint32 = 0
    n_targets: uint32 = 0
    measurements: sequence[float64] = field(default_factory=list)
    sensing_ok: sequence[bool] = field(default_factory=list)
    comm_ok: sequence[bool] = field(default_factory=list)
    sensing_persistence: sequence[str] = field(default_factory=list)
    comm_persistence: sequence[str] = field(default_factory=list)
    links: sequence[bool] = field(default_factory=list)
    attacks: sequence[ZoneAttack] = field(default_factory=list)
    recovered_robots: sequence[uint32] = field(default_factory=list)
    recovered_kinds: sequence[str] = field(default_factory=list)


#: ``.msg`` definitions of the two non-standard packages, registered with ``rosbags`` for bags.
MSG_DEFINITIONS: dict[str, str] = {
    "crazyflie_interfaces/msg/FullState": """\
std_msgs/Header header
geometry_msgs/Pose pose
geometry_msgs/Twist twist
geometry_msgs/Vector3 acc
""",
    "resilient_tracking_msgs/msg/ZoneAttack": """\
# An attack robot `robot` felt from zone `zone_id`; mu, sigma (row-major 2x2) and size are the
# zone's prior, the only thing a victim learns about it.
uint32 robot
uint32 zone_id
string kind            # sensing | comm
float64[2] mu
float64[4] sigma
float64 size           # sensing: radius r; comm: jamming strength delta2
string persistence     # temporary | permanent
string cause           # hazard | jamming | degradation | spread
""",
    "resilient_tracking_msgs/msg/TeamObservation": """\
# One tick of synthesized observations for a team of n_robots robots and n_targets targets.
std_msgs/Header header
uint32 step
float64 time
uint32 n_robots
uint32 n_targets
float64[] measurements        # n_robots*n_targets*D (D: the sensor's channels); NaN: not measured
bool[] sensing_ok             # n_robots
bool[] comm_ok                # n_robots
string[] sensing_persistence  # n_robots: "" | temporary | permanent
string[] comm_persistence     # n_robots
bool[] links                  # n_robots*n_robots, row-major, symmetric
ZoneAttack[] attacks          # attacks felt since the previous tick
uint32[] recovered_robots     # recoveries since the previous tick ...
string[] recovered_kinds      # ... and what recovered: sensing | comm
""",
}

#: Every message type the nodes use, by ROS 2 name.
MESSAGE_TYPES: dict[str, type[IdlStruct]] = {
    "builtin_interfaces/msg/Time": Time,
    "builtin_interfaces/msg/Duration": Duration,
    "std_msgs/msg/Header": Header,
    "std_msgs/msg/ColorRGBA": ColorRGBA,
    "geometry_msgs/msg/Point": Point,
    "geometry_msgs/msg/Vector3": Vector3,
    "geometry_msgs/msg/Quaternion": Quaternion,
    "geometry_msgs/msg/Pose": Pose,
    "geometry_msgs/msg/PoseStamped": PoseStamped,
    "geometry_msgs/msg/Twist": Twist,
    "sensor_msgs/msg/CompressedImage": CompressedImage,
    "visualization_msgs/msg/UVCoordinate": UVCoordinate,
    "visualization_msgs/msg/MeshFile": MeshFile,
    "visualization_msgs/msg/Marker": Marker,
    "visualization_msgs/msg/MarkerArray": MarkerArray,
    "crazyflie_interfaces/msg/FullState": FullState,
    "resilient_tracking_msgs/msg/ZoneAttack": ZoneAttack,
    "resilient_tracking_msgs/msg/TeamObservation": TeamObservation,
}


def ros_name(msg_type: type[IdlStruct]) -> str:
    """The ROS 2 name (``pkg/msg/Name``) of one of :data:`MESSAGE_TYPES`."""
    for name, cls in MESSAGE_TYPES.items():
        if cls is msg_type:
            return name
    raise KeyError(msg_type)
