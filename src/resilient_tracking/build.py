"""From a scenario to the objects that run it: the team's own description, its estimator, its
planner, its policy and the zones it knows from the start.

The scenario schema (:mod:`resilient_tracking.scenario`) only validates; the components
(:mod:`~resilient_tracking.policies`, :mod:`~resilient_tracking.planning`, the sensor models)
know nothing of scenario files. This module is where the two meet.
"""

from __future__ import annotations

import hashlib
from typing import Any

import numpy as np

from resilient_tracking.belief.ekf import ExtendedKalmanFilter
from resilient_tracking.belief.estimate import TargetEstimate
from resilient_tracking.belief.estimator import Estimator
from resilient_tracking.belief.imm import InteractingMultipleModel
from resilient_tracking.belief.knowledge import ZoneEstimate
from resilient_tracking.belief.on_evidence import AdaptiveOnEvidence, Evidence
from resilient_tracking.models.motion import NearlyConstantVelocity
from resilient_tracking.observation import ZoneClue
from resilient_tracking.planning.planner import LeaguePlanner
from resilient_tracking.policies.base import POLICIES, Policy
from resilient_tracking.rng import stream
from resilient_tracking.scenario import AdaptiveEstimatorSpec, ImmEstimatorSpec, Scenario
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
        mission_steps=scenario.steps,
    )


def make_estimator(scenario: Scenario, config: TeamConfig | None = None) -> Estimator:
    """The estimator the scenario's ``estimator`` section selects, with the team's sensor: the
    paper's EKF of the team's target model, the IMM of :mod:`~.belief.imm`, or that IMM over a
    ladder of noise levels (the adaptive estimator)."""
    config = config or team_config(scenario)
    spec = scenario.estimator
    if isinstance(spec, AdaptiveEstimatorSpec):
        adaptive = InteractingMultipleModel.noise_levels(
            scenario.dt,
            spec.noise_levels(),
            spec.switch_probability,
            config.sensor,
            spec.update_iterations,
            spec.second_order,
        )
        if not spec.on_evidence:
            return adaptive
        ekf = ExtendedKalmanFilter(config.target_model, config.sensor)
        evidence = Evidence(spec.evidence_window, spec.evidence_level)
        return AdaptiveOnEvidence(ekf, adaptive, evidence)
    if isinstance(spec, ImmEstimatorSpec):
        return InteractingMultipleModel.quiet_and_manoeuvre(
            scenario.dt,
            spec.accel_std,
            spec.manoeuvre_accel_std,
            spec.switch_probability,
            config.sensor,
            spec.update_iterations,
            spec.second_order,
        )
    return ExtendedKalmanFilter(config.target_model, config.sensor)


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
    ``planner`` replaces the scenario's :class:`LeaguePlanner` (e.g. one with a fault hook);
    the scenario's ``guards`` go to a policy that uses them.
    """
    cls = POLICIES.get(name)
    config = config or team_config(scenario)
    params: Any = scenario.policy.params_for(name)
    planner = planner or LeaguePlanner.from_spec(scenario.planner)
    return cls.build(config, params, planner, scenario.guards)


def policy_files_digest(name: str, scenario: Scenario) -> str:
    """A hash of the contents of the files the policy ``name`` reads under ``scenario``'s
    parameters (:meth:`Policy.files_read`; empty when it reads none), so that a stored run
    made with another model is seen as stale. A missing file hashes as missing."""
    cls = POLICIES.get(name)
    files = cls.files_read(scenario.policy.params_for(name))
    if not files:
        return ""
    digest = hashlib.sha256()
    for path in files:
        digest.update(str(path).encode())
        digest.update(path.read_bytes() if path.is_file() else b"missing")
    return digest.hexdigest()[:16]


def zone_map(scenario: Scenario) -> list[ZoneEstimate]:
    """The zones the scenario marks ``known`` (a hazard map), as the team holds them from the
    first tick: each zone's prior ``μ, Σ``, size and persistence, exactly what an attack clue
    reveals (docs/model.md §3), as if broadcast; never its true centre."""
    return [
        estimate
        for k, spec in enumerate(scenario.zones)
        if spec.known
        for estimate in ZoneEstimate.all_from_clue(
            ZoneClue(
                zone_id=k,
                kind=spec.kinds[0],
                mu=np.asarray(spec.mu, dtype=float),
                sigma=np.asarray(spec.sigma, dtype=float),
                size=float(spec.sizes[spec.kinds[0]]),
                persistence=spec.persistence,
                modes=tuple((k, spec.sizes[k]) for k in spec.kinds) if len(spec.kinds) > 1 else (),
            ),
            step=0,
            source="broadcast",
        )
    ]


def prior_estimate(scenario: Scenario, truth: np.ndarray, seed: int) -> TargetEstimate:
    """The prior around the targets' starting states ``truth`` (N, 4), seeded like an episode."""
    spec = scenario.estimator
    std = np.array([spec.initial_position_std] * 2 + [spec.initial_velocity_std] * 2)
    noise = stream(seed, "estimator_init").standard_normal(truth.shape) * std
    return TargetEstimate.initial(
        truth + noise, spec.initial_position_std, spec.initial_velocity_std
    )
