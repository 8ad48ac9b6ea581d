"""Danger zones of a scenario: their hazard models, and the sensing and communication zones
(paper eq. 4-5)."""

from __future__ import annotations

from typing import Annotated, Any, ClassVar, Literal

import numpy as np
from pydantic import (
    Discriminator,
    Field,
    SerializeAsAny,
    Tag,
    field_validator,
    model_validator,
)

from resilient_tracking.scenario.base import (
    MAX_VARIANCE,
    MIN_COVARIANCE_RATIO,
    MIN_VARIANCE,
    Matrix2,
    Strict,
    Vec2,
    plugin_spec,
)
from resilient_tracking.scenario.effects import CommEffect, FailEffect, SensingEffect
from resilient_tracking.scenario.world_specs import TargetMotion
from resilient_tracking.spec import MAX_INTENSITY, MAX_LENGTH, MAX_RATE, MAX_RATIO

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
    f_act: float = Field(
        1.0,
        gt=0,
        le=MAX_RATE,
        description="Activation frequency of the zone.",
        json_schema_extra={"unit": "Hz"},
    )
    kappa: float = Field(
        1.0,
        gt=0,
        le=MAX_INTENSITY,
        description="Intensity κ, multiplying a density in m⁻².",
        json_schema_extra={"unit": "m²"},
    )


class DiskHazard(HazardSpec):
    """Hit with probability ``p_hit`` at each activation tick while inside the true disk."""

    model: Literal["disk"] = Field(description="Selects this hazard model.")
    f_act: float = Field(
        1.0,
        gt=0,
        le=MAX_RATE,
        description="Activation frequency of the zone.",
        json_schema_extra={"unit": "Hz"},
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
    plugin_spec("resilient_tracking.world.hazard_model:HAZARDS", "model"),
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

    name: str | None = Field(
        None,
        description=(
            "Label for plots and logs, unique among the zones; a lure target names its zone by it."
        ),
    )
    mu: Vec2 = Field(
        ..., description="Prior mean μ of the zone center.", json_schema_extra={"unit": "m"}
    )
    sigma: Matrix2 = Field(
        ...,
        description=(
            "Prior covariance Σ of the zone center: symmetric, positive definite, entries within "
            f"±{MAX_VARIANCE:g} m², smallest eigenvalue at least {MIN_VARIANCE:g} m² and at "
            f"least {MIN_COVARIANCE_RATIO:g} times the largest."
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
    m_recover: float = Field(
        2.0,
        gt=0,
        le=MAX_RATIO,
        description=(
            "Size of the influence region (x − μ)ᵀ Σ⁻¹ (x − μ) ≤ m_recover², out of which a "
            "temporary failure ends."
        ),
        json_schema_extra={"unit": "Mahalanobis"},
    )
    known: bool = Field(
        False,
        description=(
            "A mapped hazard: the team holds the zone's prior (μ, Σ, size, persistence), what an "
            "attack would reveal, from step 0 as if broadcast; never its true center."
        ),
    )

    motion: TargetMotion | None = Field(
        None,
        description=(
            "How the zone moves, selected by its type (the targets' motions, starting at μ); "
            "the prior mean and the drawn centre shift by the motion's displacement. None: the "
            "zone stays where it is. Motions that react to the world are refused."
        ),
    )

    _sigma_ok = field_validator("sigma")(_check_covariance)

    @property
    def kinds(self) -> tuple[Literal["sensing", "comm"], ...]:
        """The capabilities an attack of this zone disables."""
        raise NotImplementedError

    @property
    def sizes(self) -> dict[str, float]:
        """What an attack clue reports as the zone's size, per kind."""
        raise NotImplementedError


class SpreadSpec(Strict):
    """How a permanent comm zone's compromise passes from robot to robot over links
    (docs/model.md §2)."""

    probability: float = Field(
        ...,
        gt=0,
        le=1,
        description=(
            "Probability per step that a robot whose radio this zone compromised passes the"
            " compromise to each teammate it has a link to."
        ),
        json_schema_extra={"unit": "per step"},
    )


class SensingZone(ZoneBase):
    """A sensing danger zone (paper eq. 4): a disk of radius ``r`` around its true center; an attack
    disables the robot's sensor."""

    @model_validator(mode="before")
    @classmethod
    def _no_spread(cls, data: object) -> object:
        # a multimodal zone's dump carries ``spread: null`` (its comm side's field): no spread
        if isinstance(data, dict) and data.get("spread") is not None:
            raise ValueError("spread: only a permanent comm zone's compromise spreads")
        return data

    kind: Literal["sensing"] = Field(
        description="An attack disables the robot's sensor (or degrades it: effect)."
    )
    radius: float = Field(
        ...,
        gt=0,
        le=MAX_LENGTH,
        description="Radius r of the zone's disk around its true center.",
        json_schema_extra={"unit": "m"},
    )
    effect: SensingEffect = Field(
        FailEffect(),
        description=(
            "What an attack does: fail (the sensor is lost, the default) or degrade (noise "
            "multiplied, range biased, measurements dropped)."
        ),
    )

    @property
    def size(self) -> float:
        """What an attack clue reports as the zone's size: the radius ``r``."""
        return self.radius

    @property
    def kinds(self) -> tuple[Literal["sensing", "comm"], ...]:
        """``("sensing",)``."""
        return ("sensing",)

    @property
    def sizes(self) -> dict[str, float]:
        """``{"sensing": r}``."""
        return {"sensing": self.radius}


class CommZone(ZoneBase):
    """A comm danger zone (paper eq. 5): an attack disables the robot's radio, and its jammer cuts a
    link when a robot is within ``δ2`` times the link length of the true center."""

    kind: Literal["comm"] = Field(
        description=(
            "An attack disables the robot's radio (or degrades it: effect); the zone also jams "
            "links."
        )
    )
    delta2: float = Field(
        ...,
        gt=0,
        le=MAX_RATIO,
        description=(
            "Jammer strength δ2: a link is cut when a robot is within δ2 times the link length of"
            " the true center."
        ),
        json_schema_extra={"unit": "ratio"},
    )
    effect: CommEffect = Field(
        FailEffect(),
        description=(
            "What an attack does: fail (the radio is lost, the default) or degrade (messages "
            "on the robot's links lost)."
        ),
    )
    spread: SpreadSpec | None = Field(
        None,
        description=(
            "Permanent zones only: a robot whose radio this zone compromised passes the"
            " compromise on to linked teammates (stochastic fault propagation); absent: it"
            " does not."
        ),
    )

    @model_validator(mode="after")
    def _spread_is_permanent(self) -> CommZone:
        if self.spread is not None and self.persistence != "permanent":
            raise ValueError(
                "spread: only a permanent comm zone's compromise spreads (this zone's"
                f" persistence is {self.persistence})"
            )
        return self

    @property
    def size(self) -> float:
        """What an attack clue reports as the zone's size: the jammer strength ``δ2``."""
        return self.delta2

    @property
    def kinds(self) -> tuple[Literal["sensing", "comm"], ...]:
        """``("comm",)``."""
        return ("comm",)

    @property
    def sizes(self) -> dict[str, float]:
        """``{"comm": δ2}``."""
        return {"comm": self.delta2}


class MultimodalZone(SensingZone, CommZone):  # type: ignore[misc]
    """A zone that attacks both the sensor and the radio: one hazard draw disables both (each
    failure with the zone's persistence), its disk has the radius ``r`` and its jammer the
    strength ``δ2``; a clue tells the victim both kinds."""

    #: how the scenario reference names this variant (its ``kind`` is a list)
    variant: ClassVar[str] = "kind: [sensing, comm]"

    kind: list[Literal["sensing", "comm"]] = Field(  # type: ignore[assignment]
        description=(
            "[sensing, comm]: an attack disables the robot's sensor and its radio; the zone "
            "also jams links."
        ),
        min_length=2,
        max_length=2,
    )
    effect: FailEffect = Field(  # type: ignore[assignment]
        FailEffect(),
        description="What an attack does: a zone of two kinds fails both (it does not degrade).",
    )

    @field_validator("kind")
    @classmethod
    def _both_kinds(cls, value: list[str]) -> list[str]:
        if set(value) != {"sensing", "comm"}:
            raise ValueError("a list of kinds must name sensing and comm, once each")
        return ["sensing", "comm"]

    @property
    def size(self) -> float:  # type: ignore[override]
        """A multimodal zone has one size per kind: see :attr:`sizes`."""
        raise AttributeError("a multimodal zone has one size per kind: use sizes")

    @property
    def kinds(self) -> tuple[Literal["sensing", "comm"], ...]:
        """``("sensing", "comm")``."""
        return ("sensing", "comm")

    @property
    def sizes(self) -> dict[str, float]:
        """``{"sensing": r, "comm": δ2}``."""
        return {"sensing": self.radius, "comm": self.delta2}


def zone_tag(value: Any) -> str | None:
    """Which zone variant a mapping (or model) is: its ``kind``, or ``multimodal`` for a list
    of kinds."""
    kind = value.get("kind") if isinstance(value, dict) else getattr(value, "kind", None)
    if isinstance(kind, (list, tuple)):
        return "multimodal"
    return kind if isinstance(kind, str) else None


Zone = Annotated[
    Annotated[SensingZone, Tag("sensing")]
    | Annotated[CommZone, Tag("comm")]
    | Annotated[MultimodalZone, Tag("multimodal")],
    Discriminator(
        zone_tag,
        custom_error_type="zone_kind",
        custom_error_message=("kind must be sensing, comm or the list [sensing, comm]"),
    ),
]
