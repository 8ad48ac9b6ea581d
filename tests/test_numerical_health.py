"""Numerical health (docs/reliability.md): covariances SPD, angles wrapped, tables free of NaN."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from helpers import healthy_observation, shipped
from resilient_tracking.belief import health
from resilient_tracking.belief.ekf import ExtendedKalmanFilter
from resilient_tracking.belief.estimate import TargetEstimate
from resilient_tracking.belief.health import is_spd, repair_covariances
from resilient_tracking.belief.team_belief import TeamBelief
from resilient_tracking.models.motion import NearlyConstantVelocity
from resilient_tracking.models.range_bearing import RangeBearingSensor
from resilient_tracking.observation import TeamObservation
from resilient_tracking.sim.episode import run_episode

# ---------------------------------------------------------------------------- repair


def spd_stack(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    a = rng.standard_normal((n, 4, 4))
    cov = a @ np.swapaxes(a, 1, 2) + 0.1 * np.eye(4)
    return 0.5 * (cov + np.swapaxes(cov, 1, 2))


def test_healthy_covariances_come_back_unchanged():
    cov = spd_stack(5, 0)
    out, repairs = repair_covariances(cov)
    assert repairs == [] and np.array_equal(out, cov)


def test_asymmetry_is_symmetrised_and_reported():
    cov = spd_stack(3, 1)
    cov[1, 0, 2] += 1e-3
    out, repairs = repair_covariances(cov)
    assert [(r.index, r.problem) for r in repairs] == [(1, "asymmetric")]
    assert is_spd(out) and np.array_equal(out[0], cov[0])


def test_a_negative_eigenvalue_is_floored_and_reported():
    cov = spd_stack(3, 2)
    eig, vec = np.linalg.eigh(cov[2])
    eig[0] = -0.5
    cov[2] = (vec * eig) @ vec.T
    out, repairs = repair_covariances(cov)
    assert [(r.index, r.problem) for r in repairs] == [(2, "not positive definite")]
    assert repairs[0].min_eigenvalue == pytest.approx(-0.5)
    assert is_spd(out)
    # only the bad direction changed
    assert np.allclose(out[2] @ vec[:, 1:], cov[2] @ vec[:, 1:])


def test_a_non_finite_covariance_is_replaced_by_the_fallback():
    cov = spd_stack(2, 3)
    cov[0, 1, 1] = np.nan
    fallback = np.diag([0.25, 0.25, 0.09, 0.09])
    out, repairs = repair_covariances(cov, fallback=fallback)
    assert [(r.index, r.problem) for r in repairs] == [(0, "not finite")]
    assert np.array_equal(out[0], fallback) and is_spd(out)


@pytest.mark.slow
@settings(max_examples=150, deadline=None)
@given(
    arrays(
        np.float64,
        (3, 4, 4),
        elements=st.floats(-1e6, 1e6, allow_nan=False, allow_infinity=False),
    )
)
def test_any_finite_stack_comes_out_spd(cov):
    out, repairs = repair_covariances(cov)
    assert is_spd(out)
    if not repairs:  # nothing reported: nothing but exact rounding-level symmetrisation
        assert np.allclose(out, cov, rtol=1e-9, atol=1e-9 * max(1.0, np.abs(cov).max()))


@pytest.mark.slow
@settings(max_examples=150, deadline=None)
@given(
    arrays(
        np.float64,
        (3, 4, 4),
        elements=st.floats(-10.0, 10.0, allow_nan=False, allow_infinity=False),
    ),
    st.floats(1e-14, 1e3),
)
def test_the_quick_health_check_agrees_with_the_eigen_decomposition(factor, shift):
    """The Cholesky shortcut for healthy stacks decides as the full check does: same matrices
    out, and no repair it would have reported is skipped (near-singular stacks included)."""
    cov = np.asarray(factor)
    spd = cov @ np.swapaxes(cov, 1, 2) + shift * np.eye(4)  # symmetric, eigenvalues ≥ shift
    for stack in (spd, 0.5 * (spd + np.swapaxes(spd, 1, 2)), cov):
        quick = health._surely_healthy(np.array(stack))
        full, repairs = _full_repair(stack)
        if quick is not None:
            assert not repairs
            np.testing.assert_array_equal(quick, full)


@pytest.mark.parametrize("seed", range(20))
def test_the_quick_health_check_never_skips_a_repair_near_the_floor(seed):
    """Matrices whose smallest eigenvalue sits around the eigen path's floor (relative and
    absolute), alone and in stacks of very unequal scales: whenever the quick check passes a
    stack, the eigen path repairs nothing in it and returns the same matrices."""
    rng = np.random.default_rng(seed)
    vec = np.linalg.qr(rng.standard_normal((3, 4, 4)))[0]
    scale = 10.0 ** rng.uniform(-14, 6, size=3)
    scale[0] = 1.0
    passed = 0
    for factor in (0.3, 0.9, 1.0, 1.1, 2.0, 2.2, 3.0, 10.0, 1e3):
        eig = scale[:, None] * np.array([1.0, 0.5, 0.2, 0.0])
        floor = np.maximum(health.EIGEN_FLOOR_RATIO * scale, health.EIGEN_FLOOR_ABS)
        eig[:, -1] = factor * floor
        stack = (vec * eig[:, None, :]) @ np.swapaxes(vec, 1, 2)
        stack = 0.5 * (stack + np.swapaxes(stack, 1, 2))
        for cov in (stack, stack[:1], stack[1:2], stack[2:]):
            quick = health._surely_healthy(np.array(cov))
            full, repairs = _full_repair(cov)
            if quick is not None:
                passed += 1
                assert not repairs
                np.testing.assert_array_equal(quick, full)
    assert passed > 0  # the comfortable cases do pass


@pytest.mark.parametrize("outer", ["ignore", "warn", "raise"])
def test_the_quick_health_check_answers_as_numpy_cholesky_whatever_the_errstate(outer):
    """The quick check runs LAPACK's Cholesky without np.linalg.cholesky's wrapper: it fails
    a stack exactly where np.linalg.cholesky would, with no warning nor error of its own,
    whatever the caller's floating-point error settings."""
    rng = np.random.default_rng(3)
    factor = rng.standard_normal((3, 4, 4))
    spd = factor @ np.swapaxes(factor, 1, 2) + 0.1 * np.eye(4)
    indefinite = spd.copy()
    indefinite[1] -= 50.0 * np.eye(4)
    for stack in (spd, indefinite):

        def numpy_says(cov=stack):
            try:
                np.linalg.cholesky(cov)
            except np.linalg.LinAlgError:
                return False
            return True

        with warnings.catch_warnings(), np.errstate(all=outer):
            warnings.simplefilter("error")
            quick = health._surely_healthy(np.array(stack))
        assert (quick is not None) == numpy_says()


def test_the_belief_asks_for_a_repair_only_when_the_quick_check_fails(monkeypatch):
    """The belief's tick skips :func:`repair_covariances` for healthy covariances and calls
    it otherwise."""
    calls = []
    original = health.repair_covariances

    def counting(cov, fallback=None):
        calls.append(cov)
        return original(cov, fallback)

    import resilient_tracking.belief.team_belief as team_belief

    monkeypatch.setattr(team_belief, "repair_covariances", counting)
    est = TargetEstimate.initial(np.array([[0.0, 1.0, 0.1, 0.0]]), 0.3, 0.1)
    belief = TeamBelief(
        1, est, ExtendedKalmanFilter(NearlyConstantVelocity(0.1, 0.2), RangeBearingSensor())
    )
    positions, z = np.array([[0.0, 0.0]]), np.full((1, 1, 2), np.nan)
    belief.update(healthy_observation(0, positions, z, np.ones((1, 1), bool)))
    assert calls == []
    belief.estimates[0].cov[0, 0, 0] = -1.0
    assert belief._check_health(1) and len(calls) == 1
    assert is_spd(belief.estimates[0].cov)


def _full_repair(cov):
    original = health._surely_healthy
    health._surely_healthy = lambda c: None
    try:
        return repair_covariances(cov)
    finally:
        health._surely_healthy = original


def test_the_belief_predicts_each_league_once_per_tick():
    """The plan's prediction is the next update's prior: one prediction per league and tick."""
    ekf = ExtendedKalmanFilter(NearlyConstantVelocity(0.1, 0.2), RangeBearingSensor())
    calls, priors = [], []

    class Counting:
        def predict(self, est):
            calls.append(est)
            return ekf.predict(est)

        def update(self, est, robots, z):
            priors.append(est)
            return ekf.update(est, robots, z)

    est = TargetEstimate.initial(np.array([[0.0, 1.0, 0.1, 0.0], [1.0, -1.0, 0.0, 0.2]]), 0.3, 0.1)
    belief = TeamBelief(2, est, Counting())
    positions = np.array([[0.0, 0.0], [1.0, 0.5]])
    z = np.full((2, 2, 2), np.nan)

    def tick(step: int) -> TeamObservation:
        return healthy_observation(step, positions, z, np.ones((2, 2), bool))

    for step in range(3):
        belief.update(tick(step))
        planned = belief.predicted(0)
        assert belief.predicted(0) is planned  # asked again: the same prediction
        assert len(calls) == step + 1
    # what the next tick starts from is exactly the prediction the plan used
    belief.update(tick(3))
    assert priors[-1] is planned
    assert len(calls) == 3
    again = ekf.predict(calls[-1].copy())  # the same numbers as a prediction made anew
    np.testing.assert_array_equal(planned.mean, again.mean)
    np.testing.assert_array_equal(planned.cov, again.cov)


def test_a_drifted_estimate_is_repaired_with_an_event(monkeypatch):
    """Corrupt one EKF output mid-run: the belief repairs it and events.parquet says so."""
    original = ExtendedKalmanFilter.update
    calls = {"n": 0}

    def drifting_update(self, est, robots, z, nis_out=None):
        out = original(self, est, robots, z, nis_out)
        calls["n"] += 1
        if calls["n"] == 40:
            cov = out.cov.copy()
            cov[1, 0, 0] = -0.2  # no longer positive definite
            cov[1, 2, 3] += 0.05  # and asymmetric
            return TargetEstimate(out.mean, cov)
        return out

    monkeypatch.setattr(ExtendedKalmanFilter, "update", drifting_update)
    route = shipped("sensing-temp").with_overrides(steps=60).with_team("route")  # the EKF
    result = run_episode(route, seed=1)
    events = result["events"]
    repaired = events[events["event"] == "covariance_repaired"]
    assert len(repaired) == 1
    assert (
        repaired["step"].iloc[0] == 39
        and "target 1: not positive definite" in (repaired["detail"].iloc[0])
    )
    targets = result["targets"]
    assert np.all(targets[["var_x", "var_y"]].to_numpy() > 0)


LONG_RUNS = [
    ("combined-perm", "failure_aware", 3, 700),
    ("comm-temp", "failure_aware", 4, 700),
    ("sensing-perm", "vanilla", 5, 700),
]


@pytest.mark.slow
@pytest.mark.parametrize(("name", "policy", "seed", "steps"), LONG_RUNS)
def test_long_runs_stay_spd_wrapped_and_finite(monkeypatch, name, policy, seed, steps):
    seen = {"ticks": 0, "matrices": 0, "bearings": 0, "min_eig": math.inf}
    original = TeamBelief.update

    def checking_update(self, obs):
        events = original(self, obs)
        for est in self.estimates:
            assert is_spd(est.cov), f"step {obs.step}: covariance not SPD"
            assert np.all(np.isfinite(est.mean)), f"step {obs.step}: mean not finite"
            seen["matrices"] += len(est.cov)
            seen["min_eig"] = min(seen["min_eig"], float(np.linalg.eigvalsh(est.cov).min()))
        bearings = obs.measurements[..., 1]
        bearings = bearings[np.isfinite(bearings)]
        assert np.all((bearings >= -np.pi) & (bearings < np.pi)), "bearing not wrapped"
        seen["bearings"] += bearings.size
        seen["ticks"] += 1
        return events

    monkeypatch.setattr(TeamBelief, "update", checking_update)
    result = run_episode(shipped(name).with_overrides(steps=steps), policy=policy, seed=seed)
    assert seen["ticks"] == steps and seen["bearings"] > steps
    assert seen["min_eig"] > 0
    for table_name, table in result.tables.items():
        numbers = table.select_dtypes("number").to_numpy(dtype=float)
        assert np.all(np.isfinite(numbers)), table_name
        text = table.select_dtypes(exclude="number")
        for column in text.columns:
            assert not text[column].isna().any(), (table_name, column)
    # drift would have been repaired, and logged; the filter does not drift in these runs
    assert (result["events"]["event"] == "covariance_repaired").sum() == 0
