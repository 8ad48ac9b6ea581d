"""Recording topics as a ROS 2 bag (``rosbags``), replayable with ``ros2 bag play``.

Messages are stored as the CDR bytes that travelled on DDS (the same bytes ROS 2 records),
with the ROS 2 Jazzy message definitions from ``rosbags`` plus this project's and Crazyswarm2's
definitions (:data:`~resilient_tracking.ros2.msgs.MSG_DEFINITIONS`).
"""

from __future__ import annotations

import logging
import threading
from pathlib import Path

from cyclonedds.idl import IdlStruct
from rosbags.rosbag2 import Writer
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

from resilient_tracking.ros2.msgs import MSG_DEFINITIONS, ros_name
from resilient_tracking.ros2.transport import dds_topic

log = logging.getLogger(__name__)

#: The ROS 2 distribution whose message definitions the nodes follow (same for Humble here).
DISTRO = Stores.ROS2_JAZZY


def typestore() -> Typestore:
    """ROS 2's standard types plus the non-standard ones the nodes use."""
    store = get_typestore(DISTRO)
    for name, text in MSG_DEFINITIONS.items():
        store.register(get_types_from_msg(text, name))
    return store


class BagRecorder:
    """Writes every message handed to :meth:`write` into a new bag folder ``path`` (from any
    thread: the belief markers of a free-running node are recorded from their writer's)."""

    def __init__(self, path: str | Path):
        self.path = Path(path)
        if self.path.exists():
            raise FileExistsError(f"--bag: {self.path} already exists; not overwriting it")
        self._store = typestore()
        self._writer = Writer(self.path, version=8)
        self._writer.open()
        self._connections: dict[str, object] = {}
        self._lock = threading.Lock()
        self.count = 0

    def write(self, ros_topic: str, msg: IdlStruct, timestamp_ns: int) -> None:
        """Write ``msg`` of the ROS 2 topic ``ros_topic`` at ``timestamp_ns`` (ns), registering the
        topic's connection with its first message."""
        topic = "/" + dds_topic(ros_topic).removeprefix("rt/")
        data = msg.serialize()
        with self._lock:
            if topic not in self._connections:
                self._connections[topic] = self._writer.add_connection(
                    topic, ros_name(type(msg)), typestore=self._store
                )
            self._writer.write(self._connections[topic], timestamp_ns, data)  # type: ignore[arg-type]
            self.count += 1

    def close(self) -> None:
        """Close the bag and log how many messages it holds."""
        with self._lock:
            self._writer.close()
        log.info("bag %s: %d messages", self.path, self.count)
