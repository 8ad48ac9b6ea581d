"""Parameters of the failure-aware policy (Algorithm 1): the adaptive weights' two extremes
and the cool-down set (eq. 10), the risk levels of the chance constraints (eqs. 7c, 7d), circular
evasion and the gates of the circle fit (Alg. 3)."""

from __future__ import annotations

import numpy as np
from pydantic import Field

from resilient_tracking.spec import (
    MAX_ACCEL,
    MAX_DURATION,
    MAX_POSITION_STD,
    MAX_RATIO,
    MAX_SPEED,
    MAX_STEP_COUNT,
    MAX_UPDATE_ITERATIONS,
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


class CircleFitParams(Strict):
    """Gates of EstimateCircleParameters (Alg. 3): when an observed path counts as a circle."""

    window: int = Field(
        40,
        ge=5,
        le=10_000,
        description="Last observed positions of a silent robot used in the fit.",
        json_schema_extra={"unit": "steps"},
    )
    min_samples: int = Field(
        20,
        ge=5,
        le=10_000,
        description="Fewest positions before a fit is accepted.",
        json_schema_extra={"unit": "steps"},
    )
    min_arc: float = Field(
        2.5,
        gt=0,
        le=6.2832,
        description="Smallest arc of the circle the positions must cover.",
        json_schema_extra={"unit": "rad"},
    )
    max_residual: PositiveLength = Field(
        0.08,
        description="Largest RMS radial residual of an accepted fit.",
        json_schema_extra={"unit": "m"},
    )
    min_radius: PositiveLength = Field(
        0.2, description="Smallest plausible circle radius.", json_schema_extra={"unit": "m"}
    )
    max_radius: PositiveLength = Field(
        5.0, description="Largest plausible circle radius.", json_schema_extra={"unit": "m"}
    )
    silent_steps: int = Field(
        8,
        ge=1,
        le=MAX_STEP_COUNT,
        description="Steps without any working link before a teammate is watched.",
        json_schema_extra={"unit": "steps"},
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


class DegradationWatchParams(Strict):
    """Finding a robot's silently degraded sensor from its own measurements and adapting to it
    (the ``degradation_watch`` of the failure-aware policy, docs/model.md §6.4)."""

    enabled: bool = Field(
        False,
        description=(
            "Beyond the paper: check each robot's measurements against its league's predicted"
            " estimate (NIS, CUSUM); a robot found degraded has its noise re-estimated and used"
            " by the filter, counts as partly attacked in the adaptive weights (1 − 1/λ̂ of a"
            " robot) and learns a sensing zone where it was found, shared with its league."
            " false, the default: the paper's team."
        ),
    )
    design_factor: float = Field(
        2.0,
        gt=1,
        le=MAX_RATIO,
        description=(
            "Noise standard-deviation factor the CUSUM is tuned to: the alternative hypothesis"
            " of its log-likelihood ratio (the noise variance times its square)."
        ),
        json_schema_extra={"unit": "ratio"},
    )
    threshold: float = Field(
        20.0,
        gt=0,
        le=MAX_RATIO,
        description=(
            "CUSUM threshold, a log-likelihood ratio: larger means fewer false alarms and later"
            " detections."
        ),
    )
    warmup: int = Field(
        30,
        ge=0,
        le=MAX_STEP_COUNT,
        description=(
            "Steps from the first tick before the CUSUM starts: the filter first settles from"
            " its wide initial prior."
        ),
        json_schema_extra={"unit": "steps"},
    )
    nis_cap: float = Field(
        20.0,
        gt=0,
        le=MAX_RATIO,
        description=(
            "Cap on one measurement's normalised innovation squared in the CUSUM, so one outlier"
            " adds a bounded amount."
        ),
    )
    memory: float = Field(
        30.0,
        ge=1,
        le=MAX_STEP_COUNT,
        description="Steps over which a degraded sensor's noise estimate forgets (exponentially).",
        json_schema_extra={"unit": "steps"},
    )
    max_factor: float = Field(
        20.0,
        ge=1,
        le=MAX_RATIO,
        description="Largest noise standard-deviation factor estimated.",
        json_schema_extra={"unit": "ratio"},
    )
    zone_radius: PositiveLength = Field(
        0.5,
        description="Radius of the sensing zone learned where a degradation is found.",
        json_schema_extra={"unit": "m"},
    )
    zone_std: float = Field(
        0.5,
        gt=0,
        le=MAX_POSITION_STD,
        description="Spread of the centre of the zone learned where a degradation is found.",
        json_schema_extra={"unit": "m"},
    )
    update_iterations: int = Field(
        5,
        ge=1,
        le=MAX_UPDATE_ITERATIONS,
        description=(
            "Linearisations per measurement update of a league with a robot found degraded (the"
            " iterated EKF: each at the last one's result); 1: the estimator's own update."
        ),
        json_schema_extra={"unit": "count"},
    )
    second_order: bool = Field(
        True,
        description=(
            "Whether that update's noise carries each channel's second-order term, so a large"
            " noise next to a target does not make the update overconfident."
        ),
    )


class ZoneMotionParams(Strict):
    """Zone estimates that age and move (the ``zone_motion`` of the failure-aware policy,
    docs/model.md §6.3): a nearly-constant-velocity Kalman filter per identified zone, fed with
    the means of successive clues."""

    enabled: bool = Field(
        False,
        description=(
            "Beyond the paper: each identified zone's clues feed a filter of its mean and"
            " velocity; the team plans against the zone predicted at plan time, its spread"
            " grown by the filter's position uncertainty. false, the default: zone estimates"
            " stay where they were learned (the paper's team)."
        ),
    )
    accel_std: float = Field(
        0.02,
        ge=0,
        le=MAX_ACCEL,
        description=(
            "Process noise: white-noise acceleration of the nearly-constant-velocity model"
            " (spectral density accel_std²)."
        ),
        json_schema_extra={"unit": "m/s²"},
    )
    speed_std: float = Field(
        0.02,
        ge=0,
        le=MAX_SPEED,
        description=(
            "Prior standard deviation of a zone's velocity (each axis) before its second clue:"
            " how fast the knowledge of a zone seen once grows uncertain."
        ),
        json_schema_extra={"unit": "m/s"},
    )
    mean_std: float = Field(
        0.05,
        gt=0,
        le=MAX_POSITION_STD,
        description=(
            "Measurement noise of a clue's mean (a clue gives the zone's prior mean as it is at"
            " the attack; its covariance is the zone's own spread, kept apart)."
        ),
        json_schema_extra={"unit": "m"},
    )
    max_std: float = Field(
        1.0,
        ge=0,
        le=MAX_POSITION_STD,
        description=(
            "Cap on the standard deviation (largest axis) the filter adds to a zone's spread;"
            " 0: no cap."
        ),
        json_schema_extra={"unit": "m"},
    )
    refresh: Length = Field(
        0.1,
        description=(
            "Distance the predicted zone (its mean, or its largest standard deviation) moves"
            " before the team replans around the new prediction; keeps zone rows and route"
            " maps from being rebuilt every step. 0: every step."
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
    circle_fit: CircleFitParams = Field(
        CircleFitParams(),
        description="When a silent robot's observed path counts as a circle (Alg. 3).",
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
    inferred_delta2: float = Field(
        0.3,
        gt=0,
        le=MAX_RATIO,
        description=(
            "Jammer strength assumed for a comm zone inferred from a circle (its δ2 is not seen)."
        ),
        json_schema_extra={"unit": "ratio"},
    )
    silence_std: float = Field(
        0.3,
        ge=0,
        le=MAX_POSITION_STD,
        description=(
            "Spread of the provisional comm zone put where a teammate fell silent, until a circle"
            " fit replaces it; 0 turns it off."
        ),
        json_schema_extra={"unit": "m"},
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
    zone_motion: ZoneMotionParams = Field(
        ZoneMotionParams(),
        description=(
            "Beyond the paper: zone estimates that move with a velocity estimated from"
            " successive clues and grow uncertain with time since the last one"
            " (docs/model.md §6.3); off by default."
        ),
    )
    degradation_watch: DegradationWatchParams = Field(
        DegradationWatchParams(),
        description=(
            "Beyond the paper: find silently degraded sensors and adapt to them (enabled: false,"
            " the default, is the paper's team; docs/model.md §6.4)."
        ),
    )
