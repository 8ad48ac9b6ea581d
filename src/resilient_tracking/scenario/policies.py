"""The policy section of a scenario: the built-in policies' parameters, and a policy chosen
by name."""

from __future__ import annotations

from typing import Any

from pydantic import (
    BaseModel,
    Field,
    ValidationInfo,
    field_validator,
)

from resilient_tracking.scenario.base import PositiveFloat, Strict

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
    guard_temporary_jammers: bool = Field(
        True,
        description=(
            "Keep league links clear (eq. 7d) of comm zones the league knows to be temporary, as"
            " the paper does; false: such a zone costs only a short outage, so leagues plan as"
            " if it were not there (docs/generalization.md measures both)."
        ),
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
