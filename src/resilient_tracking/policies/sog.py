"""Risk-aware SOG baseline after Mayya et al., RA-L 2022, "Adaptive and Risk-Aware Target
Tracking with Heterogeneous Robot Teams" (docs/model.md §7).

**A reconstruction.** The original program could not be consulted; this policy is rebuilt
from its published description as docs/model.md §7 restates it, and the choices it had to make are
listed in ``docs/paper-map.md``. Per league, every tick (program in ``planning/sog_problem``):

* the failure likelihood ``φ_i(x)`` of each robot near the sensing zones the league *knows*
  (belief only) is the zone hazard of docs/model.md §2 accumulated over ``risk_window`` seconds;
* the safety-aware observability Gramian ``O_j = Σ_i (1 − φᵒ_i) Hᵀ R⁻¹ H`` weighs each
  sensor's information by its probability ``1 − φᵒ_i`` of surviving the planned step
  (``survival_steps``), and ``P⁺_j = (P⁻_j⁻¹ + O_j)⁻¹``;
* the league minimises control effort plus penalised slacks on ``tr P⁺_j ≤ ρ1`` and
  ``φ_i ≤ ρ2``; the slack penalties follow the **sensor abundance** ``a`` (fraction of the
  team's robots whose sensor works), geometrically from the ``scarce`` weights at ``a = 0``
  (risk-averse) to the ``abundant`` ones at ``a = 1`` (aggressive).

Unlike the failure-aware policy it has no comm-zone reasoning, no circular evasion or circle
inference and no cool-down; it learns sensing zones from attack clues and shares them within a
league. A robot cut off from the others plans alone (mode ``individual``). When no solver
attempt succeeds, the league takes the shared safe action
(:meth:`~resilient_tracking.policies.planning_helpers.PlanningPolicy.settle`): SOG states no
chance constraints, so a robot inside the disk of a sensing zone it knows (``β = 0``) steps out
of it, every other robot holds.
"""

from __future__ import annotations

from functools import partial

import numpy as np
from pydantic import Field

from resilient_tracking.belief.knowledge import KnowledgeBase
from resilient_tracking.belief.team_belief import TeamBelief
from resilient_tracking.observation import TeamObservation
from resilient_tracking.planning.layout import Weight, sensing_row, sensing_table
from resilient_tracking.planning.planner import LeaguePlanner
from resilient_tracking.planning.sog_problem import SogInputs, SogPlanner, zone_rows
from resilient_tracking.policies.base import Decision, register_policy
from resilient_tracking.policies.planning_helpers import PlanningPolicy
from resilient_tracking.spec import (
    MAX_DURATION,
    MAX_RATE,
    MAX_VARIANCE,
    MIN_VARIANCE,
    PositiveWeight,
    Strict,
)
from resilient_tracking.team_config import TeamConfig


class SogSlackWeights(Strict):
    """Penalties on the SOG program's slacks at one extreme of the sensor abundance."""

    track: PositiveWeight = Field(
        ...,
        description="Penalty on δ1j, the excess of tr P⁺_j over ρ1.",
        json_schema_extra={"unit": "1/m²"},
    )
    risk: PositiveWeight = Field(
        ..., description="Penalty on δ2i, the excess of the failure likelihood φ_i over ρ2."
    )


class SogParams(Strict):
    """Risk-aware SOG baseline after Mayya et al. (RA-L 2022), rebuilt from its published
    description (docs/model.md §7); see ``policies/sog.py``."""

    rho1: float = Field(
        0.01,
        ge=MIN_VARIANCE,
        le=MAX_VARIANCE,
        description="Tracking requirement tr P⁺_j ≤ ρ1 per target (position block).",
        json_schema_extra={"unit": "m²"},
    )
    rho2: float = Field(
        0.3,
        gt=0,
        lt=1,
        description="Acceptable risk φ_i ≤ ρ2: risky 0.6, regular 0.3, conservative 0.2.",
    )
    effort: PositiveWeight = Field(0.05, description="Weight on the control effort Σ_i ‖u_i‖².")
    abundant: SogSlackWeights = Field(
        SogSlackWeights(track=100.0, risk=2.0),
        description="Slack penalties with every sensor working (aggressive).",
    )
    scarce: SogSlackWeights = Field(
        SogSlackWeights(track=5.0, risk=2000.0),
        description=(
            "Slack penalties with no sensor left (risk-averse); geometric interpolation in between."
        ),
    )
    hazard_rate: float = Field(
        1.0,
        gt=0,
        le=MAX_RATE,
        description=(
            "Attack rate κ f_act the team assumes for a known zone (clues do not carry it)."
        ),
        json_schema_extra={"unit": "1/s"},
    )
    risk_window: float = Field(
        10.0,
        gt=0,
        le=MAX_DURATION,
        description=(
            "φ is the chance of an attack when staying at x this long, about the time a target of"
            " the shipped scenarios takes to cross a zone."
        ),
        json_schema_extra={"unit": "s"},
    )
    survival_steps: int = Field(
        1,
        ge=1,
        le=10_000,
        description=(
            "Steps over which each sensor is weighed by its survival in the Gramian (1: the "
            "planned step)."
        ),
        json_schema_extra={"unit": "steps"},
    )


def abundance_weights(params: SogParams, abundance: float) -> tuple[float, float]:
    """Slack penalties ``(w_track, w_risk)`` at sensor abundance ``a ∈ [0, 1]``:
    ``w = w_scarce^(1−a) · w_abundant^a``."""
    a = min(max(abundance, 0.0), 1.0)
    lo, hi = params.scarce, params.abundant
    return lo.track ** (1 - a) * hi.track**a, lo.risk ** (1 - a) * hi.risk**a


@register_policy("sog")
class SogPolicy(PlanningPolicy):
    """The risk-aware SOG baseline (module docstring): one SOG program per league."""

    name = "sog"
    Params = SogParams
    learns_zones = True
    params: SogParams

    def __init__(
        self,
        config: TeamConfig,
        params: SogParams,
        planner: LeaguePlanner | None = None,
        sog_planner: SogPlanner | None = None,
    ):
        super().__init__(config, params, planner)
        # the scenario's solver choice (``planner.solver``) holds for SOG's program too
        self.sog_planner = sog_planner or SogPlanner(
            self.planner.fault_hook, solver=self.planner.solver, options=self.planner.options
        )
        #: ``(w_track, w_risk)`` used at the last tick (for inspection and tests)
        self.last_weights = abundance_weights(params, 1.0)

    def risk_scale(self) -> float:
        """``c = κ f_act T_risk`` in the safety requirement's ``φ = 1 − exp(−c pdf)``."""
        return self.params.hazard_rate * self.params.risk_window

    def survival_scale(self) -> float:
        """``c = κ f_act T_survival`` in the SOG's survival weights ``1 − φᵒ``."""
        return self.params.hazard_rate * self.params.survival_steps * self.config.dt

    @staticmethod
    def known_zones(knowledge: KnowledgeBase) -> np.ndarray:
        """Rows of the sensing zones a league knows (comm zones play no part in SOG)."""
        zones = knowledge.of_kind("sensing")
        return zone_rows([z.mean for z in zones], [z.cov for z in zones])

    @staticmethod
    def known_disks(knowledge: KnowledgeBase) -> np.ndarray:
        """Sensing rows of the known zones' disks (``β = 0``) for the safe action."""
        rows = [
            sensing_row(z.mean, z.cov, r_safe=z.size + z.clearance, beta=0.0)
            for z in knowledge.of_kind("sensing")
        ]
        return sensing_table(rows)

    def act(self, belief: TeamBelief, obs: TeamObservation) -> Decision:
        """Per league: abundance weights, then the SOG program (module docstring)."""
        m = obs.n_robots
        decision = Decision(controls=np.zeros((m, 2)), modes=["league"] * m)
        w_track, w_risk = abundance_weights(self.params, float(np.mean(obs.sensing_ok)))
        self.last_weights = (w_track, w_risk)
        for k in self.planning_order(belief.leagues):
            robots = belief.leagues[k]
            sensing = obs.sensing_ok[robots].astype(float)
            base = self.tracking_inputs(
                belief, obs, robots, k, np.zeros(Weight.COUNT), sensing, with_route=False
            )
            knowledge = belief.league_knowledge(robots)
            q = SogInputs(
                positions=base.positions,
                sensing=base.sensing,
                targets=base.targets,
                prior_info=base.prior_info,
                sensor=base.sensor,
                dt=base.dt,
                u_lower=base.u_lower,
                u_upper=base.u_upper,
                zones=self.known_zones(knowledge),
                rho1=self.params.rho1,
                rho2=self.params.rho2,
                w_effort=self.params.effort,
                w_track=w_track,
                w_risk=w_risk,
                risk_scale=self.risk_scale(),
                survival_scale=self.survival_scale(),
                sensor_model=base.sensor_model,
            )
            base.sensing_zones = self.known_disks(knowledge)
            decision.controls[robots] = self.settle(
                partial(self.sog_planner.plan_sog, tuple(robots), q),
                robots,
                base,
                obs.step,
                decision,
            )
            for i in robots:
                decision.modes[i] = "league" if len(robots) > 1 else "individual"
        return decision
