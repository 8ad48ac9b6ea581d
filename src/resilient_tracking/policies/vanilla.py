"""Vanilla baseline (docs/model.md §7): fixed weights, no zone knowledge, no adaptation.

Each league minimises ``w1 Σ tr P⁺ + w2 Σ‖u‖²``; robots that cannot sense contribute nothing,
and a robot cut off from the others plans alone.
"""

from __future__ import annotations

import numpy as np
from pydantic import Field

from resilient_tracking.belief.team_belief import TeamBelief
from resilient_tracking.observation import TeamObservation
from resilient_tracking.planning.planner import LeaguePlanner
from resilient_tracking.policies.base import Decision, register_policy
from resilient_tracking.policies.planning_helpers import PlanningPolicy
from resilient_tracking.spec import PositiveWeight, Strict
from resilient_tracking.team_config import TeamConfig


class VanillaParams(Strict):
    """Fixed weights (docs/model.md §7.1): tracking trace and control effort."""

    w_track: PositiveWeight = Field(
        50.0, description="Weight w1 on the predicted tracking uncertainty Σ_j tr P⁺_j."
    )
    w_effort: PositiveWeight = Field(
        0.05, description="Weight w2 on the control effort Σ_i ‖u_i‖²."
    )


@register_policy("vanilla")
class VanillaPolicy(PlanningPolicy):
    """The vanilla baseline (module docstring): fixed weights, no zone knowledge."""

    name = "vanilla"
    Params = VanillaParams
    learns_zones = False
    params: VanillaParams

    def __init__(
        self, config: TeamConfig, params: VanillaParams, planner: LeaguePlanner | None = None
    ):
        super().__init__(config, params, planner)
        self.weights = np.array([params.w_track, params.w_effort, 0.0, 0.0])

    def act(self, belief: TeamBelief, obs: TeamObservation) -> Decision:
        """Per league, its sensing robots minimise tracking trace plus effort; others idle."""
        m = obs.n_robots
        decision = Decision(controls=np.zeros((m, 2)), modes=["idle"] * m)
        for k in self.planning_order(belief.leagues):
            robots = belief.leagues[k]
            # Robots that cannot sense gain nothing by moving: they stay put ("idle").
            sensing = [i for i in robots if obs.sensing_ok[i]]
            if not sensing:
                continue
            q = self.tracking_inputs(belief, obs, sensing, k, self.weights, np.ones(len(sensing)))
            decision.controls[sensing] = self.solve(sensing, q, obs.step, decision)
            mode = "league" if len(robots) > 1 else "individual"
            for i in sensing:
                decision.modes[i] = mode
        return decision
