"""ROS 2-compatible nodes over DDS: the team on robots, and a world to test it against.

ROS 2 talks DDS on the wire, so ``cyclonedds`` can publish and subscribe ROS 2 topics without
``rclpy`` when topic names (``rt/...``) and type names (``pkg::msg::dds_::Type_``) follow ROS 2's
conventions; ``rosbags`` carries ROS 2's message definitions and writes bags. Both come with the
``ros2`` extra and are imported only here, never by the base package. See ``docs/robots.md``.
"""

from __future__ import annotations

INSTALL_HINT = 'pip install "resilient-tracking[ros2]"'


class MissingExtraError(ImportError):
    """The ``ros2`` extra is not installed."""


def require_extra() -> None:
    """Raise :class:`MissingExtraError` with the install command when a dependency is missing."""
    for module in ("cyclonedds", "rosbags"):
        try:
            __import__(module)
        except ImportError as err:
            raise MissingExtraError(
                f"the ROS 2 nodes need the '{module}' package: {INSTALL_HINT}"
            ) from err
