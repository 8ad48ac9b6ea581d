"""DDS transport with ROS 2's naming and QoS: what lets a ``cyclonedds`` node join a ROS 2 graph.

ROS 2 maps a topic ``/cf1/pose`` to the DDS topic ``rt/cf1/pose`` and uses the DDS domain in
``ROS_DOMAIN_ID`` (0 by default). QoS profiles follow ROS 2's: ``default`` is reliable, volatile,
keep last 10 (what Crazyswarm2's server subscribes with); ``sensor_data`` is best effort, keep
last 5, which also accepts reliable publishers; ``lockstep`` is reliable and transient-local so a
sample written before the other side was discovered still arrives.

CycloneDDS reads its configuration (network interface, discovery) from ``CYCLONEDDS_URI``;
:func:`loopback_config` gives one that keeps all traffic on 127.0.0.1 (tests, one machine).
"""

from __future__ import annotations

import logging
import os
import threading
import time
from collections.abc import Callable
from typing import Any

from cyclonedds._clayer import ddspy_take
from cyclonedds.core import (
    DDSException,
    InstanceState,
    ReadCondition,
    SampleState,
    ViewState,
    WaitSet,
)
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.pub import DataWriter
from cyclonedds.qos import Policy, Qos
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

log = logging.getLogger(__name__)

#: Plain CDR (XCDR1), the representation ROS 2's rmw layers use.
_CDR = Policy.DataRepresentation(use_cdrv0_representation=True)
_ANY_SAMPLE = SampleState.Any | ViewState.Any | InstanceState.Any


def dds_topic(ros_topic: str) -> str:
    """``/cf1/pose`` or ``cf1/pose`` → ``rt/cf1/pose``: ROS 2's DDS name of a topic."""
    name = ros_topic.strip("/")
    if not name or "//" in name or any(c.isspace() for c in name):
        raise ValueError(f"topic name {ros_topic!r}: not a valid ROS 2 topic name")
    return f"rt/{name}"


def default_qos(depth: int = 10) -> Qos:
    """ROS 2's default profile: reliable, volatile, keep last ``depth``."""
    return Qos(
        Policy.Reliability.Reliable(duration(seconds=1)),
        Policy.Durability.Volatile,
        Policy.History.KeepLast(depth),
        _CDR,
    )


def sensor_data_qos(depth: int = 5) -> Qos:
    """ROS 2's sensor-data profile: best effort, volatile, keep last ``depth`` (accepts reliable
    publishers too)."""
    return Qos(
        Policy.Reliability.BestEffort,
        Policy.Durability.Volatile,
        Policy.History.KeepLast(depth),
        _CDR,
    )


def lockstep_qos(depth: int = 64) -> Qos:
    """Reliable and transient-local, keep last ``depth``: a sample written before the other node was
    discovered still arrives (lock-step runs)."""
    return Qos(
        Policy.Reliability.Reliable(duration(seconds=5)),
        Policy.Durability.TransientLocal,
        Policy.History.KeepLast(depth),
        _CDR,
    )


def loopback_config() -> str:
    """A CycloneDDS configuration that keeps discovery and data on the loopback interface."""
    return (
        "<CycloneDDS><Domain Id='any'><General>"
        "<Interfaces><NetworkInterface address='127.0.0.1'/></Interfaces>"
        "<AllowMulticast>false</AllowMulticast></General>"
        "<Discovery><ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>50"
        "</MaxAutoParticipantIndex><Peers><Peer address='127.0.0.1'/></Peers></Discovery>"
        "</Domain></CycloneDDS>"
    )


def domain_from_env(domain_id: int | None) -> int:
    """The DDS domain: the one given, else ``ROS_DOMAIN_ID``, else 0 (as ROS 2 does)."""
    if domain_id is not None:
        return domain_id
    raw = os.environ.get("ROS_DOMAIN_ID", "").strip()
    if not raw:
        return 0
    if not raw.isdigit() or int(raw) > 232:
        raise ValueError(f"ROS_DOMAIN_ID: {raw!r} is not a domain id (0-232)")
    return int(raw)


class DdsNode:
    """One DDS participant with ROS 2-named topics, and a wait set over all its readers."""

    def __init__(self, domain_id: int | None = None):
        self.participant = DomainParticipant(domain_from_env(domain_id))
        self._topics: dict[str, Topic] = {}
        self._waitset = WaitSet(self.participant)
        self.readers: list[DataReader] = []
        self.writers: list[DataWriter] = []

    def _topic(self, ros_topic: str, msg_type: type[IdlStruct]) -> Topic:
        name = dds_topic(ros_topic)
        if name not in self._topics:
            self._topics[name] = Topic(self.participant, name, msg_type)
        return self._topics[name]

    def publisher(self, ros_topic: str, msg_type: type[IdlStruct], qos: Qos) -> DataWriter:
        """A writer of ``msg_type`` on the ROS 2 topic ``ros_topic`` with ``qos``."""
        writer = DataWriter(self.participant, self._topic(ros_topic, msg_type), qos=qos)
        self.writers.append(writer)
        return writer

    def subscription(self, ros_topic: str, msg_type: type[IdlStruct], qos: Qos) -> DataReader:
        """A reader of ``msg_type`` on the ROS 2 topic ``ros_topic`` with ``qos``, attached to the
        node's wait set."""
        reader = DataReader(self.participant, self._topic(ros_topic, msg_type), qos=qos)
        condition = ReadCondition(reader, SampleState.NotRead | ViewState.Any | InstanceState.Any)
        self._waitset.attach(condition)
        self.readers.append(reader)
        return reader

    def wait(self, timeout_s: float) -> None:
        """Block until some reader has unread data or ``timeout_s`` passes."""
        self._waitset.wait(duration(seconds=max(timeout_s, 0.0)))

    def wait_matched(
        self, writers: list[DataWriter], readers: list[DataReader], timeout_s: float
    ) -> bool:
        """Wait until every writer has a matched reader and every reader a matched writer."""
        deadline = time.monotonic() + timeout_s
        while True:
            ok = all(w.get_publication_matched_status().current_count > 0 for w in writers) and all(
                r.get_subscription_matched_status().current_count > 0 for r in readers
            )
            if ok or time.monotonic() >= deadline:
                return ok
            time.sleep(0.02)


def take(
    reader: DataReader,
    limit: int = 256,
    undecodable: Callable[[Exception], object] | None = None,
) -> list[Any]:
    """All samples waiting in ``reader`` (valid data only), oldest first, each decoded on its own.

    cyclonedds checks the CDR framing of what it receives (truncated or garbled bytes never get
    this far), but not everything in it: a string that is not UTF-8 passes and cannot be
    decoded. ``DataReader.take`` decodes a batch in one go, so such a sample raises and loses
    the batch; here it is handed to ``undecodable`` (logged when that is None) and the others
    are kept."""
    got = ddspy_take(reader._ref, _ANY_SAMPLE, limit)  # what DataReader.take calls
    if isinstance(got, int):
        raise DDSException(got, f"Occurred while taking data in {reader!r}")
    decode = reader.topic.data_type.deserialize
    samples = []
    for data, info in got:
        if not info.valid_data:
            continue
        try:
            samples.append(decode(data))
        except Exception as err:  # anything a peer sends must not stop the loop
            if undecodable is None:
                log.warning("dropped an undecodable sample: %s: %s", type(err).__name__, err)
            else:
                undecodable(err)
    return samples


class BackgroundWriter:
    """Builds and writes messages from a worker thread, keeping only the newest one waiting.

    For visualization topics on a control loop: building a belief ``MarkerArray`` at 10×10
    takes a few milliseconds and serializing it about 14 ms in cyclonedds' Python serializer;
    both then happen while the loop waits for its next period, not between an observation and
    its setpoints. :meth:`write` takes a message, or a function that builds one from data the
    caller copied; a message not yet written when a newer one arrives is dropped.
    ``on_written`` is called with each message written (e.g. to record it in a bag).
    """

    def __init__(
        self,
        writer: DataWriter,
        name: str = "rtrack-writer",
        on_written: Callable[[IdlStruct], object] | None = None,
    ):
        self._writer = writer
        self._on_written = on_written
        self._ready = threading.Condition()
        self._pending: IdlStruct | Callable[[], IdlStruct] | None = None
        self._closed = False
        self.dropped = 0
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._thread.start()

    def write(self, msg: IdlStruct | Callable[[], IdlStruct]) -> None:
        """Hand ``msg`` (or a function building it) over for writing, replacing one still
        waiting."""
        with self._ready:
            if self._pending is not None:
                self.dropped += 1
            self._pending = msg
            self._ready.notify()

    def close(self, timeout: float = 5.0) -> None:
        """Write what is waiting, then stop the thread."""
        with self._ready:
            self._closed = True
            self._ready.notify()
        self._thread.join(timeout)

    def _run(self) -> None:
        while True:
            with self._ready:
                while self._pending is None and not self._closed:
                    self._ready.wait()
                if self._pending is None:
                    return
                pending, self._pending = self._pending, None
            try:
                msg = pending() if callable(pending) else pending
                self._writer.write(msg)
                if self._on_written is not None:
                    self._on_written(msg)
            except Exception as err:  # a visualization topic must not stop the loop
                log.warning("building or writing a message failed: %s: %s", type(err).__name__, err)
