"""The policy section of a scenario: the policy chosen by name, and parameters of any policy.

Every policy, built-in or plug-in, owns its parameter model (its ``Params``, beside its code).
The scenario only says which policy the team uses and holds parameter mappings, each under the
name of the policy it configures, checked by that policy's ``Params``::

    policy:
      name: failure_aware
      failure_aware: {eps1: 0.05}      # the parameters of failure_aware
      vanilla: {w_track: 40}           # kept for runs that pick vanilla (rtrack compare)

``params`` is the same mapping for the policy ``name`` names, for plug-ins whose name is a
dotted path (``package.module:Class``) that cannot be a key.
"""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator
from pydantic_core import InitErrorDetails

from resilient_tracking.policies.base import POLICIES
from resilient_tracking.registry import UnknownName


class PolicySpec(BaseModel):
    """The team's policy by name, and the parameters of every policy the file configures, each
    under the policy's own name.

    ``params`` holds those of the policy ``name`` names (for plug-ins named by a dotted path).
    """

    model_config = ConfigDict(extra="allow", allow_inf_nan=False, frozen=True, strict=True)

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
            "Parameters of the policy named by name, checked by its Params model; the same as a"
            " mapping under the policy's own name (policy.<name>), which any policy may have"
            " (docs/own-policy.md)."
        ),
    )

    @field_validator("name")
    @classmethod
    def _known_policy(cls, name: str) -> str:
        why = POLICIES.problem(name)
        if why is not None:
            raise ValueError(why)
        return name

    @model_validator(mode="after")
    def _valid_sections(self) -> PolicySpec:
        """Each section names a policy and passes its ``Params``; errors name the field."""
        problems: list[InitErrorDetails] = []
        for key, section in self.sections().items():
            loc: tuple[str, ...] = ("params",) if key == "params" else (key,)
            if not key.isidentifier():  # not a policy's name (a class path goes in params)
                problems.append(InitErrorDetails(type="extra_forbidden", loc=loc, input=section))
                continue
            try:
                model = POLICIES.get(self.name if key == "params" else key).Params
            except UnknownName as err:
                problems.append(_error(loc, f"not a policy: {err}", section))
                continue
            if key == self.name and self.params:
                problems.append(
                    _error(
                        loc, f"parameters of {key!r} given twice (also as policy.params)", section
                    )
                )
                continue
            try:
                model.model_validate(section)
            except ValidationError as err:
                problems += [
                    InitErrorDetails(
                        type=e["type"],
                        loc=(*loc, *e["loc"]),
                        input=e["input"],
                        ctx=e.get("ctx", {}),
                    )
                    for e in err.errors()
                ]
        if problems:
            raise ValidationError.from_exception_data(type(self).__name__, problems)
        return self

    def sections(self) -> dict[str, Any]:
        """The parameter mappings the file gives, by policy name (``params`` under that key)."""
        found = dict(self.__pydantic_extra__ or {})
        if self.params:
            found["params"] = self.params
        return found

    def params_for(self, name: str, model: type[BaseModel] | None = None) -> BaseModel:
        """The validated parameters of the policy ``name`` (its ``Params``, or ``model`` for a
        class not registered under that name): its section (or ``params`` when it is the named
        policy), else the defaults."""
        extra = self.__pydantic_extra__ or {}
        section = extra.get(name, self.params if name == self.name else {})
        return (model or POLICIES.get(name).Params).model_validate(section)


def _error(loc: tuple[str, ...], message: str, value: Any) -> InitErrorDetails:
    return InitErrorDetails(type="value_error", loc=loc, input=value, ctx={"error": message})
