"""The policy contract: belief and the tick's observation in, a :class:`Decision` out.

A policy is a class with one verb, :meth:`Policy.act`. It reads only the team's
:class:`~resilient_tracking.belief.team_belief.TeamBelief` and the tick's
:class:`~resilient_tracking.observation.TeamObservation` (never the simulated world) and returns
one velocity command per robot. Its parameters are a pydantic model, ``Params``, validated from
the scenario's ``policy.params`` with the same error messages as every other field.

Policies that plan with the league NLP of the paper (docs/model.md §5) build on
:class:`~resilient_tracking.policies.planning_helpers.PlanningPolicy`; a policy of its own needs
nothing but this module. Register a class with :func:`register_policy` (or an entry point in the
group ``resilient_tracking.policies``) to make it findable by name.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
from pydantic import BaseModel, ConfigDict, create_model

from resilient_tracking.belief.needs import BeliefNeeds
from resilient_tracking.belief.team_belief import TeamBelief
from resilient_tracking.events import Event
from resilient_tracking.observation import TeamObservation
from resilient_tracking.registry import Registry
from resilient_tracking.team_config import TeamConfig

if TYPE_CHECKING:
    from resilient_tracking.planning.planner import LeaguePlanner, PlanResult
    from resilient_tracking.policies.guards.settings import GuardsSpec


@dataclass
class Decision:
    """What a policy returns for one tick."""

    #: ``(M, 2)`` velocity commands, one row per robot, within the robots' velocity bounds
    controls: np.ndarray
    #: one word per robot saying what it does ("league", "individual", "idle"…), for the tables
    modes: list[str]
    #: what happened while deciding (solver fallbacks…), in order
    events: list[Event] = field(default_factory=list)
    #: the league plans solved this tick (empty for a policy that does not plan)
    plans: list[PlanResult] = field(default_factory=list)

    @property
    def plan_ms(self) -> float:
        """Total solve time of this tick's plans (ms)."""
        return float(sum(p.solve_ms for p in self.plans))


class NoParams(BaseModel):
    """Parameters of a policy that has none: the mapping must be empty."""

    model_config = ConfigDict(extra="forbid", frozen=True)


class Policy(ABC):
    """Decides every robot's velocity from belief, once per tick.

    Subclasses set ``name``, ``Params`` (a pydantic model of their parameters) and implement
    :meth:`act`. A policy declares what it needs of the belief, never configures it:
    ``learns_zones`` says whether the team keeps zone knowledge at all (the vanilla team does
    not); :meth:`belief_needs` says it all (the failure-aware policy adds the comm zones
    inferred from silent teammates, Alg. 3).
    """

    name: ClassVar[str] = "policy"
    Params: ClassVar[type[BaseModel]] = NoParams
    learns_zones: ClassVar[bool] = True
    #: the field of ``Params`` that the name ``<name>:<value>`` fills (the ``onnx`` policy's
    #: ``model``: ``onnx:team.onnx``); ``None``: the name takes no argument
    argument: ClassVar[str | None] = None

    def __init__(self, config: TeamConfig, params: Any = None):
        #: the team: number of robots, velocity bounds, sensor, time step
        self.config = config
        #: the validated ``Params`` (their defaults when none are given)
        self.params = self.Params() if params is None else params

    def belief_needs(self) -> BeliefNeeds:
        """What this policy needs of the team's belief (by default: zone knowledge if
        ``learns_zones``)."""
        return BeliefNeeds(zones=self.learns_zones)

    @classmethod
    def files_read(cls, params: Any) -> list[Path]:
        """Files whose content decides this policy's actions under ``params`` (a model's
        weights): a stored run made with other contents is stale. None by default."""
        del params
        return []

    def check_targets(self, n_targets: int) -> None:
        """Refuse a team tracking ``n_targets`` targets that this policy cannot serve (a
        ``ValueError`` saying what does not match); the team asks once, before its first tick.
        Every count by default."""
        del n_targets  # any number serves

    @classmethod
    def with_argument(cls, value: str) -> type[Policy]:
        """This policy with its ``argument`` parameter set to ``value`` unless the scenario
        sets it: the class of the name ``<name>:<value>``."""
        if cls.argument is None:
            raise TypeError(f"policy {cls.name!r} takes no argument")
        fields: dict[str, Any] = {cls.argument: (str, value)}
        params = create_model(cls.Params.__name__, __base__=cls.Params, **fields)
        return type(cls.__name__, (cls,), {"Params": params, "__module__": cls.__module__})

    @classmethod
    def build(
        cls,
        config: TeamConfig,
        params: BaseModel,
        planner: LeaguePlanner | None = None,
        guards: GuardsSpec | None = None,
    ) -> Policy:
        """The policy for a team, as :func:`make_policy` makes it; ``planner`` is the scenario's
        league planner and ``guards`` its guards' settings, ignored by policies that do not
        plan with them (only the failure-aware policy uses guards)."""
        return cls(config, params)

    @abstractmethod
    def act(self, belief: TeamBelief, obs: TeamObservation) -> Decision:
        """The commands for this tick, from belief and the tick's observation only.

        ``belief`` has already been updated with ``obs`` (leagues, target estimates, zone
        knowledge). Return ``Decision.controls`` of shape ``(M, 2)``, finite and within
        ``self.config.velocity_bounds``, and one mode per robot.
        """


#: Every policy findable by name: the built-ins, entry points of the group
#: ``resilient_tracking.policies`` and dotted paths ``package.module:Class``.
POLICIES: Registry[type[Policy]] = Registry(
    "policy", "resilient_tracking.policies", Policy, builtins=("resilient_tracking.policies",)
)

#: Class decorator registering a policy under a name: ``@register_policy("greedy")``.
register_policy = POLICIES.register
