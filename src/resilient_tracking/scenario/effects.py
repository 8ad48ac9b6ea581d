"""What a zone's attack does to a robot: ``fail`` (the capability is lost, the paper's model) or
``degrade`` (it keeps working, worse; docs/model.md §2).

A sensing zone's degradation multiplies the sensor's noise, adds a bias to its range and drops
measurements; a comm zone's loses messages on the robot's links. Whether the robot notices is
``announced``: a failure always is; an unannounced degradation is known to the world alone.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import Discriminator, Field, Tag, model_validator

from resilient_tracking.spec import MAX_LENGTH, MAX_RATIO, Strict

#: The fields of a sensing zone's degradation, and of a comm zone's.
SENSING_DEGRADE_FIELDS = ("noise_factor", "bias", "dropout")
COMM_DEGRADE_FIELDS = ("loss_probability",)


class FailEffect(Strict):
    """The attack disables the capability (the paper's failure): always announced."""

    type: Literal["fail"] = Field("fail", description="Selects this effect (the default).")
    announced: Literal[True] = Field(
        True, description="A failure is always noticed by its robot (an attack event and clue)."
    )


def _refuse(data: Any, fields: tuple[str, ...], kind: str) -> Any:
    """``data`` unchanged, or a ``ValueError`` naming a field that belongs to the other kind."""
    if isinstance(data, dict):
        for name in fields:
            if name in data:
                other = "sensing" if kind == "comm" else "comm"
                raise ValueError(
                    f"{name}: applies to a {other} zone's degradation, not a {kind} zone's"
                )
    return data


class _Degrade(Strict):
    type: Literal["degrade"] = Field(description="Selects this effect.")
    announced: bool = Field(
        False,
        description=(
            "Whether the robot notices: an attack event and the zone's clue as for a failure, "
            "and a recovery when a temporary degradation ends. false: silent, known to the "
            "world alone; the robot keeps believing its nominal model."
        ),
    )


class SensingDegrade(_Degrade):
    """The sensor keeps measuring, worse: noise multiplied, range biased, measurements lost."""

    noise_factor: float = Field(
        1.0,
        ge=1,
        le=MAX_RATIO,
        description="Factor on the standard deviation of every channel's measurement noise.",
        json_schema_extra={"unit": "ratio"},
    )
    bias: float = Field(
        0.0,
        ge=-MAX_LENGTH,
        le=MAX_LENGTH,
        description=(
            "Added to the range channel of every measurement; a sensor that measures no range "
            "(bearing_only) takes none."
        ),
        json_schema_extra={"unit": "m"},
    )
    dropout: float = Field(
        0.0,
        ge=0,
        le=1,
        description="Probability that each measurement of the robot is lost, per target and step.",
    )

    @model_validator(mode="before")
    @classmethod
    def _sensing_fields_only(cls, data: Any) -> Any:
        return _refuse(data, COMM_DEGRADE_FIELDS, "sensing")


class CommDegrade(_Degrade):
    """The radio keeps working, lossily: each link of the robot is down for a step with
    ``loss_probability``, drawn per link and step."""

    loss_probability: float = Field(
        0.0,
        ge=0,
        le=1,
        description=(
            "Probability that each link of the robot is down for a step (its messages lost), "
            "drawn per link and step; leagues form over the links that remain."
        ),
    )

    @model_validator(mode="before")
    @classmethod
    def _comm_fields_only(cls, data: Any) -> Any:
        return _refuse(data, SENSING_DEGRADE_FIELDS, "comm")


def _effect_type(value: Any) -> Any:
    """The ``type`` of an effect section; ``fail`` when the mapping has none."""
    if isinstance(value, dict):
        return value.get("type", "fail")
    return getattr(value, "type", None)


_EFFECT_DISCRIMINATOR = Discriminator(
    _effect_type,
    custom_error_type="effect_type",
    custom_error_message="type must be 'fail' (the default) or 'degrade'",
)

#: A sensing zone's effect, selected by ``type`` (``fail`` when absent).
SensingEffect = Annotated[
    Annotated[FailEffect, Tag("fail")] | Annotated[SensingDegrade, Tag("degrade")],
    _EFFECT_DISCRIMINATOR,
]
#: A comm zone's effect, selected by ``type`` (``fail`` when absent).
CommEffect = Annotated[
    Annotated[FailEffect, Tag("fail")] | Annotated[CommDegrade, Tag("degrade")],
    _EFFECT_DISCRIMINATOR,
]
