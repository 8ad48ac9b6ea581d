"""Failure-aware multi-robot target tracking (Li, Liu, Wu, Zhou).

Layout: ``world`` holds truth, ``belief`` what the robots know, ``planning`` and ``policies``
decide from belief only, ``sim`` runs episodes, ``runs`` declares, records, writes and reads
their tables, ``viz`` plots saved data.

What a user needs is importable from here (loaded on first use, so ``import
resilient_tracking`` stays light)::

    from resilient_tracking import (
        Team, TeamObservation, load_scenario, run_episode, make_policy, check_policy,
        Policy, Decision,
    )
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from resilient_tracking.version import __version__

#: Public name → the module defining it.
_PUBLIC = {
    # scenarios
    "Scenario": "resilient_tracking.scenario",
    "ScenarioError": "resilient_tracking.scenario",
    "load_scenario": "resilient_tracking.scenario",
    "parse_scenario": "resilient_tracking.scenario",
    "HazardSpec": "resilient_tracking.scenario",
    "MotionSpec": "resilient_tracking.scenario",
    "SensorSpec": "resilient_tracking.scenario",
    # the robots' side of the loop
    "Team": "resilient_tracking.team",
    "TeamStep": "resilient_tracking.team",
    "TeamConfig": "resilient_tracking.team_config",
    "TeamObservation": "resilient_tracking.observation",
    "Attack": "resilient_tracking.observation",
    "ZoneClue": "resilient_tracking.observation",
    "TeamBelief": "resilient_tracking.belief.team_belief",
    "TargetEstimate": "resilient_tracking.belief.estimate",
    "Event": "resilient_tracking.events",
    # policies
    "Policy": "resilient_tracking.policies.base",
    "Decision": "resilient_tracking.policies.base",
    "NoParams": "resilient_tracking.policies.base",
    "POLICIES": "resilient_tracking.policies.base",
    "register_policy": "resilient_tracking.policies.base",
    "PlanningPolicy": "resilient_tracking.policies.planning_helpers",
    "make_policy": "resilient_tracking.build",
    "check_policy": "resilient_tracking.policy_check",
    "PolicyReport": "resilient_tracking.policy_check",
    # sensors, hazard models and target motions
    "MeasurementModel": "resilient_tracking.models.sensor",
    "SENSORS": "resilient_tracking.models.sensor",
    "register_sensor": "resilient_tracking.models.sensor",
    "HazardModel": "resilient_tracking.world.hazard_model",
    "HAZARDS": "resilient_tracking.world.hazard_model",
    "TargetMotion": "resilient_tracking.world.target_motion",
    "Surroundings": "resilient_tracking.world.target_motion",
    "MOTIONS": "resilient_tracking.world.target_motion",
    "UnknownName": "resilient_tracking.registry",
    # running episodes
    "run_episode": "resilient_tracking.sim.episode",
    "EpisodeResult": "resilient_tracking.runs.records",
}

__all__ = [
    "__version__",
    "Attack",
    "Decision",
    "EpisodeResult",
    "Event",
    "HAZARDS",
    "HazardModel",
    "HazardSpec",
    "MOTIONS",
    "MeasurementModel",
    "MotionSpec",
    "NoParams",
    "POLICIES",
    "PlanningPolicy",
    "Policy",
    "PolicyReport",
    "SENSORS",
    "Scenario",
    "ScenarioError",
    "SensorSpec",
    "Surroundings",
    "TargetEstimate",
    "TargetMotion",
    "Team",
    "TeamBelief",
    "TeamConfig",
    "TeamObservation",
    "TeamStep",
    "UnknownName",
    "ZoneClue",
    "check_policy",
    "load_scenario",
    "make_policy",
    "parse_scenario",
    "register_policy",
    "register_sensor",
    "run_episode",
]


def __getattr__(name: str) -> Any:
    """Load a public name's module on first use (PEP 562)."""
    module = _PUBLIC.get(name)
    if module is None:
        raise AttributeError(f"module 'resilient_tracking' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(__all__)


if TYPE_CHECKING:
    from resilient_tracking.belief.estimate import TargetEstimate
    from resilient_tracking.belief.team_belief import TeamBelief
    from resilient_tracking.build import make_policy
    from resilient_tracking.events import Event
    from resilient_tracking.models.sensor import SENSORS, MeasurementModel, register_sensor
    from resilient_tracking.observation import Attack, TeamObservation, ZoneClue
    from resilient_tracking.policies.base import (
        POLICIES,
        Decision,
        NoParams,
        Policy,
        register_policy,
    )
    from resilient_tracking.policies.planning_helpers import PlanningPolicy
    from resilient_tracking.policy_check import PolicyReport, check_policy
    from resilient_tracking.registry import UnknownName
    from resilient_tracking.runs.records import EpisodeResult
    from resilient_tracking.scenario import (
        HazardSpec,
        MotionSpec,
        Scenario,
        ScenarioError,
        SensorSpec,
        load_scenario,
        parse_scenario,
    )
    from resilient_tracking.sim.episode import run_episode
    from resilient_tracking.team import Team, TeamStep
    from resilient_tracking.team_config import TeamConfig
    from resilient_tracking.world.hazard_model import HAZARDS, HazardModel
    from resilient_tracking.world.target_motion import MOTIONS, Surroundings, TargetMotion
