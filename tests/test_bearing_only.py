"""BearingOnlySensor (docs/model.md §1): measurement, Jacobian, noise and planning information
against finite differences, EKF consistency when several robots triangulate, and whole
episodes of the shipped ``bearing-only`` scenario."""

from __future__ import annotations

import json
from dataclasses import replace

import casadi as ca
import numpy as np
import pandas as pd
import pytest
from scipy.stats import chi2

from helpers import SCENARIOS, shipped
from resilient_tracking.belief.ekf import ExtendedKalmanFilter
from resilient_tracking.belief.estimate import TargetEstimate
from resilient_tracking.build import make_policy, team_config
from resilient_tracking.cli import main
from resilient_tracking.models.bearing_only import BearingOnlySensor
from resilient_tracking.models.motion import NearlyConstantVelocity
from resilient_tracking.models.sensor import SENSORS, wrap_angle
from resilient_tracking.sim.episode import run_episode
from resilient_tracking.world.world import World

SENSOR = BearingOnlySensor(bearing_peak=40.0, bearing_shape=0.3)


def _points(seed: int, n: int = 8) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    robots = rng.uniform(-3, 3, size=(n, 2))
    return robots, robots + rng.uniform(0.5, 3, size=(n, 1)) * rng.normal(size=(n, 2))


# --------------------------------------------------------------------------- scenario


def test_the_sensor_type_picks_the_bearing_only_sensor():
    scenario = shipped("bearing-only")
    assert scenario.sensor.type == "bearing_only"
    assert SENSORS.get("bearing_only") is BearingOnlySensor
    sensor = team_config(scenario).sensor
    assert sensor == BearingOnlySensor(bearing_peak=60.0, bearing_shape=0.2)
    assert make_policy("vanilla", scenario).config.sensor == sensor
    obs = World(scenario, 1).observe()
    assert obs.measurements.shape == (3, 3, 1)
    targets = np.array([t.start for t in scenario.targets])
    bearing = sensor.predict(obs.positions[:, None], targets[None])
    assert np.abs(wrap_angle(obs.measurements - bearing)).max() < 1.0


def test_max_range_leaves_far_targets_unmeasured():
    data = shipped("bearing-only").model_dump(mode="json")
    data["sensor"]["max_range"] = 0.6
    from resilient_tracking.scenario import parse_scenario

    obs = World(parse_scenario(data), 1).observe()
    targets = np.array([t["start"] for t in data["targets"]])
    far = np.linalg.norm(obs.positions[:, None] - targets[None], axis=-1) > 0.6
    assert far.any() and (~far).any()
    np.testing.assert_array_equal(np.isnan(obs.measurements[..., 0]), far)


# --------------------------------------------------------------------------- measurement model


def test_measurement_and_jacobian_match_finite_differences():
    robots, targets = _points(1)
    z = SENSOR.predict(robots, targets)
    delta = targets - robots
    np.testing.assert_allclose(z[:, 0], np.arctan2(delta[:, 1], delta[:, 0]))
    jac = SENSOR.jacobian(robots, targets)
    assert jac.shape == (len(robots), 1, 2)
    h = 1e-6
    for axis in range(2):
        step = np.zeros(2)
        step[axis] = h
        numeric = wrap_angle(SENSOR.predict(robots, targets + step) - z) / h
        np.testing.assert_allclose(jac[:, 0, axis], numeric[:, 0], rtol=1e-5, atol=1e-6)


def test_noise_follows_the_distance_not_the_measurement():
    robots, targets = _points(2)
    z = SENSOR.predict(robots, targets)
    distance = SENSOR.noise_distance(robots, targets, z)
    np.testing.assert_allclose(distance, np.linalg.norm(targets - robots, axis=-1))
    np.testing.assert_allclose(
        SENSOR.noise_variance(distance)[:, 0], np.exp(0.3 * distance) / 40.0, rtol=1e-14
    )


def test_sampled_bearings_are_wrapped_with_the_declared_variance():
    rng = np.random.default_rng(3)
    sensor = BearingOnlySensor(bearing_peak=4.0, bearing_shape=0.2)  # std ≈ 0.6 rad at 2 m
    robot, target = np.zeros((20_000, 2)), np.tile([-2.0, 1e-3], (20_000, 1))  # bearing ≈ π
    z = sensor.sample(robot, target, rng)
    assert z.shape == (20_000, 1)
    assert (z >= -np.pi).all() and (z < np.pi).all() and (z < 0).any()
    residual = wrap_angle(z - sensor.predict(robot, target))[:, 0]
    variance = sensor.noise_variance(2.0)[0]
    n = len(residual)
    lo, hi = chi2.ppf([0.0005, 0.9995], n) / n * variance
    assert lo <= float(np.mean(residual**2)) <= hi


# --------------------------------------------------------------------------- information


def test_information_is_the_jacobian_weighted_by_the_inverse_noise():
    robots, targets = _points(4)
    info = SENSOR.information(robots, targets, eps=0.0)
    jac = SENSOR.jacobian(robots, targets)[:, 0]
    rinv = 1.0 / SENSOR.noise_variance(np.linalg.norm(targets - robots, axis=-1))[:, 0]
    outer = rinv[:, None, None] * jac[:, :, None] * jac[:, None, :]
    expected = np.stack([outer[:, 0, 0], outer[:, 0, 1], outer[:, 1, 1]], axis=-1)
    np.testing.assert_allclose(info, expected, rtol=1e-12)


def _hand_derivatives():
    x, p, params = ca.SX.sym("x", 2), ca.SX.sym("p", 2), ca.SX.sym("s", 2)
    m = ca.vertcat(*BearingOnlySensor.information_casadi(x, p, params))
    return (
        ca.Function("m", [x, p, params], [m]),
        ca.Function(
            "hand",
            [x, p, params],
            list(BearingOnlySensor.information_derivatives_casadi(x, p, params)),
        ),
    )


def test_information_derivatives_match_finite_differences():
    """The hand-derived ``∂m/∂x`` and ``∂²m/∂x²`` the planners use, against central differences
    of the NumPy information (first) and of the hand Jacobian (second)."""
    casadi_m, hand = _hand_derivatives()
    robots, targets = _points(5)
    targets[0] = robots[0] + 1e-3  # next to the target: the regularised model stays smooth
    params = SENSOR.parameters
    h = 1e-5
    for x, p in zip(robots, targets, strict=True):
        m, jac, hess = (v.full() for v in hand(x, p, params))
        np.testing.assert_allclose(m[:, 0], SENSOR.information(x, p), rtol=1e-12)
        np.testing.assert_allclose(casadi_m(x, p, params).full(), m, rtol=1e-12)
        scale = np.abs(m).max()
        for a in range(2):
            step = np.zeros(2)
            step[a] = h
            numeric = (SENSOR.information(x + step, p) - SENSOR.information(x - step, p)) / (2 * h)
            np.testing.assert_allclose(jac[:, a], numeric, rtol=1e-5, atol=1e-6 * scale)
            numeric_hess = (hand(x + step, p, params)[1] - hand(x - step, p, params)[1]).full() / (
                2 * h
            )
            # row r of hess holds ∂²m_r/∂x² as [xx, xy, yy]
            for b in range(2):
                column = 2 if (a, b) == (1, 1) else a + b
                np.testing.assert_allclose(
                    hess[:, column], numeric_hess[:, b], rtol=1e-5, atol=1e-5 * scale
                )


# --------------------------------------------------------------------------- EKF consistency
#
# N independent targets share one filter, each an independent Monte-Carlo run, seen by four
# robots around them, so that the bearings triangulate; tens of metres away, the filter works
# in its near-linear regime (the test checks the filter, not the limits of linearisation).

CONSISTENCY_SENSOR = BearingOnlySensor(bearing_peak=2000.0, bearing_shape=0.05)
ROBOTS = 40.0 * np.array([[np.cos(a), np.sin(a)] for a in 0.3 + np.arange(4) * np.pi / 2])
DT, ACCEL_STD, LEVEL = 0.1, 0.005, 0.99


def _simulate(steps: int, n_targets: int, seed: int, filter_sensor: BearingOnlySensor):
    model = NearlyConstantVelocity(dt=DT, accel_std=ACCEL_STD)
    ekf = ExtendedKalmanFilter(model, filter_sensor)
    rng = np.random.default_rng(seed)
    chol_q = np.linalg.cholesky(model.process_noise)
    pos_std, vel_std = 0.5, 0.2
    x = np.zeros((n_targets, 4))
    est = TargetEstimate.initial(
        x + rng.standard_normal(x.shape) * [pos_std, pos_std, vel_std, vel_std], pos_std, vel_std
    )
    nees = np.empty((steps, n_targets))
    joint, dof = np.empty((steps, n_targets)), np.empty((steps, n_targets), dtype=int)
    for t in range(steps):
        x = x @ model.transition.T + rng.standard_normal(x.shape) @ chol_q.T
        est = ekf.predict(est)
        z = CONSISTENCY_SENSOR.sample(ROBOTS[:, None, :], x[None, :, :2], rng)
        res = ekf.update_detailed(est, ROBOTS, z)
        est = res.estimate
        err = x - est.mean
        nees[t] = np.einsum("ni,ni->n", err, np.linalg.solve(est.cov, err[..., None])[..., 0])
        joint[t], dof[t] = res.joint_nis, res.dof
    return nees, joint, dof


def _nees_ok(nees: np.ndarray) -> bool:
    """Time-averaged NEES in the conservative single-step interval χ²(4N)/N (tests/test_ekf.py)."""
    n = nees.shape[1]
    lo, hi = chi2.ppf([(1 - LEVEL) / 2, (1 + LEVEL) / 2], 4 * n) / n
    return bool(lo <= nees.mean() <= hi)


def _joint_nis_ok(joint: np.ndarray, dof: np.ndarray) -> bool:
    """White innovations, independent targets: Σ NIS ~ χ²(Σ dof)."""
    lo, hi = chi2.ppf([(1 - LEVEL) / 2, (1 + LEVEL) / 2], int(dof.sum()))
    return bool(lo <= float(np.nansum(joint)) <= hi)


def test_ekf_with_bearings_from_several_robots_is_consistent():
    nees, joint, dof = _simulate(1500, 100, 20240601, CONSISTENCY_SENSOR)
    assert np.all(dof == len(ROBOTS))  # one channel per robot
    assert _nees_ok(nees), nees.mean()
    assert _joint_nis_ok(joint, dof), np.nanmean(joint)


def test_an_overconfident_bearing_filter_fails_the_consistency_check():
    overconfident = replace(CONSISTENCY_SENSOR, bearing_peak=8000.0)  # believes 2× the precision
    nees, joint, dof = _simulate(500, 50, 7, overconfident)
    assert not _joint_nis_ok(joint, dof)
    assert not _nees_ok(nees)


# --------------------------------------------------------------------------- episodes


@pytest.mark.parametrize("policy", ["failure_aware", "vanilla"])
def test_a_bearing_only_mission_is_planned_and_tracked(policy):
    base = shipped("bearing-only")
    # vanilla walks into the zone and loses every sensor (as it does with range-bearing
    # sensors): it is held to tracking on the mission without the zone
    scenario = base.with_overrides(zones=[]) if policy == "vanilla" else base
    result = run_episode(scenario, policy=policy)
    team = result["team"]
    assert len(team) == base.steps and (team["n_solves"] > 0).all()
    for name in ("team", "robots", "targets"):
        assert np.isfinite(result[name].select_dtypes("number").to_numpy()).all(), name
    initial = team["trace"].iloc[0]
    assert team["trace"].max() < 2 * initial  # the estimate never runs away
    assert team["trace"].iloc[-50:].mean() < initial / 4  # triangulation keeps it small
    assert team["mse"].iloc[-50:].mean() < 0.01


def test_the_sog_program_plans_with_bearings():
    result = run_episode(shipped("bearing-only").with_overrides(steps=40), policy="sog")
    team = result["team"]
    assert (team["n_solves"] > 0).all() and team["n_solver_failures"].sum() == 0
    assert np.isfinite(team[["mse", "trace"]].to_numpy()).all()
    assert team["trace"].max() < 2 * team["trace"].iloc[0]


def test_rtrack_runs_the_bearing_only_scenario(tmp_path, capsys):
    out = tmp_path / "run"
    scenario = SCENARIOS / "bearing-only.yaml"
    assert main(["run", str(scenario), "--steps", "20", "--out", str(out), "-q"]) == 0
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["scenario"]["sensor"]["type"] == "bearing_only"
    assert len(pd.read_parquet(out / "team.parquet")) == 20
