"""Signal, then track (beyond the paper, docs/model.md §6.5).

In the paper's Alg. 4 a robot whose radio a permanent comm zone destroyed circles its attacker
for the rest of the episode: the signal teammates read (Alg. 3). With this guard it circles
``turns`` times, then tracks alone again with its sensor, keeping clear of the zones it knows.
The angle swept around the attacker's estimate is summed tick by tick.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from pydantic import Field

from resilient_tracking.belief.knowledge import ZoneEstimate
from resilient_tracking.observation import TeamObservation
from resilient_tracking.policies.guards.base import Guard, GuardParams, register_guard
from resilient_tracking.team_config import TeamConfig

if TYPE_CHECKING:
    from resilient_tracking.policies.failure_aware_params import FailureAwareParams


class SignalTurnsParams(GuardParams):
    """How many times a robot circles its attacker before it tracks alone again."""

    turns: float = Field(
        1.0,
        gt=0,
        le=100,
        description="Turns around the attacker's estimate before the robot tracks alone.",
        json_schema_extra={"unit": "turns"},
    )


@register_guard("signal_turns")
class SignalTurnsGuard(Guard):
    """Circle ``turns`` times, then track (module docstring)."""

    name = "signal_turns"
    Params = SignalTurnsParams
    params: SignalTurnsParams

    def __init__(self, params: SignalTurnsParams, config: TeamConfig, method: FailureAwareParams):
        super().__init__(params, config, method)
        #: per robot: its last angle around its attacker and the angle swept
        self._swept: dict[int, tuple[float, float]] = {}

    def stops_circling(
        self, robot: int, attacker: ZoneEstimate | None, obs: TeamObservation
    ) -> bool:
        """Once the robot swept ``turns`` full turns around its attacker."""
        if attacker is None:  # no clue of what hit it: nothing to signal
            return True
        offset = obs.positions[robot] - attacker.mean
        angle = math.atan2(offset[1], offset[0])
        last, swept = self._swept.get(robot, (angle, 0.0))
        swept += abs(math.remainder(angle - last, math.tau))
        self._swept[robot] = (angle, swept)
        return swept >= self.params.turns * math.tau
