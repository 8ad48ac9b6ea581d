"""The ``guards`` section of a scenario: each guard's settings under its name.

::

    guards:
      lure: {enabled: true, standoff: 2.0}
      exposure: {enabled: true, horizon: 20}
      comm_hazard: {enabled: false}

Every registered guard takes part with its defaults unless its section says otherwise (the
built-ins ``comm_hazard``, ``last_sensors`` and ``safe_circling`` are on by default, the others
off); a plug-in guard is named by its registered name or as ``package.module:Class``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from pydantic import BaseModel, ConfigDict, ValidationError, model_validator
from pydantic_core import InitErrorDetails

from resilient_tracking.policies.guards.base import GUARDS, Guard, GuardParams
from resilient_tracking.registry import UnknownName
from resilient_tracking.team_config import TeamConfig

if TYPE_CHECKING:
    from resilient_tracking.policies.failure_aware_params import FailureAwareParams


class GuardsSpec(BaseModel):
    """Settings of the failure-aware team's guards, each under the guard's name (module
    docstring); each section is checked by its guard's ``Params``."""

    model_config = ConfigDict(extra="allow", allow_inf_nan=False, frozen=True, strict=True)

    @model_validator(mode="after")
    def _valid_sections(self) -> GuardsSpec:
        """Each section names a guard and passes its ``Params``; errors name the field."""
        problems: list[InitErrorDetails] = []
        for name, section in self.sections().items():
            try:
                model = GUARDS.get(name).Params
            except UnknownName as err:
                problems.append(
                    InitErrorDetails(
                        type="value_error", loc=(name,), input=section, ctx={"error": str(err)}
                    )
                )
                continue
            try:
                model.model_validate(section)
            except ValidationError as err:
                problems += [
                    InitErrorDetails(
                        type=e["type"],
                        loc=(name, *e["loc"]),
                        input=e["input"],
                        ctx=e.get("ctx", {}),
                    )
                    for e in err.errors()
                ]
        if problems:
            raise ValidationError.from_exception_data(type(self).__name__, problems)
        return self

    def sections(self) -> dict[str, Any]:
        """The sections the file gives, by guard name."""
        return dict(self.__pydantic_extra__ or {})

    def params_for(self, name: str) -> GuardParams:
        """The validated settings of guard ``name``: its section, else its defaults."""
        return GUARDS.get(name).Params.model_validate(self.sections().get(name, {}))

    def names(self) -> list[str]:
        """Every guard taking part: the built-ins in their order, then installed ones, then
        those only this section names, each once."""
        builtin = GUARDS.builtin_names()
        found = builtin + [n for n in GUARDS.names() if n not in builtin]
        return found + [n for n in self.sections() if n not in found]

    def enabled(self) -> list[str]:
        """The guards switched on, in :meth:`names` order."""
        return [n for n in self.names() if self.params_for(n).enabled]

    def build(self, config: TeamConfig, method: FailureAwareParams) -> list[Guard]:
        """The guards switched on, for team ``config`` and the policy's parameters ``method``."""
        chosen = [(n, self.params_for(n)) for n in self.names()]
        return [GUARDS.get(n)(params, config, method) for n, params in chosen if params.enabled]
