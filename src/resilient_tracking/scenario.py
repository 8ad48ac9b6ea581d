"""Scenario files: schema, loading and validation with errors that name the field.

A scenario is a YAML mapping validated by the pydantic models below. ``load_scenario`` returns a
:class:`Scenario` or raises :class:`ScenarioError` listing every problem as
``field.path: message (got value)``. The format is documented in ``docs/scenario-format.md``.
"""

from __future__ import annotations

import importlib
import math
import reprlib
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import (
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    SerializeAsAny,
    ValidationError,
    ValidationInfo,
    field_validator,
)
from pydantic import Strict as StrictMode

#: Largest magnitude (m, m/s) of a coordinate; beyond it, products of positions overflow.
MAX_COORDINATE = 1e6
#: Largest magnitude (m²) of a covariance entry, and the smallest eigenvalue ratio λmin/λmax: a
#: flatter Σ is numerically singular for the chance constraints and the Mahalanobis tests.
MAX_VARIANCE = 1e12
MIN_COVARIANCE_RATIO = 1e-9
#: Smallest eigenvalue (m²) of a covariance: below it the Gaussian density's normaliser
#: 1/(2π√det Σ) overflows (det Σ underflows to 0 near 1e-300), so the hazard and the risk maps
#: would be NaN. 1e-6 m² is a 1 mm standard deviation, far below any sensor's.
MIN_VARIANCE = 1e-6
#: Upper bounds on sizes: the league NLP grows with robots × targets × zones, so a team beyond
#: these is refused up front rather than left to exhaust memory while the problem is built.
MAX_ROBOTS = 64
MAX_TARGETS = 64
MAX_ROBOTS_X_TARGETS = 1024
MAX_ZONES = 32
MAX_STEPS = 100_000
MAX_DT = 10.0
#: at least 1 ms: ``dt`` divides in the velocity bounds and the route pull, and a subnormal one
#: overflows them
MIN_DT = 1e-3
#: Recorded rows (``steps × (robots + targets)``) an episode may hold in memory.
MAX_RECORDED_ROWS = 5_000_000

#: A number inside a list: strict (an int or a float, never a bool or a string) even where the
#: list itself is lax (``StrictMode(False)`` lets a YAML list stand for a tuple).
Number = Annotated[float, StrictMode()]
#: A coordinate or velocity component: a strict number of bounded size.
Coordinate = Annotated[float, StrictMode(), Field(ge=-MAX_COORDINATE, le=MAX_COORDINATE)]
Vec2 = Annotated[tuple[Coordinate, Coordinate], StrictMode(False)]
Row2 = Annotated[tuple[Number, Number], StrictMode(False)]
Matrix2 = Annotated[tuple[Row2, Row2], StrictMode(False)]
PositiveFloat = Annotated[float, Field(gt=0)]


class Strict(BaseModel):
    """Base: unknown keys are errors, NaN and infinity are rejected, and values are strict.

    Strict mode means a number field takes an int or a float but never a bool (YAML ``yes``) or a
    string (``"0.1"``), a bool field takes only ``true``/``false``, an int field only an integer.
    """

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, frozen=True, strict=True)


# ---------------------------------------------------------------------------- geometry


class Workspace(Strict):
    """Axis-aligned box the robots stay in (metres)."""

    xmin: float = Field(-5.0, description="Left edge of the box.", json_schema_extra={"unit": "m"})
    xmax: float = Field(
        5.0, description="Right edge; must exceed xmin.", json_schema_extra={"unit": "m"}
    )
    ymin: float = Field(
        -5.0, description="Bottom edge of the box.", json_schema_extra={"unit": "m"}
    )
    ymax: float = Field(
        5.0, description="Top edge; must exceed ymin.", json_schema_extra={"unit": "m"}
    )

    def contains(self, p: Vec2) -> bool:
        """Whether point ``p`` (m) lies in the box, edges included."""
        return self.xmin <= p[0] <= self.xmax and self.ymin <= p[1] <= self.ymax

    @property
    def lower(self) -> np.ndarray:
        """The lower corner ``[xmin, ymin]`` (m)."""
        return np.array([self.xmin, self.ymin])

    @property
    def upper(self) -> np.ndarray:
        """The upper corner ``[xmax, ymax]`` (m)."""
        return np.array([self.xmax, self.ymax])


# ---------------------------------------------------------------------------- robots, targets


class RobotSpec(Strict):
    """One robot: its start position and velocity bound (paper eq. 3)."""

    start: Vec2 = Field(
        ..., description="Initial position, inside the workspace.", json_schema_extra={"unit": "m"}
    )
    u_max: PositiveFloat = Field(
        1.0,
        description="Bound on each velocity component: |u_x|, |u_y| ≤ u_max.",
        json_schema_extra={"unit": "m/s"},
    )


class MotionSpec(Strict):
    """Base of a target motion's parameters; ``type`` selects the motion by its registered name
    (:mod:`resilient_tracking.world.target_motion`)."""

    type: str = Field(description="Selects the motion: a registered name or package.module:Class.")


class ConstantVelocity(MotionSpec):
    """Straight line at a constant velocity."""

    type: Literal["constant_velocity"] = Field(description="Selects this motion.")
    velocity: Vec2 = Field(
        ..., description="Constant velocity [v_x, v_y].", json_schema_extra={"unit": "m/s"}
    )


class Waypoints(MotionSpec):
    """Straight segments through points at a constant speed."""

    type: Literal["waypoints"] = Field(description="Selects this motion.")
    points: list[Vec2] = Field(
        min_length=1,
        description="Visited in order along straight segments, starting from start.",
        json_schema_extra={"unit": "m"},
    )
    speed: PositiveFloat = Field(
        ..., description="Constant speed along the path.", json_schema_extra={"unit": "m/s"}
    )
    loop: bool = Field(
        False,
        description=(
            "After the last point, head back to the first and repeat; otherwise stop at the last "
            "point."
        ),
    )


class Circle(MotionSpec):
    """Circle around ``center`` through the start point; positive ``angular_speed`` is CCW."""

    type: Literal["circle"] = Field(description="Selects this motion.")
    center: Vec2 = Field(
        ...,
        description=(
            "Center of the circle; the radius is the distance from start, which must not be 0."
        ),
        json_schema_extra={"unit": "m"},
    )
    angular_speed: float = Field(
        ...,
        description="Positive: counter-clockwise, negative: clockwise, 0: still.",
        json_schema_extra={"unit": "rad/s"},
    )


class NoisyConstantVelocity(MotionSpec):
    """Nearly-constant-velocity truth: white acceleration noise of ``accel_std`` per axis."""

    type: Literal["ncv"] = Field(description="Selects this motion.")
    velocity: Vec2 = Field(
        (0.0, 0.0), description="Initial velocity.", json_schema_extra={"unit": "m/s"}
    )
    accel_std: float = Field(
        0.1,
        ge=0,
        description=(
            "Standard deviation of the white acceleration noise per axis; 0 gives constant "
            "velocity."
        ),
        json_schema_extra={"unit": "m/s²"},
    )


def _plugin_spec(registry: str, tag: str) -> Any:
    """A before-validator: the ``Spec`` of the class the mapping's ``tag`` names in the registry
    ``registry`` (``module:ATTRIBUTE``, imported on first use), validated with it, so errors
    name the fields of that ``Spec``."""

    def validate(value: Any) -> Any:
        if isinstance(value, BaseModel):
            return value
        if not isinstance(value, dict) or not isinstance(value.get(tag), str):
            raise ValueError(f"must be a mapping with a {tag!r} naming the model")
        from resilient_tracking.registry import UnknownName

        module, _, attr = registry.partition(":")
        try:
            cls = getattr(importlib.import_module(module), attr).get(value[tag])
        except UnknownName as err:
            raise ValueError(str(err)) from None
        return cls.Spec.model_validate(value)

    return BeforeValidator(validate)


#: A target's motion: the ``Spec`` of the motion its ``type`` names.
TargetMotion = Annotated[
    SerializeAsAny[MotionSpec],
    _plugin_spec("resilient_tracking.world.target_motion:MOTIONS", "type"),
]


class TargetSpec(Strict):
    """One target: its true start position and scripted motion."""

    start: Vec2 = Field(
        ...,
        description="Initial true position, inside the workspace.",
        json_schema_extra={"unit": "m"},
    )
    motion: TargetMotion = Field(..., description="Scripted true motion, selected by its type.")


# ---------------------------------------------------------------------------- sensing, estimation


class SensorChannel(Strict):
    """One channel: inverse variance ``peak · exp(−shape · d)``."""

    peak: PositiveFloat = Field(
        15.0,
        description="Inverse variance at distance 0 (m⁻² for range, rad⁻² for bearing).",
        json_schema_extra={"unit": "1/variance"},
    )
    shape: float = Field(
        0.2,
        ge=0,
        description="Decay rate of the information with distance; 0: independent of distance.",
        json_schema_extra={"unit": "1/m"},
    )


class SensorSpec(Strict):
    """The robots' range-bearing sensor (paper eq. 2): noise per channel and an optional maximum
    range."""

    range: SensorChannel = Field(SensorChannel(), description="Noise of the range measurement.")
    bearing: SensorChannel = Field(SensorChannel(), description="Noise of the bearing measurement.")
    max_range: PositiveFloat | None = Field(
        None,
        description="Targets farther than this are not measured; null: no limit.",
        json_schema_extra={"unit": "m"},
    )


class EstimatorSpec(Strict):
    """The robots' target model (nearly constant velocity) and initial uncertainty."""

    accel_std: float = Field(
        0.2,
        gt=0,
        description="White-acceleration noise of the EKF's process model, per axis.",
        json_schema_extra={"unit": "m/s²"},
    )
    initial_position_std: PositiveFloat = Field(
        0.5,
        description=(
            "Initial position uncertainty per axis (the initial estimate is drawn with it)."
        ),
        json_schema_extra={"unit": "m"},
    )
    initial_velocity_std: PositiveFloat = Field(
        0.3, description="Initial velocity uncertainty per axis.", json_schema_extra={"unit": "m/s"}
    )


# ---------------------------------------------------------------------------- danger zones


class HazardSpec(Strict):
    """Base of a hazard model's parameters; ``model`` selects the model by its registered name
    (:mod:`resilient_tracking.world.hazard_model`)."""

    model: str = Field(
        description="Selects the hazard model: a registered name or package.module:Class."
    )


class GaussianHazard(HazardSpec):
    """``P(attack) = 1 − exp(−κ f_act dt pdf_N(μ,Σ)(x))`` per step (docs/model.md §2)."""

    model: Literal["gaussian"] = Field(description="Selects this hazard model.")
    f_act: PositiveFloat = Field(
        1.0, description="Activation frequency of the zone.", json_schema_extra={"unit": "Hz"}
    )
    kappa: PositiveFloat = Field(
        1.0,
        description="Intensity κ, multiplying a density in m⁻².",
        json_schema_extra={"unit": "m²"},
    )


class DiskHazard(HazardSpec):
    """Hit with probability ``p_hit`` at each activation tick while inside the true disk."""

    model: Literal["disk"] = Field(description="Selects this hazard model.")
    f_act: PositiveFloat = Field(
        1.0, description="Activation frequency of the zone.", json_schema_extra={"unit": "Hz"}
    )
    p_hit: float = Field(
        0.5,
        ge=0,
        le=1,
        description="Hit probability per activation tick while inside the true disk.",
    )


#: A zone's hazard: the ``Spec`` of the hazard model its ``model`` names.
Hazard = Annotated[
    SerializeAsAny[HazardSpec],
    _plugin_spec("resilient_tracking.world.hazard_model:HAZARDS", "model"),
]


def _check_covariance(value: Matrix2) -> Matrix2:
    m = np.asarray(value, dtype=float)
    if np.abs(m).max() > MAX_VARIANCE:
        raise ValueError(f"entries must not exceed {MAX_VARIANCE:g} in magnitude")
    if not np.allclose(m, m.T, rtol=0, atol=1e-12):
        raise ValueError("must be symmetric")
    eig = np.linalg.eigvalsh(m)
    if eig.min() <= 0:
        raise ValueError("must be positive definite")
    if eig.min() < MIN_VARIANCE:
        raise ValueError(
            f"is too small: its smallest eigenvalue {eig.min():.3g} m² is below {MIN_VARIANCE:g} "
            "m², where the Gaussian density of the zone center is no longer a finite number"
        )
    if eig.min() < MIN_COVARIANCE_RATIO * eig.max():
        raise ValueError(
            f"is too close to singular (eigenvalue ratio {eig.min() / eig.max():.3g} is below "
            f"{MIN_COVARIANCE_RATIO:g})"
        )
    sym = m / 2 + m.T / 2
    return ((sym[0, 0], sym[0, 1]), (sym[1, 0], sym[1, 1]))


class ZoneBase(Strict):
    """Fields every danger zone has: the prior ``N(μ, Σ)`` its true center is drawn from each
    episode (paper eq. 4), how attacks are drawn, what they do and where a temporary failure
    ends."""

    name: str | None = Field(None, description="Label for plots and logs.")
    mu: Vec2 = Field(
        ..., description="Prior mean μ of the zone center.", json_schema_extra={"unit": "m"}
    )
    sigma: Matrix2 = Field(
        ...,
        description=(
            "Prior covariance Σ of the zone center: symmetric, positive definite, not nearly "
            "singular."
        ),
        json_schema_extra={"unit": "m²"},
    )
    persistence: Literal["temporary", "permanent"] = Field(
        "temporary",
        description=(
            "What a hazard attack from this zone does: a temporary failure ends once the robot "
            "leaves the influence region; a permanent one never ends."
        ),
    )
    hazard: Hazard = Field(
        GaussianHazard(model="gaussian"),
        description="How attacks are drawn, selected by its model.",
    )
    m_recover: PositiveFloat = Field(
        2.0,
        description=(
            "Size of the influence region (x − μ)ᵀ Σ⁻¹ (x − μ) ≤ m_recover², out of which a "
            "temporary failure ends."
        ),
        json_schema_extra={"unit": "Mahalanobis"},
    )

    _sigma_ok = field_validator("sigma")(_check_covariance)


class SensingZone(ZoneBase):
    """A sensing danger zone (paper eq. 4): a disk of radius ``r`` around its true center; an attack
    disables the robot's sensor."""

    kind: Literal["sensing"] = Field(description="An attack disables the robot's sensor.")
    radius: PositiveFloat = Field(
        ...,
        description="Radius r of the zone's disk around its true center.",
        json_schema_extra={"unit": "m"},
    )


class CommZone(ZoneBase):
    """A comm danger zone (paper eq. 5): an attack disables the robot's radio, and its jammer cuts a
    link when a robot is within ``δ2`` times the link length of the true center."""

    kind: Literal["comm"] = Field(
        description="An attack disables the robot's radio; the zone also jams links."
    )
    delta2: PositiveFloat = Field(
        ...,
        description=(
            "Jammer strength δ2: a link is cut when a robot is within δ2 times the link length of"
            " the true center."
        ),
        json_schema_extra={"unit": "ratio"},
    )


Zone = Annotated[SensingZone | CommZone, Field(discriminator="kind")]


# ---------------------------------------------------------------------------- policies


class VanillaParams(Strict):
    """Fixed weights (docs/model.md §7.1): tracking trace and control effort."""

    w_track: PositiveFloat = Field(
        50.0, description="Weight w1 on the predicted tracking uncertainty Σ_j tr P⁺_j."
    )
    w_effort: PositiveFloat = Field(0.05, description="Weight w2 on the control effort Σ_i ‖u_i‖².")


class WeightSet(Strict):
    """One extreme of the adaptive weights (paper eq. 10): ``w1..w4`` and the clearance ``w5``."""

    track: float = Field(ge=0, description="w1: weight on the tracking term Σ_j tr P⁺_j.")
    effort: PositiveFloat = Field(..., description="w2: weight on the control effort Σ_i ‖u_i‖².")
    sensing_slack: float = Field(
        ge=0, description="w3: penalty on the slacks of the sensing-zone chance constraints."
    )
    comm_slack: float = Field(
        ge=0, description="w4: penalty on the slacks of the comm-zone chance constraints."
    )
    clearance: float = Field(
        0.0,
        ge=0,
        description="w5: clearance added to a sensing zone radius, r_safe = r + w5.",
        json_schema_extra={"unit": "m"},
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
    max_residual: float = Field(
        0.08,
        gt=0,
        description="Largest RMS radial residual of an accepted fit.",
        json_schema_extra={"unit": "m"},
    )
    min_radius: PositiveFloat = Field(
        0.2, description="Smallest plausible circle radius.", json_schema_extra={"unit": "m"}
    )
    max_radius: PositiveFloat = Field(
        5.0, description="Largest plausible circle radius.", json_schema_extra={"unit": "m"}
    )
    silent_steps: int = Field(
        8,
        ge=1,
        description="Steps without any working link before a teammate is watched.",
        json_schema_extra={"unit": "steps"},
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
    comm_clearance: float = Field(
        0.5,
        ge=0,
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
    circle_margin: float = Field(
        0.3,
        ge=0,
        description="Margin added to the evasion circle radius.",
        json_schema_extra={"unit": "m"},
    )
    circle_fit: CircleFitParams = Field(
        CircleFitParams(),
        description="When a silent robot's observed path counts as a circle (Alg. 3).",
    )
    inferred_delta2: PositiveFloat = Field(
        0.3,
        description=(
            "Jammer strength assumed for a comm zone inferred from a circle (its δ2 is not seen)."
        ),
        json_schema_extra={"unit": "ratio"},
    )
    silence_std: float = Field(
        0.3,
        ge=0,
        description=(
            "Spread of the provisional comm zone put where a teammate fell silent, until a circle"
            " fit replaces it; 0 turns it off."
        ),
        json_schema_extra={"unit": "m"},
    )


class SogSlackWeights(Strict):
    """Penalties on the SOG program's slacks at one extreme of the sensor abundance."""

    track: PositiveFloat = Field(
        ...,
        description="Penalty on δ1j, the excess of tr P⁺_j over ρ1.",
        json_schema_extra={"unit": "1/m²"},
    )
    risk: PositiveFloat = Field(
        ..., description="Penalty on δ2i, the excess of the failure likelihood φ_i over ρ2."
    )


class SogParams(Strict):
    """Risk-aware SOG baseline after Mayya et al. (RA-L 2022), rebuilt from its published
    description (docs/model.md §7); see ``policies/sog.py``."""

    rho1: PositiveFloat = Field(
        0.01,
        description="Tracking requirement tr P⁺_j ≤ ρ1 per target (position block).",
        json_schema_extra={"unit": "m²"},
    )
    rho2: float = Field(
        0.3,
        gt=0,
        lt=1,
        description="Acceptable risk φ_i ≤ ρ2: risky 0.6, regular 0.3, conservative 0.2.",
    )
    effort: PositiveFloat = Field(0.05, description="Weight on the control effort Σ_i ‖u_i‖².")
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
    hazard_rate: PositiveFloat = Field(
        1.0,
        description=(
            "Attack rate κ f_act the team assumes for a known zone (clues do not carry it)."
        ),
        json_schema_extra={"unit": "1/s"},
    )
    risk_window: PositiveFloat = Field(
        10.0,
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


class PolicySpec(Strict):
    """The team's policy by name, and the parameters of every policy the file configures.

    A built-in policy reads its parameters from its own section (``vanilla``, ``failure_aware``,
    ``sog``); any other policy, registered by an installed package or named by its class as
    ``package.module:Class``, reads them from ``params``, validated by the policy's own
    ``Params`` model.
    """

    name: str = Field(
        "failure_aware",
        description=(
            "Policy the team uses: failure_aware, vanilla, sog, a name an installed package "
            "registers, or a class as package.module:Class (rtrack run --policy overrides it)."
        ),
    )
    params: dict[str, Any] = Field(
        default_factory=dict,
        description=(
            "Parameters of the policy named by name when it is not a built-in, checked by its "
            "Params model (docs/own-policy.md)."
        ),
    )
    vanilla: VanillaParams = Field(
        VanillaParams(), description="Parameters of the vanilla baseline."
    )
    failure_aware: FailureAwareParams = Field(
        FailureAwareParams(), description="Parameters of the failure-aware policy (Algorithm 1)."
    )
    sog: SogParams = Field(
        SogParams(), description="Parameters of the SOG baseline (reconstruction)."
    )

    @field_validator("name")
    @classmethod
    def _known_policy(cls, name: str) -> str:
        from resilient_tracking.policies.base import POLICIES
        from resilient_tracking.registry import UnknownName

        try:
            POLICIES.get(name)
        except UnknownName as err:
            raise ValueError(str(err)) from None
        return name

    @field_validator("params")
    @classmethod
    def _valid_params(cls, params: dict[str, Any], info: ValidationInfo) -> dict[str, Any]:
        name = info.data.get("name")
        if name is None:  # the name is wrong; that is the error to report
            return params
        if name in POLICY_NAMES:
            if params:
                raise ValueError(
                    f"the built-in policy {name!r} takes its parameters from policy.{name}"
                )
            return params
        from resilient_tracking.policies.base import POLICIES

        POLICIES.get(name).Params.model_validate(params)  # errors name policy.params.<field>
        return params

    def params_for(self, name: str, model: type[BaseModel]) -> BaseModel:
        """The validated parameters of the policy ``name`` whose ``Params`` is ``model``: a
        built-in's section, ``params`` for the named policy, else the model's defaults."""
        if name in POLICY_NAMES:
            section: BaseModel = getattr(self, name)
            return section
        if name == self.name:
            return model.model_validate(self.params)
        return model()


#: The built-in policies, each with its own section under ``policy``.
POLICY_NAMES: tuple[str, ...] = ("vanilla", "failure_aware", "sog")


class RouteSpec(Strict):
    """The route program (docs/calibration.md, "Evade, then come back"): the paper's objective
    plus a cost-to-go along the shortest route around the known keep-out regions to each
    robot's assigned target, with the information model regularised at ``standoff``."""

    speed: float = Field(
        0.8,
        gt=0,
        le=1,
        description=(
            "Speed, as a fraction of the robot's u_max, at which the cost-to-go alone moves a "
            "robot that is far from its goal."
        ),
    )
    reach: float = Field(
        0.7,
        ge=0,
        le=100,
        description="Route length to its goal within which a robot feels no pull.",
        json_schema_extra={"unit": "m"},
    )
    lookahead: float = Field(
        3.0,
        ge=0,
        le=100,
        description="At most this much target motion between a goal and its target's estimate.",
        json_schema_extra={"unit": "s"},
    )
    spread: float = Field(
        0.5,
        ge=0,
        le=100,
        description="Extra route length charged to each further robot assigned to one target.",
        json_schema_extra={"unit": "m"},
    )
    standoff: float = Field(
        0.2,
        gt=0,
        le=10,
        description=(
            "Distance regularisation of the planner's range-bearing information model (the "
            "paper's one-step program uses 0.05)."
        ),
        json_schema_extra={"unit": "m"},
    )


class PlannerSpec(Strict):
    """How league problems are built and solved: the planner program (the paper's one-step
    program or the route program) and the solver (the fast SQP ladder or IPOPT only)."""

    program: Literal["route", "one_step"] = Field(
        "route",
        description=(
            "route: the paper's objective plus a cost-to-go around known zones back to the "
            "targets (docs/calibration.md); one_step: the paper's one-step program (eq. 9)."
        ),
    )
    route: RouteSpec = Field(RouteSpec(), description="Parameters of the route program.")
    solver: Literal["ladder", "ipopt"] = Field(
        "ladder",
        description=(
            "ladder: SQP warm-started from the previous step, then IPOPT warm, IPOPT cold, then "
            "hold position; ipopt: the same without the SQP rung."
        ),
    )


# ---------------------------------------------------------------------------- scenario


class Scenario(Strict):
    """A whole scenario file: team, targets, zones, policy and planner (docs/scenario-format.md).
    """

    name: str = Field("scenario", description="Label used in output folders and plots.")
    description: str = Field("", description="Free text.")
    seed: int = Field(
        0,
        ge=0,
        description="Episode seed; every random draw comes from its own stream derived from it.",
    )
    #: at most 10 s: beyond it one step moves targets out of any sensor's reach
    dt: float = Field(
        0.1, ge=MIN_DT, le=MAX_DT, description="Time step.", json_schema_extra={"unit": "s"}
    )
    steps: int = Field(
        300,
        ge=1,
        le=MAX_STEPS,
        description="Episode length (duration steps · dt).",
        json_schema_extra={"unit": "steps"},
    )
    workspace: Workspace = Field(Workspace(), description="Box the robots stay in.")
    sensor: SensorSpec = Field(SensorSpec(), description="Range/bearing sensor of every robot.")
    estimator: EstimatorSpec = Field(
        EstimatorSpec(), description="The robots' target model and initial uncertainty."
    )
    robots: list[RobotSpec] = Field(min_length=1, max_length=MAX_ROBOTS, description="The team.")
    targets: list[TargetSpec] = Field(
        min_length=1, max_length=MAX_TARGETS, description="The targets to track."
    )
    zones: list[Zone] = Field(
        default_factory=list,
        max_length=MAX_ZONES,
        description="Danger zones, initially unknown to the robots, selected by kind.",
    )
    comm_range: PositiveFloat | None = Field(
        None,
        description="Robots link only within this distance; null: unlimited.",
        json_schema_extra={"unit": "m"},
    )
    policy: PolicySpec = Field(
        PolicySpec(), description="The policy the team uses and its parameters."
    )
    planner: PlannerSpec = Field(PlannerSpec(), description="How the league problems are solved.")

    def problems(self) -> list[str]:
        """Cross-field problems pydantic cannot see, each naming its field."""
        out: list[str] = []
        ws = self.workspace
        if ws.xmin >= ws.xmax:
            out.append(f"workspace.xmax: must exceed xmin={ws.xmin} (got {ws.xmax})")
        if ws.ymin >= ws.ymax:
            out.append(f"workspace.ymax: must exceed ymin={ws.ymin} (got {ws.ymax})")
        n, m = len(self.robots), len(self.targets)
        if n * m > MAX_ROBOTS_X_TARGETS:
            out.append(
                f"robots: {n} robots × {m} targets exceeds the supported "
                f"{MAX_ROBOTS_X_TARGETS} robot-target pairs (got {n} × {m} = {n * m})"
            )
        if self.steps * (n + m) > MAX_RECORDED_ROWS:
            out.append(
                f"steps: {self.steps} steps × {n + m} robots and targets would record more than "
                f"{MAX_RECORDED_ROWS} rows; split the run (got {self.steps})"
            )
        for i, robot in enumerate(self.robots):
            if not ws.contains(robot.start):
                out.append(f"robots.{i}.start: outside the workspace (got {list(robot.start)})")
        for j, target in enumerate(self.targets):
            if not ws.contains(target.start):
                out.append(f"targets.{j}.start: outside the workspace (got {list(target.start)})")
            motion = target.motion
            if isinstance(motion, Circle) and math.dist(motion.center, target.start) == 0:
                out.append(
                    f"targets.{j}.motion.center: equals the start, radius would be 0 "
                    f"(got {list(motion.center)})"
                )
        return out

    def with_overrides(self, **changes: Any) -> Scenario:
        """A validated copy with top-level fields replaced (``seed``, ``steps``, ``policy``…)."""
        data = self.model_dump()
        data.update(changes)
        return parse_scenario(data, f"{self.name} (overridden)")


# ---------------------------------------------------------------------------- loading


class ScenarioError(ValueError):
    """A scenario file is invalid; ``problems`` lists each one with its field path."""

    def __init__(self, source: str, problems: list[str]):
        self.source = source
        self.problems = problems
        lines = "\n".join(f"  - {p}" for p in problems)
        super().__init__(f"{source}: {len(problems)} problem(s)\n{lines}")


_REPR = reprlib.Repr()
_REPR.maxlevel, _REPR.maxlist, _REPR.maxdict = 3, 8, 8
_REPR.maxstring, _REPR.maxother, _REPR.maxlong = 60, 60, 40


def _short(value: Any, limit: int = 80) -> str:
    """A bounded ``repr``: never renders more than a few items of a large input."""
    text = _REPR.repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


#: Discriminator key of the tagged union held by a field (a list's items for ``zones``).
_UNION_TAG = {"zones": "kind"}


def _field_path(loc: tuple[int | str, ...], data: Any) -> str:
    """Dotted path of an error in ``data``, without the union tags pydantic inserts in ``loc``.

    pydantic reports ``zones.0.sensing.sigma`` for a bad ``sigma`` of a sensing zone; the user's
    file has no key ``sensing``, so the tag is dropped: ``zones.0.sigma``.
    """
    parts: list[str] = []
    node, owner = data, None
    for part in loc:
        tag = _UNION_TAG.get(owner) if isinstance(owner, str) and isinstance(node, dict) else None
        if tag is not None and node.get(tag) == part:
            owner = None
            continue
        parts.append(str(part))
        if isinstance(part, str):
            owner = part
        if isinstance(node, dict):
            node = node.get(part)
        elif isinstance(node, list) and isinstance(part, int) and -len(node) <= part < len(node):
            node = node[part]
        else:
            node = None
    return ".".join(parts) or "<root>"


def _format_pydantic(err: ValidationError, data: Any) -> list[str]:
    out = []
    for e in err.errors():
        loc = e["loc"]
        key = loc[-1] if loc else None
        if e["type"] == "extra_forbidden" and not (isinstance(key, str) and key.isidentifier()):
            # a key that cannot be part of a dotted path: name its mapping, then the key
            path, msg = _field_path(loc[:-1], data), f"unknown key {_short(loc[-1], 40)}"
            out.append(f"{path}: {msg} (got {_short(e.get('input'))})")
            continue
        path = _field_path(loc, data)
        msg = e["msg"].removeprefix("Value error, ")
        out.append(f"{path}: {msg} (got {_short(e.get('input'))})")
    return out


def parse_scenario(data: Any, source: str = "<scenario>") -> Scenario:
    """Validate a parsed mapping; raise :class:`ScenarioError` naming every bad field."""
    if not isinstance(data, dict):
        raise ScenarioError(source, [f"<root>: must be a mapping (got {type(data).__name__})"])
    try:
        scenario = Scenario.model_validate(data)
    except ValidationError as err:
        raise ScenarioError(source, _format_pydantic(err, data)) from None
    except RecursionError:
        raise ScenarioError(source, ["<root>: nested too deeply to be a scenario"]) from None
    problems = scenario.problems()
    if problems:
        raise ScenarioError(source, problems)
    return scenario


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a YAML scenario file (bounded: :mod:`resilient_tracking.yaml_io`)."""
    from resilient_tracking.yaml_io import YamlInputError, read_yaml

    try:
        data = read_yaml(path)
    except YamlInputError as err:
        raise ScenarioError(str(path), [str(err)]) from None
    return parse_scenario(data, str(path))
