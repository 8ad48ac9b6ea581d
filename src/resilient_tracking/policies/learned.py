"""Learned policies as plug-ins: any callable from a robot's view to its velocity.

A trained network (or any function) that maps the view of one robot
(:mod:`resilient_tracking.belief.agent_view`, the observation of the learning environments) to
a velocity ``(2,)`` runs as a policy: under ``rtrack run``, ``rtrack compare`` and
``check_policy``, like any other. Either name the function in the scenario::

    policy:
      name: callable
      callable: {function: "my_package.agents:act"}

(``rtrack compare ... --policies vanilla,callable --set
policy.callable.function=my_package.agents:act``)
or subclass :class:`CallablePolicy` and override :meth:`CallablePolicy.make_function` (to load
weights once, say), then pick the class as ``my_package.agents:MyPolicy``;
:meth:`CallablePolicy.wrapping` makes such a class from a function in Python.

Each robot's velocity is clipped to its bounds (speed and workspace); a velocity that is not
finite is left for the team to contain (the robot holds, with an ``invalid_decision`` event).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, ClassVar

import numpy as np
from pydantic import Field, field_validator

from resilient_tracking import plugin_guard
from resilient_tracking.belief.agent_view import MAX_ZONES, team_views
from resilient_tracking.belief.needs import BeliefNeeds
from resilient_tracking.belief.team_belief import TeamBelief
from resilient_tracking.observation import TeamObservation
from resilient_tracking.policies.base import Decision, Policy, register_policy
from resilient_tracking.policies.failure_aware import FailureAwarePolicy
from resilient_tracking.spec import Strict

#: What a learned policy is: one robot's view (field name → array) to its velocity ``(2,)``.
ViewFunction = Callable[[dict[str, np.ndarray]], Any]


class CallableParams(Strict):
    """Which function decides, and the size of the views it is given."""

    function: str = Field(
        "",
        description="The function from a robot's view to its velocity, as "
        "package.module:name (empty for a subclass that makes its own).",
    )
    max_zones: int = Field(
        MAX_ZONES, ge=0, le=64, description="Rows of known zones in each view (the nearest)."
    )

    @field_validator("function")
    @classmethod
    def _dotted(cls, value: str) -> str:
        if value and (value.count(":") != 1 or not all(value.split(":"))):
            raise ValueError("expected package.module:name")
        return value


def import_function(path: str) -> ViewFunction:
    """The object ``package.module:name`` names; ``ValueError`` if it is not callable. The
    module is imported as a plug-in (:func:`~resilient_tracking.plugin_guard.importing`)."""
    module_name, _, attr = path.partition(":")
    found = getattr(plugin_guard.importing(module_name), attr)
    if not callable(found):
        raise ValueError(f"{path} is not callable")
    return found  # type: ignore[no-any-return]


@register_policy("callable")
class CallablePolicy(Policy):
    """Each robot moves as a function of its own view decides (module docstring).

    The belief kept is the failure-aware team's (zones learned and shared, comm zones inferred
    from silent teammates), as in the learning environments by default, so a function sees
    under ``rtrack run`` what it saw in training.
    """

    name: ClassVar[str] = "callable"
    Params = CallableParams
    params: CallableParams
    #: the mode recorded for every robot
    mode: ClassVar[str] = "learned"

    def __init__(self, config: Any, params: Any = None):
        super().__init__(config, params)
        self.function = self.make_function()

    def make_function(self) -> ViewFunction:
        """The function deciding each robot's velocity (by default the one ``function``
        names); subclasses may load a network here."""
        if not self.params.function:
            raise ValueError(
                f"policy {self.name}: give params.function (package.module:name) or subclass "
                "CallablePolicy and override make_function"
            )
        return import_function(self.params.function)

    def belief_needs(self) -> BeliefNeeds:
        """The failure-aware team's belief (class docstring)."""
        return FailureAwarePolicy(self.config, FailureAwarePolicy.Params()).belief_needs()

    def act(self, belief: TeamBelief, obs: TeamObservation) -> Decision:
        """Each robot's velocity from its own view, clipped to its bounds."""
        m = obs.n_robots
        views = team_views(belief, obs, self.config.u_max, self.params.max_zones)
        controls = self.velocities(views)
        lower, upper = self.config.velocity_bounds(list(range(m)), obs.positions)
        with np.errstate(invalid="ignore"):
            controls = np.clip(controls, lower, upper)
        return Decision(controls, [self.mode] * m)

    def velocities(self, views: dict[str, np.ndarray]) -> np.ndarray:
        """``(M, 2)`` velocities from every robot's view (each field with a leading axis of the
        robots): the function called on each robot's own view."""
        m = len(views["own"])
        controls = np.empty((m, 2))
        for i in range(m):
            view = {name: rows[i] for name, rows in views.items()}
            controls[i] = np.asarray(self.function(view), dtype=float).reshape(2)
        return controls

    @classmethod
    def wrapping(cls, function: ViewFunction, name: str = "learned") -> type[CallablePolicy]:
        """A policy class whose robots move as ``function`` decides (for ``check_policy`` or
        :func:`~resilient_tracking.policies.base.register_policy` in Python)."""

        def make_function(self: CallablePolicy) -> ViewFunction:
            return function

        return type(
            f"Wrapped{name.title().replace('_', '')}Policy",
            (cls,),
            {"name": name, "make_function": make_function, "__module__": cls.__module__},
        )
