"""Caution priced by what a failure costs (beyond the paper, docs/model.md §6.7).

The paper holds every sensing zone's keep-out row (eq. 7c) at one risk level ε1 and every comm
zone's (eq. 7d) at ε2, whatever the failure would cost. This guard scales each row's level by
the expected cost of the failure its zone would cause to the robots of the league near it,
relative to the cost the paper's levels are set for — the loss of one of ``M`` equally useful
sensors for a share ``D̄`` of the mission, by default the rest of it::

    ρ_il = φ_l · max(1, M · v_i) · D_l / D̄        ε_il = clip(ε / ρ_il, ε / ρ_max, ε_max)

* ``φ_l``: what the failure takes: 1 for a failure, ``degrade_fraction`` for a zone whose
  attacks the team felt as a degradation (the capability still works, worse);
* ``v_i``: what the capability of robot ``i`` adds to the team's tracking, the larger of its
  share of the working sensors' measurement information now (``Hᵀ R⁻¹ H`` at the estimated
  target positions) and an equal share ``1/s`` of the ``s`` sensors not lost for good: the last
  working sensor is worth the whole team's; a sensor lost for good is worth nothing more, and
  so is a radio already lost. A robot is never priced below an equal share (``max(1, ·)``):
  what a sensor adds now says little about what it would add later;
* ``D_l``: the share of the mission the failure lasts: 1 for a zone not known to be temporary
  (its eq. 7d rows also keep a league off a permanent comm zone's hazard); for a temporary one,
  the mean length of the temporary failures of that kind the team has seen (starting from
  ``temporary_steps``) over the mission's length ``T`` (the team's ``mission_steps``, else
  ``horizon``);
* ``D̄`` (``reference_share``): the persistence the paper's levels are taken to be set for,
  1 (a permanent failure). The paper sets one ``ε1`` and one ``ε2`` for its temporary and
  permanent experiments alike; ``D̄ = ½`` reads them as set for their mean persistence, which
  prices a permanent failure twice as high (measured in docs/caution.md, not the default).

A league's row takes the highest cost of the robots near its zone (within ``reach`` of the
keep-out disc), since one row holds for the whole league. With ``ρ = 1`` — equal sensors, a
failure lasting ``D̄`` of the mission — the levels are the paper's.
"""

from __future__ import annotations

from collections import defaultdict
from typing import TYPE_CHECKING

import numpy as np
from pydantic import Field

from resilient_tracking.belief.estimate import TargetEstimate
from resilient_tracking.belief.knowledge import KnowledgeBase, ZoneEstimate
from resilient_tracking.observation import TeamObservation
from resilient_tracking.planning.adaptation import chance_margin, risk_level
from resilient_tracking.planning.layout import CommRow, SensingRow
from resilient_tracking.policies.guards.base import Guard, GuardParams, LeagueRows, register_guard
from resilient_tracking.spec import MAX_STEP_COUNT, Length
from resilient_tracking.team_config import TeamConfig

if TYPE_CHECKING:
    from resilient_tracking.policies.failure_aware_params import FailureAwareParams


class PricedCautionParams(GuardParams):
    """The cost model's settings (module docstring)."""

    degrade_fraction: float = Field(
        0.5,
        ge=0,
        le=1,
        description="φ of a zone whose attacks degrade rather than destroy (the share lost).",
        json_schema_extra={"unit": "fraction"},
    )
    temporary_steps: float = Field(
        10.0,
        gt=0,
        le=MAX_STEP_COUNT,
        description="Prior mean length of a temporary failure, before any is seen.",
        json_schema_extra={"unit": "steps"},
    )
    horizon: int = Field(
        300,
        ge=1,
        le=MAX_STEP_COUNT,
        description="Mission length T when the team is not told it (TeamConfig.mission_steps).",
        json_schema_extra={"unit": "steps"},
    )
    reference_share: float = Field(
        1.0,
        gt=0,
        le=1,
        description=(
            "D̄: the share of the mission a failure lasts for which the paper's risk levels "
            "are taken to be set; 1: a permanent failure."
        ),
        json_schema_extra={"unit": "fraction"},
    )
    max_ratio: float = Field(
        10.0,
        ge=1,
        le=1000,
        description="ρ_max: the most a cost can tighten a level (ε / ρ_max at least).",
        json_schema_extra={"unit": "ratio"},
    )
    max_risk: float = Field(
        0.45,
        gt=0,
        lt=0.5,
        description="ε_max: the loosest level a cheap failure gets.",
    )
    information_share: bool = Field(
        True,
        description=(
            "Whether a robot's value counts its share of the measurement information now "
            "(else only the redundancy left, 1/s)."
        ),
    )
    reach: Length = Field(
        1.0,
        description="A robot within this distance of a zone's keep-out disc prices its row.",
        json_schema_extra={"unit": "m"},
    )


@register_guard("priced")
class PricedCautionGuard(Guard):
    """Each zone row's risk level scaled by the expected cost of its failure (module
    docstring)."""

    name = "priced"
    Params = PricedCautionParams
    params: PricedCautionParams

    def __init__(self, params: GuardParams, config: TeamConfig, method: FailureAwareParams):
        super().__init__(params, config, method)
        #: when each (robot, kind) temporary failure under way began
        self._began: dict[tuple[int, str], int] = {}
        #: lengths of the temporary failures seen, by kind
        self._lengths: dict[str, list[int]] = defaultdict(list)
        #: ids of zones whose attacks came as a degradation
        self._degrading: set[int] = set()

    # ------------------------------------------------------------------ what the team saw

    def observe(self, obs: TeamObservation) -> None:
        """Learn how long temporary failures last and which zones degrade."""
        for a in obs.attacks:
            if a.cause == "degradation":
                self._degrading.add(a.clue.zone_id)
            kind = a.clue.kind
            if a.cause == "jamming" or a.clue.persistence == "temporary":
                self._began.setdefault((a.robot, kind), obs.step)
        for robot, kind in obs.recoveries:
            began = self._began.pop((robot, kind), None)
            if began is not None:
                self._lengths[kind].append(max(obs.step - began, 1))

    def temporary_length(self, kind: str) -> float:
        """Mean length of a temporary failure of ``kind``: the prior counted as one failure
        seen, then every one seen."""
        seen = self._lengths[kind]
        return (self.params.temporary_steps + sum(seen)) / (1 + len(seen))

    # ------------------------------------------------------------------ the cost

    def sensor_values(self, estimate: TargetEstimate, obs: TeamObservation) -> np.ndarray:
        """``v_i`` of every robot's sensor: the larger of its information share and ``1/s``;
        0 for a sensor lost for good."""
        working = np.array([p != "permanent" for p in obs.sensing_persistence])
        s = int(working.sum())
        if s == 0:
            return np.zeros(obs.n_robots)
        share = np.zeros(obs.n_robots)
        if self.params.information_share:
            info = self.config.sensor.information(
                obs.positions[:, None, :], estimate.mean[None, :, :2]
            )  # (M, N, 3): xx, xy, yy
            amount = (info[..., 0] + info[..., 2]).sum(axis=1) * working
            total = float(amount.sum())
            if total > 0:
                share = amount / total
        return np.where(working, np.maximum(share, 1.0 / s), 0.0)

    def cost_ratio(self, zone: ZoneEstimate, persistent: bool, value: float) -> float:
        """``ρ`` of a failure from ``zone`` to a robot whose capability is worth ``value``;
        ``persistent``: the failure lasts the rest of the mission."""
        if value <= 0:
            return 0.0
        horizon = self.config.mission_steps or self.params.horizon
        lasts = 1.0 if persistent else min(self.temporary_length(zone.kind) / horizon, 1.0)
        share = self.params.degrade_fraction if zone.zone_id in self._degrading else 1.0
        return share * max(1.0, self.config.n_robots * value) * lasts / self.params.reference_share

    def price_rows(
        self,
        rows: LeagueRows,
        robots: list[int],
        estimate: TargetEstimate,
        knowledge: KnowledgeBase,
        obs: TeamObservation,
    ) -> None:
        """Scale each row's level by the highest cost ratio of the league's robots near it."""
        values = self.sensor_values(estimate, obs)
        for table, keys, width, links in (
            (rows.sensing, rows.sensing_keys, SensingRow, False),
            (rows.comm, rows.comm_keys, CommRow, True),
        ):
            for r, key in enumerate(keys):
                zone = knowledge.zones.get(key)
                if zone is None:
                    continue
                if links:  # an eq. 7d row concerns every link of the league
                    near = robots
                else:
                    reach = float(table[r, SensingRow.R_SAFE]) + self.params.reach
                    distance = np.linalg.norm(obs.positions[robots] - zone.mean, axis=1)
                    near = [i for i, d in zip(robots, distance, strict=True) if d <= reach]
                if not near:
                    continue
                # a zone not known to be temporary is priced as permanent: a league's eq. 7d
                # rows also keep it off a permanent comm zone's hazard
                persistent = zone.persistence != "temporary"
                ratio = max(
                    self.cost_ratio(zone, persistent, self._value(i, zone, values, obs))
                    for i in near
                )
                eps = float(risk_level(table[r, width.BETA]))
                if ratio <= 0:  # nothing left to lose
                    eps = self.params.max_risk
                else:
                    eps = min(max(eps / ratio, eps / self.params.max_ratio), self.params.max_risk)
                table[r, width.BETA] = chance_margin(eps)

    def _value(
        self, robot: int, zone: ZoneEstimate, values: np.ndarray, obs: TeamObservation
    ) -> float:
        """What ``robot`` stands to lose to ``zone``: its sensor's value; a radio it still has
        is worth what its sensor adds to the league (a permanent comm failure ends its
        tracking, Alg. 4; a jammed robot's measurements stop reaching its league)."""
        if zone.kind == "comm" and not obs.comm_ok[robot]:
            return 0.0
        return float(values[robot])
