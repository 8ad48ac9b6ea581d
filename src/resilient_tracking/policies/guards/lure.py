"""The lure guard: keeping away from targets suspected of luring robots into danger (beyond the
paper, docs/model.md §6.1).

From the league's estimate only, a target is suspect while one that kept a steady course speeds
up well beyond its usual speed (the surge cue, :mod:`~.surge_watch`), and for the rest of the
episode once one lingers after moving or stands at a known zone's keep-out disc
(:mod:`~.suspects`). The league keeps ``standoff`` from each suspect target: one more eq. 7c
row per suspect, at risk level ε1.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from resilient_tracking.belief.estimate import TargetEstimate
from resilient_tracking.events import Event
from resilient_tracking.observation import TeamObservation
from resilient_tracking.policies.guards.base import Guard, register_guard
from resilient_tracking.policies.guards.lure_params import LureGuardParams
from resilient_tracking.policies.guards.suspects import SuspectWatch
from resilient_tracking.team_config import TeamConfig

if TYPE_CHECKING:
    from resilient_tracking.policies.failure_aware_params import FailureAwareParams


@register_guard("lure")
class LureGuard(Guard):
    """Suspect targets and a stand-off from each (module docstring)."""

    name = "lure"
    Params = LureGuardParams
    params: LureGuardParams

    def __init__(self, params: LureGuardParams, config: TeamConfig, method: FailureAwareParams):
        super().__init__(params, config, method)
        #: targets each robot suspects of luring it into danger
        self.suspects = SuspectWatch(config.n_robots, params, config.dt)

    def league_rows(
        self,
        step: int,
        robots: list[int],
        estimate: TargetEstimate,
        predicted: TargetEstimate,
        zone_rows: np.ndarray,
        obs: TeamObservation,
        beta1: float,
    ) -> tuple[np.ndarray, list[Event]]:
        """Update the league's suspects; a stand-off row per suspect target."""
        events = self.suspects.observe(step, robots, estimate, zone_rows)
        return self.suspects.rows(robots, predicted, beta1), events
