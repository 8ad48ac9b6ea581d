"""The world a scenario describes: the workspace, the robots, the targets and their motions,
and the robots' sensor and estimator."""

from __future__ import annotations

from typing import Annotated, Any, ClassVar, Literal

import numpy as np
from pydantic import (
    Discriminator,
    Field,
    SerializeAsAny,
    Tag,
    model_validator,
)

from resilient_tracking.models.sensor import SensorSpec
from resilient_tracking.scenario.base import Coordinate, Strict, Vec2, plugin_spec
from resilient_tracking.spec import (
    MAX_ACCEL,
    MAX_NOISE_LEVELS,
    MAX_POSITION_STD,
    MAX_RATIO,
    MAX_SPEED,
    MAX_STEP_COUNT,
    MAX_TURN_RATE,
    MAX_UPDATE_ITERATIONS,
    Velocity2,
)

# ---------------------------------------------------------------------------- geometry


class Workspace(Strict):
    """Axis-aligned box the robots stay in (metres)."""

    xmin: Coordinate = Field(
        -5.0, description="Left edge of the box.", json_schema_extra={"unit": "m"}
    )
    xmax: Coordinate = Field(
        5.0, description="Right edge; must exceed xmin.", json_schema_extra={"unit": "m"}
    )
    ymin: Coordinate = Field(
        -5.0, description="Bottom edge of the box.", json_schema_extra={"unit": "m"}
    )
    ymax: Coordinate = Field(
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
    u_max: float = Field(
        1.0,
        gt=0,
        le=MAX_SPEED,
        description="Bound on each velocity component: |u_x|, |u_y| ≤ u_max.",
        json_schema_extra={"unit": "m/s"},
    )


class MotionSpec(Strict):
    """Base of a target motion's parameters; ``type`` selects the motion by its registered name
    (:mod:`resilient_tracking.world.target_motion`)."""

    #: whether the motion it selects reacts to the world (robots, zones): the spec says so, so
    #: that a scenario is checked without the world (a zone's motion must not react)
    reacts: ClassVar[bool] = False

    type: str = Field(description="Selects the motion: a registered name or package.module:Class.")


class ConstantVelocity(MotionSpec):
    """Straight line at a constant velocity."""

    type: Literal["constant_velocity"] = Field(description="Selects this motion.")
    velocity: Velocity2 = Field(
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
    speed: float = Field(
        ...,
        gt=0,
        le=MAX_SPEED,
        description="Constant speed along the path.",
        json_schema_extra={"unit": "m/s"},
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
        ge=-MAX_TURN_RATE,
        le=MAX_TURN_RATE,
        description=(
            "Positive: counter-clockwise, negative: clockwise, 0: still; the speed along the "
            f"circle, angular_speed × radius, must not exceed {MAX_SPEED:g} m/s."
        ),
        json_schema_extra={"unit": "rad/s"},
    )


class NoisyConstantVelocity(MotionSpec):
    """Nearly-constant-velocity truth: white acceleration noise of ``accel_std`` per axis."""

    type: Literal["ncv"] = Field(description="Selects this motion.")
    velocity: Velocity2 = Field(
        (0.0, 0.0), description="Initial velocity.", json_schema_extra={"unit": "m/s"}
    )
    accel_std: float = Field(
        0.1,
        ge=0,
        le=MAX_ACCEL,
        description=(
            "Standard deviation of the white acceleration noise per axis; 0 gives constant "
            "velocity."
        ),
        json_schema_extra={"unit": "m/s²"},
    )


#: A target's motion: the ``Spec`` of the motion its ``type`` names.
TargetMotion = Annotated[
    SerializeAsAny[MotionSpec],
    plugin_spec("resilient_tracking.world.target_motion:MOTIONS", "type"),
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


#: The robots' sensor: the ``Spec`` of the measurement model its ``type`` names; a section
#: without a ``type`` is the paper's range-bearing sensor.
Sensor = Annotated[
    SerializeAsAny[SensorSpec],
    plugin_spec("resilient_tracking.models.sensor:SENSORS", "type", default="range_bearing"),
]


def _acceleration_noise(default: float, description: str) -> Any:
    """A positive white-acceleration noise field of an estimator (m/s² per axis)."""
    return Field(
        default, gt=0, le=MAX_ACCEL, description=description, json_schema_extra={"unit": "m/s²"}
    )


class _EstimatorBase(Strict):
    """What every estimator reads: the target model's quiet process noise, the prior spread."""

    type: str = Field(description="Selects the estimator.")
    accel_std: float = _acceleration_noise(
        0.2, "White-acceleration noise of the EKF's process model, per axis."
    )
    initial_position_std: float = Field(
        0.5,
        gt=0,
        le=MAX_POSITION_STD,
        description=(
            "Initial position uncertainty per axis (the initial estimate is drawn with it)."
        ),
        json_schema_extra={"unit": "m"},
    )
    initial_velocity_std: float = Field(
        0.3,
        gt=0,
        le=MAX_SPEED,
        description="Initial velocity uncertainty per axis.",
        json_schema_extra={"unit": "m/s"},
    )


class EstimatorSpec(_EstimatorBase):
    """The paper's estimator: an EKF with one nearly-constant-velocity target model, and the
    initial uncertainty."""

    # left out of the scenario's dump, as a section without a type is this one: dumps (and the
    # run fingerprints made from them) of scenarios written before the type existed are unchanged
    type: Literal["ekf"] = Field(
        "ekf",
        exclude=True,
        description="Selects this estimator; a section without a type is this one.",
    )


class _MultipleModelBase(_EstimatorBase):
    """What a multiple-model estimator reads besides its models: how its modes are updated."""

    update_iterations: int = Field(
        5,
        ge=1,
        le=MAX_UPDATE_ITERATIONS,
        description=(
            "Linearisations per measurement update of each mode (the iterated EKF); 1: the "
            "paper's EKF update."
        ),
        json_schema_extra={"unit": "count"},
    )
    second_order: bool = Field(
        True,
        description=(
            "Whether the modes' measurement noise carries its second-order term, so a "
            "measurement taken within the estimate's spread (a robot next to the target) counts "
            "for little; false: the paper's EKF update."
        ),
    )


class ImmEstimatorSpec(_MultipleModelBase):
    """An interacting multiple model estimator for manoeuvring targets: a quiet
    nearly-constant-velocity model (``accel_std``) and a manoeuvre model, switching by a Markov
    chain (docs/model.md §4)."""

    type: Literal["imm"] = Field(description="Selects this estimator.")
    accel_std: float = _acceleration_noise(
        0.2, "White-acceleration noise of the quiet model, per axis."
    )
    manoeuvre_accel_std: float = _acceleration_noise(
        1.0, "White-acceleration noise of the manoeuvre model, per axis."
    )
    switch_probability: float = Field(
        0.05,
        ge=0,
        le=0.5,
        description=(
            "Probability per step of leaving the current model (either way); both models start "
            "equally likely."
        ),
        json_schema_extra={"unit": "per step"},
    )


class AdaptiveEstimatorSpec(_MultipleModelBase):
    """An estimator that learns each target's process noise: nearly-constant-velocity models on
    a geometric ladder of noise levels around ``accel_std``, weighed by how well each explains
    the measurements (an IMM over the levels, docs/model.md §4.2)."""

    type: Literal["adaptive"] = Field(description="Selects this estimator.")
    accel_std: float = _acceleration_noise(
        0.2, "White-acceleration noise of the middle level, per axis."
    )
    levels: int = Field(
        5,
        ge=1,
        le=MAX_NOISE_LEVELS,
        description=(
            "Number of noise levels: accel_std · spacing^(i − (levels − 1)/2) for i = 0 … "
            "levels − 1; 1: the EKF."
        ),
        json_schema_extra={"unit": "count"},
    )
    spacing: float = Field(
        2.0,
        gt=1,
        le=MAX_RATIO,
        description="Ratio between the noise of neighbouring levels.",
        json_schema_extra={"unit": "–"},
    )
    switch_probability: float = Field(
        0.02,
        ge=0,
        le=0.5,
        description=(
            "Probability per step of moving to each neighbouring level; every level starts "
            "equally likely."
        ),
        json_schema_extra={"unit": "per step"},
    )

    on_evidence: bool = Field(
        False,
        description=(
            "Track with the EKF (at accel_std) until its innovations reject its target model "
            "(a χ² test over evidence_window updates), then with the ladder; false: the ladder "
            "from the start."
        ),
    )
    evidence_window: int = Field(
        20,
        ge=1,
        le=MAX_STEP_COUNT,
        description="Updates whose normalised innovations are summed for the switch's test.",
        json_schema_extra={"unit": "updates"},
    )
    evidence_level: float = Field(
        1e-3,
        gt=0,
        lt=0.5,
        description="False-alarm probability of one test of the switch (χ² quantile 1 − level).",
    )

    @model_validator(mode="after")
    def _levels_stay_finite(self) -> AdaptiveEstimatorSpec:
        top = self.noise_levels()[-1]
        if top > MAX_ACCEL:
            raise ValueError(
                f"levels: the highest level's accel_std · spacing^((levels − 1)/2) = {top:.3g} "
                f"m/s² is above {MAX_ACCEL:g}"
            )
        return self

    def noise_levels(self) -> list[float]:
        """The levels' white-acceleration noise, lowest first."""
        half = (self.levels - 1) / 2
        return [self.accel_std * self.spacing ** (i - half) for i in range(self.levels)]


def _estimator_type(value: object) -> object:
    """The variant an ``estimator`` section names; one without a ``type`` is the EKF."""
    if isinstance(value, dict):
        return value.get("type", "ekf")
    return getattr(value, "type", "ekf")


#: The robots' estimator, selected by its ``type``; a section without one is the paper's EKF.
Estimator = Annotated[
    Annotated[EstimatorSpec, Tag("ekf")]
    | Annotated[ImmEstimatorSpec, Tag("imm")]
    | Annotated[AdaptiveEstimatorSpec, Tag("adaptive")],
    Discriminator(
        _estimator_type,
        custom_error_type="estimator_type",
        custom_error_message="type must be 'ekf' (the default), 'imm' or 'adaptive'",
    ),
]
