"""Circling without losing the sensor (beyond the paper, docs/model.md §6).

A robot whose radio a permanent comm zone destroyed circles its attacker (Alg. 4). With this
guard, a robot that still senses turns back where its circle would take it into, or deeper
into, a known sensing zone's keep-out disc (eq. 7c at ε1), so its sensor survives the signal:
the arc it sweeps still shows the circle.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from pydantic import Field

from resilient_tracking.observation import TeamObservation
from resilient_tracking.planning.layout import SensingRow
from resilient_tracking.planning.margins import keep_out_values
from resilient_tracking.policies.guards.base import Guard, GuardParams, register_guard


class SafeCirclingParams(GuardParams):
    """A circling robot turns back at a known sensing zone's keep-out disc."""

    enabled: bool = Field(True, description="Whether the team uses this guard (on by default).")


@register_guard("safe_circling")
class SafeCirclingGuard(Guard):
    """A sensing robot's circle turns back at a keep-out disc (module docstring)."""

    name = "safe_circling"
    Params = SafeCirclingParams

    def turns_back(
        self,
        robot: int,
        obs: TeamObservation,
        step: np.ndarray,
        keep_out: Callable[[], np.ndarray],
    ) -> bool:
        """Turn back where the circle enters a keep-out disc, while the sensor works."""
        if not obs.sensing_ok[robot]:
            return False
        rows = keep_out()
        return bool(len(rows)) and enters(obs.positions[robot], step, rows)


def enters(position: np.ndarray, step: np.ndarray, rows: np.ndarray) -> bool:
    """Whether moving by ``step`` takes ``position`` into, or deeper into, a keep-out disc of
    the sensing rows (eq. 7c's margin falls below zero and keeps falling)."""
    gaussians = rows[:, SensingRow.GAUSSIAN]
    offset, beta = rows[:, SensingRow.R_SAFE], rows[:, SensingRow.BETA]
    now = keep_out_values(position, gaussians, offset, beta)
    then = keep_out_values(position + step, gaussians, offset, beta)
    return bool(np.any((then < 0) & (then < now)))
