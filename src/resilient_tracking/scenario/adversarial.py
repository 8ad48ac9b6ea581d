"""Target motions that react to the world's truth: ``evasive`` targets that flee the robots and
``lure`` targets that lead them into a danger zone (docs/model.md §1). Both wrap a ``base``
motion, any target motion, that they follow when they are not reacting."""

from __future__ import annotations

from typing import Annotated, ClassVar, Literal

from pydantic import Field

from resilient_tracking.scenario.world_specs import MotionSpec, TargetMotion
from resilient_tracking.spec import MAX_ACCEL, MAX_DURATION, MAX_LENGTH, MAX_SPEED

#: The acceleration bound of a reacting target unless its spec sets one (m/s²).
DEFAULT_MAX_ACCEL = 1.0


class Evasive(MotionSpec):
    """Follows ``base`` until a robot comes within ``radius``, then flees the robots within it
    (the closer, the more), at most ``speed``, with acceleration at most ``max_accel``, inside
    the workspace; steers back onto its base motion once no robot is within ``radius``."""

    reacts: ClassVar[bool] = True

    type: Literal["evasive"] = Field(description="Selects this motion.")
    base: TargetMotion = Field(
        ...,
        description=(
            "The motion followed while no robot is near: any target motion, selected by its type."
        ),
    )
    radius: float = Field(
        ...,
        gt=0,
        le=MAX_LENGTH,
        description="A robot closer than this (true distance) makes the target flee.",
        json_schema_extra={"unit": "m"},
    )
    speed: float = Field(
        ...,
        gt=0,
        le=MAX_SPEED,
        description=(
            "Top speed while fleeing and while steering back to the base motion; keep it below "
            "the robots' u_max for a target the team can follow."
        ),
        json_schema_extra={"unit": "m/s"},
    )
    max_accel: float = Field(
        DEFAULT_MAX_ACCEL,
        gt=0,
        le=MAX_ACCEL,
        description="Largest change of velocity per second while fleeing or steering back.",
        json_schema_extra={"unit": "m/s²"},
    )
    wall_margin: float = Field(
        0.5,
        ge=0,
        le=MAX_LENGTH,
        description=(
            "Within this distance of a workspace wall the target stops fleeing into it and "
            "slides along it instead (out of a corner along the longer free side)."
        ),
        json_schema_extra={"unit": "m"},
    )


class Lure(MotionSpec):
    """Follows ``base``, and from time ``after`` (again every ``period``) leaves it for the
    true centre of the zone called ``zone``, lingers there ``linger`` seconds and steers back
    onto its base motion, at most ``speed`` throughout."""

    reacts: ClassVar[bool] = True

    type: Literal["lure"] = Field(description="Selects this motion.")
    base: TargetMotion = Field(
        ...,
        description=("The motion followed between trips: any target motion, selected by its type."),
    )
    zone: str = Field(
        ...,
        description="The name of the danger zone the target leads to (a zones[].name).",
    )
    speed: float = Field(
        ...,
        gt=0,
        le=MAX_SPEED,
        description="Top speed on the way to the zone and back to the base motion.",
        json_schema_extra={"unit": "m/s"},
    )
    linger: float = Field(
        5.0,
        ge=0,
        le=MAX_DURATION,
        description="How long the target stays at the zone once there.",
        json_schema_extra={"unit": "s"},
    )
    after: float = Field(
        5.0,
        ge=0,
        le=MAX_DURATION,
        description="Time of the first trip to the zone.",
        json_schema_extra={"unit": "s"},
    )
    period: Annotated[float, Field(gt=0, le=MAX_DURATION)] | None = Field(
        None,
        description=(
            "A further trip is due every period seconds after the first (one that falls during "
            "a trip starts once the target is back on its base motion); null: one trip."
        ),
        json_schema_extra={"unit": "s"},
    )
    near: Annotated[float, Field(gt=0, le=MAX_LENGTH)] | None = Field(
        None,
        description=(
            "A due trip waits until a robot is within this distance of the target (it leads "
            "its trackers in); null: it starts when due."
        ),
        json_schema_extra={"unit": "m"},
    )
    standoff: float = Field(
        0.0,
        ge=0,
        le=MAX_LENGTH,
        description=(
            "Distance from the zone's true centre at which the target stops, on the side it "
            "came from; 0: on the centre."
        ),
        json_schema_extra={"unit": "m"},
    )
    max_accel: float = Field(
        DEFAULT_MAX_ACCEL,
        gt=0,
        le=MAX_ACCEL,
        description="Largest change of velocity per second on its trips.",
        json_schema_extra={"unit": "m/s²"},
    )
