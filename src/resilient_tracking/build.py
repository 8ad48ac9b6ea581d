"""From a scenario to the objects that run it: the team's own description, its planner and its
policy.

The scenario schema (:mod:`resilient_tracking.scenario`) only validates; the components
(:mod:`~resilient_tracking.policies`, :mod:`~resilient_tracking.planning`, the sensor models)
know nothing of scenario files. This module is where the two meet.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from resilient_tracking.models.motion import NearlyConstantVelocity
from resilient_tracking.planning.planner import LeaguePlanner
from resilient_tracking.policies.base import POLICIES, Policy
from resilient_tracking.scenario import Scenario
from resilient_tracking.team_config import TeamConfig


def team_config(scenario: Scenario) -> TeamConfig:
    """The team a scenario declares: its robots, workspace, sensor and target model."""
    return TeamConfig(
        dt=scenario.dt,
        u_max=np.array([r.u_max for r in scenario.robots], dtype=float),
        lower=scenario.workspace.lower,
        upper=scenario.workspace.upper,
        sensor=scenario.sensor.model(),
        target_model=NearlyConstantVelocity(scenario.dt, scenario.estimator.accel_std),
        comm_range=scenario.comm_range,
    )


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
    config = config or team_config(scenario)
    params: Any = scenario.policy.params_for(name)
    return cls.build(config, params, planner or LeaguePlanner.from_spec(scenario.planner))
