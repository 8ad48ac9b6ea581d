"""Settings of the lure guard (:mod:`~.lure`): when a target is suspect, how far robots keep."""

from __future__ import annotations

from pydantic import Field

from resilient_tracking.policies.guards.base import GuardParams
from resilient_tracking.spec import MAX_DURATION, MAX_SPEED, MAX_STEP_COUNT, Length, PositiveLength


class LureGuardParams(GuardParams):
    """When a target is suspected of luring robots into danger, and how far robots then keep
    from it."""

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
