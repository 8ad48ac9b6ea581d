"""Parameters of the failure-aware policy (Algorithm 1): the adaptive weights' two extremes
and the cool-down set (eq. 10), the risk levels of the chance constraints (eqs. 7c, 7d), circular
evasion and the gates of the circle fit (Alg. 3)."""

from __future__ import annotations

import numpy as np
from pydantic import Field

from resilient_tracking.spec import (
    MAX_DURATION,
    MAX_SPEED,
    MAX_STEP_COUNT,
    Length,
    PositiveLength,
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


class LureGuardParams(Strict):
    """When a target is suspected of luring robots into danger, and how far robots then keep
    from it (the ``lure_guard`` of the failure-aware policy, docs/model.md §6.1)."""

    window: int = Field(
        40,
        ge=1,
        le=MAX_STEP_COUNT,
        description=(
            "Steps over which a target's speed is measured: the distance between the mean"
            " estimated positions of the window's two halves, over the time between them (the"
            " velocity estimate alone is too noisy)."
        ),
        json_schema_extra={"unit": "steps"},
    )
    linger_speed: float = Field(
        0.08,
        gt=0,
        le=MAX_SPEED,
        description="A target whose speed over the window is below this lingers.",
        json_schema_extra={"unit": "m/s"},
    )
    moving_speed: float = Field(
        0.1,
        gt=0,
        le=MAX_SPEED,
        description=(
            "A target counts as having moved once its speed over the window exceeded this;"
            " only a target that moved can linger."
        ),
        json_schema_extra={"unit": "m/s"},
    )
    position_std: PositiveLength = Field(
        0.15,
        description=(
            "Largest standard deviation (largest axis) of a target's position estimate at which"
            " its speed over the window is trusted."
        ),
        json_schema_extra={"unit": "m"},
    )
    linger_steps: int = Field(
        5,
        ge=1,
        le=MAX_STEP_COUNT,
        description="Consecutive lingering steps after which a target is suspect.",
        json_schema_extra={"unit": "steps"},
    )
    surge: float = Field(
        0.07,
        gt=0,
        le=MAX_SPEED,
        description=(
            "A steady target whose speed over the window exceeds its usual speed by more than"
            " this for surge_steps ticks is suspect until it is back at its usual speed (within"
            " half of this for calm_steps ticks): a lure leaving its route."
        ),
        json_schema_extra={"unit": "m/s"},
    )
    surge_steps: int = Field(
        10,
        ge=1,
        le=MAX_STEP_COUNT,
        description="Consecutive ticks above the usual speed before a target surges.",
        json_schema_extra={"unit": "steps"},
    )
    calm_steps: int = Field(
        30,
        ge=1,
        le=MAX_STEP_COUNT,
        description="Consecutive ticks back at its usual speed before a target's surge ends.",
        json_schema_extra={"unit": "steps"},
    )
    usual_memory: float = Field(
        3.0,
        gt=0,
        le=MAX_DURATION,
        description=(
            "Time constant of the running means of a target's usual speed, usual velocity and"
            " unsteadiness; also how long a target is watched before it can surge."
        ),
        json_schema_extra={"unit": "s"},
    )
    steady: float = Field(
        0.1,
        gt=0,
        le=MAX_SPEED,
        description=(
            "Largest unsteadiness (running mean of how far its velocity lies from its usual"
            " velocity) of a target that can surge: one fleeing robots is not steady."
        ),
        json_schema_extra={"unit": "m/s"},
    )
    zone_margin: Length = Field(
        0.3,
        description=(
            "A target whose estimated position lies within this of the safe radius r_safe of a"
            " known zone's eq. 7c row (or inside it) is suspect."
        ),
        json_schema_extra={"unit": "m"},
    )
    standoff: PositiveLength = Field(
        1.5,
        description=(
            "Radius of the keep-out disc around a suspect target's predicted position (an eq. 7c"
            " row at risk level ε1 with the target's position covariance)."
        ),
        json_schema_extra={"unit": "m"},
    )


class QuarantineParams(Strict):
    """How long and how far robots keep out of radio range of a teammate known to carry a
    compromise (the ``quarantine`` of the failure-aware policy, docs/model.md §6.2)."""

    steps: int = Field(
        0,
        ge=0,
        le=MAX_STEP_COUNT,
        description=(
            "Steps a quarantine lasts from when the compromise became known; 0, the default:"
            " the rest of the episode (a permanent compromise never heals)."
        ),
        json_schema_extra={"unit": "steps"},
    )
    margin: Length = Field(
        0.3,
        description=(
            "Added to the team's radio range: the keep-out disc around a quarantined robot has"
            " radius comm_range + margin."
        ),
        json_schema_extra={"unit": "m"},
    )
    position_std: PositiveLength = Field(
        0.05,
        description=(
            "Standard deviation given to a quarantined robot's observed position in its eq. 7c"
            " row (it moves between ticks)."
        ),
        json_schema_extra={"unit": "m"},
    )


class FailureAwareParams(Strict):
    """Algorithm 1 with adaptive weights, cool-down, circular evasion and circle inference."""

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
    signal_turns: float | None = Field(
        None,
        gt=0,
        le=100,
        description=(
            "Beyond the paper: turns a robot whose radio a permanent comm zone destroyed circles"
            " its attacker (the signal teammates read, Alg. 3) before it tracks alone again with"
            " its sensor, keeping clear of the zones it knows; null, the default: it circles for"
            " the rest of the episode, as the paper's Alg. 4 (docs/model.md §6.5)."
        ),
        json_schema_extra={"unit": "turns"},
    )
    guard_temporary_jammers: bool = Field(
        True,
        description=(
            "Keep league links clear (eq. 7d) of comm zones the league knows to be temporary, as"
            " the paper does; false: such a zone costs only a short outage, so leagues plan as"
            " if it were not there (docs/generalization.md measures both)."
        ),
    )
    hazard_guard: bool = Field(
        True,
        description=(
            "Beyond the paper: league robots keep clear of the hazard of every comm zone they"
            " know and do not know to be temporary (an eq. 7c disc of radius comm_clearance +"
            " w5, besides eq. 7d, at risk level ε1); the risk level of the sensing-zone"
            " constraints shrinks with the share of robots still sensing (ε1·s/M); with"
            " exposure_horizon, each zone's risk level shrinks with the team's exposure to it; a"
            " robot circling its attacker (Alg. 4) turns back at a known sensing zone's keep-out"
            " disc. false: the paper's constraint set (docs/paper-map.md)."
        ),
    )
    exposure_horizon: int = Field(
        0,
        ge=0,
        le=1_000_000,
        description=(
            "With hazard_guard: robot-steps near a known zone's keep-out disc after which the risk"
            " level of its constraint halves, and halves again each time that exposure doubles"
            " (risk accumulated over time); 0, the default, turns it off (docs/calibration.md §7"
            " measures both)."
        ),
        json_schema_extra={"unit": "steps"},
    )
    lure_guard: bool = Field(
        False,
        description=(
            "Beyond the paper: suspect targets of luring robots into danger (from the league's"
            " estimate only): while a target that kept a steady course speeds up beyond its"
            " usual speed, and for the rest of the episode once one lingers after moving or"
            " stands at a known zone's keep-out disc; the league keeps lure.standoff from each"
            " suspect target. false, the default: the paper's team (docs/model.md §6.1)."
        ),
    )
    lure: LureGuardParams = Field(
        LureGuardParams(), description="When a target is suspect and how far robots keep from it."
    )
    quarantine: bool = Field(
        False,
        description=(
            "Beyond the paper: a robot that announces its radio compromised by a permanent comm"
            " zone is quarantined by the teammates that heard it (linked to it at the tick"
            " before), who share it in their league; the league keeps"
            " quarantine_keep_out.margin beyond the radio range from it (an eq. 7c row), so a"
            " spreading compromise cannot reach them. false, the default: the paper's team"
            " (docs/model.md §6.2)."
        ),
    )
    quarantine_keep_out: QuarantineParams = Field(
        QuarantineParams(),
        description="How long a quarantine lasts and how far robots keep from a quarantined robot.",
    )
