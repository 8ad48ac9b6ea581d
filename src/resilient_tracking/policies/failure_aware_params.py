"""Parameters of the failure-aware policy (Algorithm 1): the adaptive weights' two extremes
and the cool-down set (eq. 10), the risk levels of the chance constraints (eqs. 7c, 7d) and
circular evasion (Alg. 4). The paper's parameters only: the mechanisms beyond it are guards
(:mod:`resilient_tracking.policies.guards`)."""

from __future__ import annotations

import numpy as np
from pydantic import Field

from resilient_tracking.spec import (
    MAX_STEP_COUNT,
    Length,
    PositiveWeight,
    Strict,
    Weight,
)


class WeightSet(Strict):
    """One extreme of the adaptive weights (paper eq. 10): ``w1..w4`` and the clearance ``w5``."""

    track: Weight = Field(description="w1: weight on the tracking term Σ_j tr P⁺_j.")
    effort: PositiveWeight = Field(..., description="w2: weight on the control effort Σ_i ‖u_i‖².")
    sensing_slack: Weight = Field(
        description="w3: penalty on the slacks of the sensing-zone chance constraints."
    )
    comm_slack: Weight = Field(
        description="w4: penalty on the slacks of the comm-zone chance constraints."
    )
    clearance: Length = Field(
        0.0,
        description="w5: clearance added to a sensing zone radius, r_safe = r + w5.",
        json_schema_extra={"unit": "m"},
    )

    def as_array(self) -> np.ndarray:
        """``[w1, w2, w3, w4, w5]``: track, effort, sensing slack, comm slack, clearance."""
        return np.array(
            [self.track, self.effort, self.sensing_slack, self.comm_slack, self.clearance]
        )


class FailureAwareParams(Strict):
    """The paper's Algorithm 1: adaptive weights (eq. 10), cool-down, the risk levels of the
    chance constraints (eqs. 7c, 7d) and circular evasion (Alg. 4). The mechanisms beyond the
    paper are guards (``guards``), the belief's settings its own (``belief``)."""

    risky: WeightSet = Field(
        WeightSet(track=50, effort=0.05, sensing_slack=200, comm_slack=100),
        description="Weights with no robot under attack (eq. 10, w_risky).",
    )
    safe: WeightSet = Field(
        WeightSet(track=45, effort=0.05, sensing_slack=2000, comm_slack=500, clearance=0.4),
        description=(
            "Weights with every robot under attack (eq. 10, w_safe); isolated robots use them."
        ),
    )
    cooldown: WeightSet = Field(
        WeightSet(track=40, effort=0.05, sensing_slack=4000, comm_slack=1000, clearance=0.6),
        description="Weights of the whole team during a cool-down after a temporary failure.",
    )
    cooldown_steps: int = Field(
        10,
        ge=0,
        le=MAX_STEP_COUNT,
        description="Length of the cool-down after a temporary failure.",
        json_schema_extra={"unit": "steps"},
    )
    eps1: float = Field(
        0.02,
        gt=0,
        lt=0.5,
        description=(
            "Risk level ε1 of the sensing-zone chance constraints (smaller: more cautious)."
        ),
    )
    eps2: float = Field(
        0.15,
        gt=0,
        lt=0.5,
        description="Risk level ε2 of the comm-zone chance constraints and of the evasion circle.",
    )
    comm_clearance: Length = Field(
        0.5,
        description="Clearance added around a comm zone an isolated robot escapes.",
        json_schema_extra={"unit": "m"},
    )
    circle_speed: float = Field(
        0.9,
        gt=0,
        le=1,
        description="Speed of circular evasion as a fraction of u_max.",
        json_schema_extra={"unit": "fraction"},
    )
    circle_margin: Length = Field(
        0.3,
        description="Margin added to the evasion circle radius.",
        json_schema_extra={"unit": "m"},
    )
