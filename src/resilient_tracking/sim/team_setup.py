"""The team of an episode: its policy, planner and seeded prior, built from a scenario.

Free of truth: given the targets' starting states, a simulated episode and a node on robots
build the same team.
"""

from __future__ import annotations

import numpy as np

from resilient_tracking.belief.estimate import TargetEstimate
from resilient_tracking.planning.planner import FaultHook, LeaguePlanner
from resilient_tracking.policies import make_policy
from resilient_tracking.rng import stream
from resilient_tracking.scenario import Scenario
from resilient_tracking.team import Team
from resilient_tracking.team_config import TeamConfig


def prior_estimate(scenario: Scenario, truth: np.ndarray, seed: int) -> TargetEstimate:
    """The prior around the targets' starting states ``truth`` (N, 4), seeded like an episode."""
    spec = scenario.estimator
    std = np.array([spec.initial_position_std] * 2 + [spec.initial_velocity_std] * 2)
    noise = stream(seed, "estimator_init").standard_normal(truth.shape) * std
    return TargetEstimate.initial(
        truth + noise, spec.initial_position_std, spec.initial_velocity_std
    )


def build_team(
    scenario: Scenario,
    policy_name: str,
    seed: int,
    initial_targets: np.ndarray,
    fault_hook: FaultHook | None = None,
) -> Team:
    """The team of an episode: policy, planner and the seeded prior around ``initial_targets``."""
    config = TeamConfig.from_scenario(scenario)
    planner = LeaguePlanner.from_spec(scenario.planner, fault_hook=fault_hook)
    policy_obj = make_policy(policy_name, scenario, config, planner)
    return Team(policy_obj, prior_estimate(scenario, initial_targets, seed))
