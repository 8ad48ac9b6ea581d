"""Policies a user picks by name; each decides from belief only (never from ``world``)."""

from __future__ import annotations

from resilient_tracking.planning.planner import LeaguePlanner
from resilient_tracking.policies.base import Decision, Policy
from resilient_tracking.policies.failure_aware import FailureAwarePolicy
from resilient_tracking.policies.sog import SogPolicy
from resilient_tracking.policies.vanilla import VanillaPolicy
from resilient_tracking.scenario import Scenario
from resilient_tracking.team_config import TeamConfig

__all__ = ["Decision", "FailureAwarePolicy", "Policy", "SogPolicy", "VanillaPolicy", "make_policy"]


def make_policy(
    name: str, scenario: Scenario, config: TeamConfig, planner: LeaguePlanner | None = None
) -> Policy:
    """The policy called ``name`` with its parameters and planner from the scenario.

    ``planner`` replaces the scenario's :class:`LeaguePlanner` (e.g. one with a fault hook).
    """
    planner = planner or LeaguePlanner.from_spec(scenario.planner)
    if name == "vanilla":
        return VanillaPolicy(config, scenario.policy.vanilla, planner)
    if name == "failure_aware":
        return FailureAwarePolicy(config, scenario.policy.failure_aware, planner)
    if name == "sog":
        return SogPolicy(config, scenario.policy.sog, planner)
    raise ValueError(f"policy: unknown name {name!r}")
