"""What the tracker node dropped or could not hear, and why: the run manifest's account of it.

Each message dropped is counted by topic and reason (the reason words of
:class:`~resilient_tracking.ros2.convert.MessageError`, and ``undecodable``). Hostile or broken
traffic must not flood the log as well (a warning per message would cost the control loop its
period under a flood), so the first drop of each reason on each topic is a warning and later
ones are logged at debug level; all are counted.

Some publishers are never heard at all: DDS does not deliver another type on one of the node's
topics, and the node subscribes to no pose topic of a name the scenario does not have (a robot
or motion-capture body named ``cf01`` where the scenario's is ``cf1``). DDS discovery still
announces them (the built-in publication topic); :class:`PublicationWatch` reads those
announcements and each such publisher is logged once and listed.
"""

from __future__ import annotations

import logging
from collections import Counter
from typing import Any

from cyclonedds.builtin import BuiltinDataReader, BuiltinTopicDcpsPublication
from cyclonedds.domain import DomainParticipant

log = logging.getLogger(__name__)

#: Why a received message was dropped (the keys of the manifest's ``drops``).
REASONS: dict[str, str] = {
    "undecodable": "passed cyclonedds' CDR check but does not decode (a string that is not UTF-8)",
    "not_finite": "a pose with a NaN or infinite coordinate",
    "invalid": "an observation that does not fit the scenario (sizes, labels, numbers)",
    "stale": "stamped longer ago than the timeout",
    "future": "stamped later than this computer's clock by more than the timeout",
    "out_of_order": "stamped no later than the newest one taken on its topic",
}
#: Why a publisher is never heard (the ``reason`` of the manifest's ``ignored_publishers``).
PUBLISHER_REASONS: dict[str, str] = {
    "wrong_type": "publishes another type on one of the node's topics",
    "unknown_name": "publishes the pose of a name the scenario does not have",
}


class DropLog:
    """Counts of dropped messages by topic and reason, and the publishers never heard."""

    def __init__(self) -> None:
        self.by_topic: dict[str, Counter[str]] = {}
        #: (ROS 2 topic, ROS 2 type) of each publisher never heard, and why
        self.ignored: dict[tuple[str, str], str] = {}

    def drop(self, topic: str, reason: str, detail: str) -> None:
        """Count one message of ``topic`` dropped for ``reason`` (``detail``: one line)."""
        counts = self.by_topic.setdefault(topic, Counter())
        counts[reason] += 1
        if counts[reason] == 1:
            log.warning(
                "dropped a message (%s): %s; further ones of this kind on %s are counted in the "
                "run's manifest (transport.drops)",
                reason,
                detail,
                topic,
            )
        else:
            log.debug("dropped a message (%s): %s", reason, detail)

    def ignore(self, topic: str, type_name: str, reason: str) -> None:
        """Note a publisher of ``type_name`` on ``topic`` that the node never hears."""
        if (topic, type_name) in self.ignored:
            return
        self.ignored[(topic, type_name)] = reason
        log.warning("not heard: a publisher of %s on %s (%s)", type_name, topic, reason)

    @property
    def total(self) -> int:
        """Messages dropped so far."""
        return sum(sum(c.values()) for c in self.by_topic.values())

    def by_reason(self) -> dict[str, int]:
        """Messages dropped per reason, over all topics."""
        total: Counter[str] = Counter()
        for counts in self.by_topic.values():
            total.update(counts)
        return dict(sorted(total.items()))

    def unknown_names(self) -> list[str]:
        """Names whose poses are published though the scenario does not have them."""
        return sorted(
            topic.strip("/").removesuffix("/pose")
            for (topic, _), reason in self.ignored.items()
            if reason == "unknown_name"
        )

    def manifest(self) -> dict[str, Any]:
        """The manifest's account: ``drops`` per reason, ``drops_by_topic``,
        ``ignored_publishers``."""
        return {
            "drops": self.by_reason(),
            "drops_by_topic": {
                t: dict(sorted(c.items())) for t, c in sorted(self.by_topic.items())
            },
            "ignored_publishers": [
                {"topic": topic, "type": type_name, "reason": reason}
                for (topic, type_name), reason in sorted(self.ignored.items())
            ],
        }


def _ros_topic(dds_name: str) -> str:
    """``rt/cf1/pose`` → ``/cf1/pose``."""
    return "/" + dds_name.removeprefix("rt/")


def _ros_type(dds_type: str) -> str:
    """``geometry_msgs::msg::dds_::PoseStamped_`` → ``geometry_msgs/msg/PoseStamped``."""
    return dds_type.replace("::dds_::", "::").replace("::", "/").removesuffix("_")


class PublicationWatch:
    """Reads DDS discovery for publishers the node will never hear.

    ``subscribed`` maps each DDS topic the node reads to its DDS type name; ``names`` are the
    robots and targets of the scenario. :meth:`poll` returns, once each, ``(topic, type,
    reason)`` in ROS 2 names for a publisher of another type on a subscribed topic
    (``wrong_type``) or on ``rt/<name>/pose`` for a name not in ``names`` (``unknown_name``).
    """

    def __init__(
        self, participant: DomainParticipant, subscribed: dict[str, str], names: list[str]
    ):
        self._reader = BuiltinDataReader(participant, BuiltinTopicDcpsPublication)
        self._subscribed = subscribed
        self._names = set(names)

    def poll(self) -> list[tuple[str, str, str]]:
        """The publishers announced since the last call that the node will not hear."""
        found = []
        for sample in self._reader.take(N=64):
            topic, type_name = getattr(sample, "topic_name", None), getattr(sample, "type_name", "")
            if not isinstance(topic, str):
                continue  # a publication that went away
            expected = self._subscribed.get(topic)
            if expected is not None:
                if type_name != expected:
                    found.append((_ros_topic(topic), _ros_type(type_name), "wrong_type"))
            elif topic.startswith("rt/") and topic.endswith("/pose"):
                name = topic.removeprefix("rt/").removesuffix("/pose")
                if name and name not in self._names:
                    found.append((_ros_topic(topic), _ros_type(type_name), "unknown_name"))
        return found
