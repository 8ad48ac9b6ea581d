"""More caution for the last working sensors (beyond the paper, docs/model.md §6).

Losing the last sensor leaves the team blind for good, so the last sensors are worth more than
the first: with ``s`` of the team's ``M`` robots still sensing, the sensing zones' chance
constraints (eq. 7c) hold at risk level ``ε1 · s/M`` instead of ``ε1``.
"""

from __future__ import annotations

from pydantic import Field

from resilient_tracking.policies.guards.base import Guard, GuardParams, register_guard


class LastSensorsParams(GuardParams):
    """The sensing zones' risk level shrinks with the share of robots still sensing."""

    enabled: bool = Field(True, description="Whether the team uses this guard (on by default).")


@register_guard("last_sensors")
class LastSensorsGuard(Guard):
    """``ε1 · s/M`` for the sensing zones' rows (module docstring)."""

    name = "last_sensors"
    Params = LastSensorsParams

    def sensing_risk(self, eps: float, sensing: int, m: int) -> float:
        """``eps · s/M`` while a sensor is lost."""
        if sensing >= m:
            return eps
        return eps * max(sensing, 1) / m
