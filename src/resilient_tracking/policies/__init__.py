"""Policies a user picks by name; each decides from belief only (never from ``world``).

Built-ins: ``failure_aware`` (the paper's Algorithm 1), ``vanilla`` and ``sog`` (baselines).
Other packages add policies through the entry-point group ``resilient_tracking.policies`` or a
scenario names a class directly as ``package.module:Class`` (:mod:`resilient_tracking.registry`).
"""

from __future__ import annotations

from typing import Any

from resilient_tracking.planning.planner import LeaguePlanner
from resilient_tracking.policies.base import POLICIES, Decision, NoParams, Policy, register_policy
from resilient_tracking.policies.failure_aware import FailureAwarePolicy
from resilient_tracking.policies.planning_helpers import PlanningPolicy
from resilient_tracking.policies.sog import SogPolicy
from resilient_tracking.policies.vanilla import VanillaPolicy
from resilient_tracking.scenario import Scenario
from resilient_tracking.team_config import TeamConfig

__all__ = [
    "POLICIES",
    "Decision",
    "FailureAwarePolicy",
    "NoParams",
    "PlanningPolicy",
    "Policy",
    "SogPolicy",
    "VanillaPolicy",
    "make_policy",
    "register_policy",
]


def make_policy(
    name: str,
    scenario: Scenario,
    config: TeamConfig | None = None,
    planner: LeaguePlanner | None = None,
) -> Policy:
    """The policy called ``name`` with its parameters and planner from the scenario.

    ``name`` is a registered name, an entry point of ``resilient_tracking.policies`` or a dotted
    path ``package.module:Class``; an unknown one raises
    :class:`~resilient_tracking.registry.UnknownName`. The parameters are
    ``scenario.policy.params_for(name)``. ``config`` defaults to the scenario's team;
    ``planner`` replaces the scenario's :class:`LeaguePlanner` (e.g. one with a fault hook).
    """
    cls = POLICIES.get(name)
    config = config or TeamConfig.from_scenario(scenario)
    params: Any = scenario.policy.params_for(name, cls.Params)
    return cls.build(config, params, planner or LeaguePlanner.from_spec(scenario.planner))
