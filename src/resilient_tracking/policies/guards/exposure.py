"""Exposure over time: the risk a team has already run near each known zone (belief only).

The chance constraints of eqs. 7c and 7d bound the risk of *one* step: a robot may stand where
the zone's centre lies within its keep-out radius with probability ``ε``. A robot that holds
station at the edge of a keep-out disc for a hundred steps runs that risk a hundred times.

With this guard (beyond the paper, off by default) the ledger counts, per known zone, the
robot-steps spent *near* its keep-out disc: where the keep-out margin ``h`` of eq. 7c
(docs/model.md §5) is at most one spread ``√(2 λ_max(Σ))`` of the zone estimate, so the band
scales with how uncertain the zone is. The risk level of the zone's constraint then halves each
time its exposure doubles past a horizon ``H`` (steps)::

    ε_z = ε / 2^k,   k = ⌊log₂(1 + n_z / H)⌋

Each halving lasts twice as long as the last, so the risk spent per period stays about ``ε H``
and the total grows with the logarithm of the time spent near the zone instead of linearly; the
keep-out disc widens in steps (its radius grows with ``β = erfinv(1 − 2ε_z)``), which also keeps
the route maps built on it reusable between steps. Exposure is never forgotten: the risk already
run is spent.
"""

from __future__ import annotations

import math
from collections.abc import Hashable
from typing import TYPE_CHECKING

import numpy as np
from pydantic import Field

from resilient_tracking.belief.knowledge import ZoneEstimate
from resilient_tracking.observation import TeamObservation
from resilient_tracking.planning.layout import SensingRow
from resilient_tracking.planning.margins import keep_out_values, largest_variance
from resilient_tracking.policies.guards.base import Guard, GuardParams, register_guard
from resilient_tracking.team_config import TeamConfig

if TYPE_CHECKING:
    from resilient_tracking.policies.failure_aware_params import FailureAwareParams


class ExposureLedger:
    """Robot-steps spent near each known zone, by the zone estimate's key."""

    def __init__(self, horizon: int):
        #: steps of exposure after which the risk level first halves (0: never)
        self.horizon = horizon
        self.steps: dict[str, int] = {}

    def level(self, key: str) -> int:
        """How many times the risk level of zone ``key`` has halved."""
        if self.horizon <= 0:
            return 0
        return int(math.floor(math.log2(1.0 + self.steps.get(key, 0) / self.horizon)))

    def risk(self, eps: float, key: str) -> float:
        """The risk level of zone ``key`` from base level ``eps``: halved ``level(key)`` times."""
        return eps / 2 ** self.level(key)

    def record(self, keys: list[str], rows: np.ndarray, positions: np.ndarray) -> None:
        """Add a step of exposure to zone ``keys[r]`` for each position near keep-out row
        ``rows[r]`` (a :class:`~resilient_tracking.planning.layout.SensingRow`)."""
        if self.horizon <= 0 or not len(keys) or not len(positions):
            return
        gaussians = rows[:, SensingRow.GAUSSIAN]
        band = np.sqrt(2.0 * np.maximum(largest_variance(gaussians), 0.0))
        for x in np.asarray(positions, dtype=float).reshape(-1, 2):
            h = keep_out_values(x, gaussians, rows[:, SensingRow.R_SAFE], rows[:, SensingRow.BETA])
            for r in np.flatnonzero(h <= band):
                self.steps[keys[r]] = self.steps.get(keys[r], 0) + 1


class ExposureParams(GuardParams):
    """Risk accumulated over time near a known zone's keep-out disc."""

    horizon: int = Field(
        20,
        ge=1,
        le=1_000_000,
        description=(
            "Robot-steps near a known zone's keep-out disc after which the risk level of its"
            " constraint halves, and halves again each time that exposure doubles"
            " (docs/calibration.md measures it)."
        ),
        json_schema_extra={"unit": "steps"},
    )


@register_guard("exposure")
class ExposureGuard(Guard):
    """Each known zone's risk level halves as the team's exposure to it doubles (module
    docstring)."""

    name = "exposure"
    Params = ExposureParams
    params: ExposureParams

    def __init__(self, params: ExposureParams, config: TeamConfig, method: FailureAwareParams):
        super().__init__(params, config, method)
        #: robot-steps spent near each known zone
        self.ledger = ExposureLedger(params.horizon)

    def zone_risk(self, eps: float, zone: ZoneEstimate) -> float:
        """``eps`` halved once per doubling of the team's exposure to ``zone``."""
        return self.ledger.risk(eps, zone.key)

    def rows_state(self, zones: tuple[ZoneEstimate, ...]) -> Hashable:
        """How many times each zone's risk level has halved."""
        return tuple(self.ledger.level(z.key) for z in zones)

    def after_rows(
        self,
        keys: list[str],
        table: np.ndarray,
        n_sensing: int,
        robots: list[int],
        obs: TeamObservation,
    ) -> None:
        """Count a step of exposure for each robot near a disc that can still harm it."""
        # a sensing zone's disc harms a working sensor, a comm zone's a working radio
        sensing = [i for i in robots if obs.sensing_ok[i]]
        radio = [i for i in robots if obs.comm_ok[i]]
        self.ledger.record(keys[:n_sensing], table[:n_sensing], obs.positions[sensing])
        self.ledger.record(keys[n_sensing:], table[n_sensing:], obs.positions[radio])
