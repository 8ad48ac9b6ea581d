"""The adaptive estimator switched on by evidence (docs/model.md §4.3)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import chi2

from helpers import shipped
from resilient_tracking.belief.on_evidence import AdaptiveOnEvidence, Evidence
from resilient_tracking.build import make_estimator
from resilient_tracking.scenario.overrides import overridden
from resilient_tracking.sim.episode import run_episode

ON_EVIDENCE = {"estimator.type": "adaptive", "estimator.on_evidence": True}


def switches(evidence: Evidence, draws: np.ndarray, channels: int = 2) -> bool:
    return any(evidence.record(nis, channels) for nis in draws)


def test_a_consistent_filter_rarely_triggers_the_switch():
    rng = np.random.default_rng(0)
    runs = 400
    # 300 updates of 3 targets' NIS, each χ² with 2 degrees of freedom: the model is right
    fired = sum(
        switches(Evidence(20, 1e-3), chi2.rvs(2, size=(300, 3), random_state=rng))
        for _ in range(runs)
    )
    # 281 tests a run at 1e-3 each, two-sided, over overlapping windows: about one run in ten
    assert fired / runs < 0.15


@pytest.mark.parametrize("scale", [3.0, 0.3])
def test_innovations_too_large_or_too_small_trigger_the_switch(scale):
    rng = np.random.default_rng(1)
    draws = scale * chi2.rvs(2, size=(40, 3), random_state=rng)
    evidence = Evidence(20, 1e-3)
    assert switches(evidence, draws)
    assert 20 <= evidence.updates <= 40


def test_no_switch_before_the_window_is_full_and_unmeasured_targets_count_for_nothing():
    evidence = Evidence(5, 1e-3)
    for _ in range(4):
        assert not evidence.record(np.array([100.0, np.nan]), 2)
    assert evidence.record(np.array([100.0, np.nan]), 2)  # the fifth update: a full window


def test_until_the_switch_the_team_tracks_with_the_ekf_bit_for_bit():
    # ncv-sensing's targets move as the EKF's model says: no switch in this run
    s = shipped("ncv-sensing").with_overrides(steps=100).with_team("route")
    ekf = run_episode(s, seed=1)
    on_evidence = run_episode(overridden(s, ON_EVIDENCE), seed=1)
    for table in ("team", "targets", "robots"):
        assert ekf[table].equals(on_evidence[table]), table


def test_targets_that_move_otherwise_than_the_model_switch_to_the_adaptive_estimator():
    route = shipped("sensing-temp").with_team("route")
    s = overridden(route, ON_EVIDENCE)
    estimator = make_estimator(s)
    assert isinstance(estimator, AdaptiveOnEvidence) and not estimator.switched
    ekf = run_episode(route, seed=1)
    switched = run_episode(s, seed=1)
    assert not ekf["team"].equals(switched["team"])
    # the same first steps, then another estimate
    first = ekf["team"]["trace"].to_numpy()[:10]
    np.testing.assert_array_equal(first, switched["team"]["trace"].to_numpy()[:10])
