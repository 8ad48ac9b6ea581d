"""Topic names and the settings both nodes share.

Default names follow Crazyswarm2: robot ``i`` is ``cf{i+1}`` with its pose on ``/cf1/pose``
and its commands on ``/cf1/cmd_full_state``; targets are ``target{j+1}`` with poses on
``/target1/pose`` (motion capture publishes rigid bodies by name). The synthesized observations
are on ``/rtrack/observation`` and the team's belief on ``/rtrack/belief``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from resilient_tracking.scenario import Scenario

CommandKind = Literal["full_state", "twist"]

OBSERVATION_TOPIC = "/rtrack/observation"
BELIEF_TOPIC = "/rtrack/belief"


@dataclass
class NodeSettings:
    """What the tracker and world nodes must agree on."""

    robots: list[str]
    targets: list[str]
    #: ``full_state``: Crazyswarm2's ``cmd_full_state``; ``twist``: ``cmd_vel`` (Twist).
    command: CommandKind = "full_state"
    lockstep: bool = False
    #: flight altitude (m) for drones' setpoints and simulated poses
    altitude: float = 0.5
    frame: str = "world"
    domain_id: int | None = None
    #: a robot with no pose for this long (s) holds position while the team plans for the
    #: others; running free, the tracker drops a pose stamped more than this from its clock
    pose_timeout: float = 0.5
    #: no observation for this long (s): hold position; running free, the tracker drops an
    #: observation stamped more than this from its clock
    observation_timeout: float = 1.0
    #: no observation for this long (s): give up and write what was recorded
    give_up: float = 30.0
    #: the tracker: stop when no observation, or no pose of some robot, came within this (s);
    #: the world: how long to wait for the tracker (lock-step) or the poses (mocap)
    startup_timeout: float = 60.0
    #: running free: the share of the control period, from taking an observation, by which
    #: a league planned as sub-teams must be planned; its sub-teams not planned by then coast
    #: or hold that tick (None: no limit)
    plan_budget: float | None = 0.35

    @classmethod
    def for_scenario(
        cls,
        scenario: Scenario,
        robot_prefix: str = "cf",
        target_prefix: str = "target",
        **kwargs: object,
    ) -> NodeSettings:
        """Settings for ``scenario``'s team: robots ``cf1..cfM`` and targets ``target1..targetN``
        (or the prefixes given); other fields from ``kwargs``."""
        robots = [f"{robot_prefix}{i + 1}" for i in range(len(scenario.robots))]
        targets = [f"{target_prefix}{j + 1}" for j in range(len(scenario.targets))]
        return cls(robots=robots, targets=targets, **kwargs)  # type: ignore[arg-type]

    def pose_topic(self, name: str) -> str:
        """``/<name>/pose``: the pose of a robot or target (motion capture or the simulated
        world)."""
        return f"/{name}/pose"

    def command_topic(self, robot: str) -> str:
        """A robot's command topic: ``/<robot>/cmd_full_state`` (Crazyswarm2) or
        ``/<robot>/cmd_vel`` (Twist), per :attr:`command`."""
        return f"/{robot}/cmd_full_state" if self.command == "full_state" else f"/{robot}/cmd_vel"
