"""RangeBearingSensor: Jacobian, noise model and sampled noise statistics (docs/model.md §1)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import chi2

from resilient_tracking.models.range_bearing import RangeBearingSensor
from resilient_tracking.models.sensor import wrap_angle


def _numerical_jacobian(sensor: RangeBearingSensor, robot, target, eps: float = 1e-6):
    jac = np.zeros((2, 2))
    for i in range(2):
        step = np.zeros(2)
        step[i] = eps
        plus = sensor.predict(robot, target + step)
        minus = sensor.predict(robot, target - step)
        diff = plus - minus
        diff[1] = wrap_angle(diff[1])  # the bearing may jump across ±π between the two points
        jac[:, i] = diff / (2 * eps)
    return jac


@pytest.mark.parametrize("seed", range(10))
def test_jacobian_matches_central_differences(seed: int) -> None:
    rng = np.random.default_rng(seed)
    sensor = RangeBearingSensor()
    for _ in range(20):
        robot = rng.uniform(-20, 20, size=2)
        target = robot + rng.uniform(0.5, 30) * np.array(
            [np.cos(a := rng.uniform(-np.pi, np.pi)), np.sin(a)]
        )
        analytic = sensor.jacobian(robot, target)
        numeric = _numerical_jacobian(sensor, robot, target)
        np.testing.assert_allclose(analytic, numeric, rtol=1e-6, atol=1e-8)


@pytest.mark.parametrize("dy", [1e-9, -1e-9, 0.0])
def test_jacobian_across_bearing_wrap(dy: float) -> None:
    """Target straight behind (bearing ≈ ±π): finite differences straddle the wrap."""
    sensor = RangeBearingSensor()
    robot = np.array([1.0, 2.0])
    target = robot + np.array([-7.0, dy])
    numeric = _numerical_jacobian(sensor, robot, target)
    np.testing.assert_allclose(sensor.jacobian(robot, target), numeric, rtol=1e-6, atol=1e-8)
    # Without the wrap the bearing derivative would be ~2π/(2·eps): make sure we exercised it.
    assert abs(numeric[1, 1]) < 1.0


def test_noise_variance_is_exp_shape_d_over_peak() -> None:
    sensor = RangeBearingSensor(
        range_peak=12.0, range_shape=0.3, bearing_peak=40.0, bearing_shape=0.1
    )
    d = np.array([0.0, 1.0, 5.0, 17.5])
    var = sensor.noise_variance(d)
    assert var.shape == (4, 2)
    np.testing.assert_allclose(var[:, 0], np.exp(0.3 * d) / 12.0, rtol=1e-14)
    np.testing.assert_allclose(var[:, 1], np.exp(0.1 * d) / 40.0, rtol=1e-14)
    # Inverse variance is peak · exp(−shape · d) (paper eq. 2).
    np.testing.assert_allclose(1.0 / var[:, 0], 12.0 * np.exp(-0.3 * d), rtol=1e-14)
    scalar = sensor.noise_variance(2.0)
    np.testing.assert_allclose(scalar, [np.exp(0.6) / 12.0, np.exp(0.2) / 40.0], rtol=1e-14)


def _variance_consistent(residuals: np.ndarray, variance: float, alpha: float = 1e-3) -> bool:
    """Two-sided χ² test of ``Var = variance`` for zero-mean Gaussian residuals."""
    n = residuals.size
    stat = float(np.sum(residuals**2) / variance)
    lo, hi = chi2.ppf([alpha / 2, 1 - alpha / 2], n)
    return bool(lo <= stat <= hi)


def _buggy_sample(sensor: RangeBearingSensor, robot, target, rng) -> np.ndarray:
    """The classic bug: the variance used as the standard deviation."""
    clean = sensor.predict(robot, target)
    std = sensor.noise_variance(clean[..., 0])  # wrong on purpose
    z = clean + std * rng.standard_normal(clean.shape)
    z[..., 1] = wrap_angle(z[..., 1])
    return z


# Distances where variance and standard deviation differ a lot (variance ≈ 3.6, 0.067, 0.018…).
SAMPLE_CASES = [
    (RangeBearingSensor(), 20.0, 0),  # range variance e⁴/15 ≈ 3.64
    (RangeBearingSensor(), 0.5, 0),  # range variance ≈ 0.074
    (RangeBearingSensor(bearing_peak=400.0), 10.0, 1),  # bearing variance e²/400 ≈ 0.018
    (RangeBearingSensor(bearing_peak=60.0), 3.0, 1),  # bearing variance ≈ 0.030
]


@pytest.mark.parametrize(("sensor", "distance", "channel"), SAMPLE_CASES)
def test_sample_variance_matches_noise_variance(
    sensor: RangeBearingSensor, distance: float, channel: int
) -> None:
    rng = np.random.default_rng(1234 + channel)
    n = 20_000
    robot = np.array([3.0, -1.0])
    angle = 2.9  # bearing close to π, so wrapping matters for the residuals
    target = robot + distance * np.array([np.cos(angle), np.sin(angle)])
    targets = np.repeat(target[None, :], n, axis=0)
    clean = sensor.predict(robot, target)
    expected = float(sensor.noise_variance(distance)[channel])

    z = sensor.sample(robot, targets, rng)
    assert z.shape == (n, 2)
    assert np.all(z[:, 1] >= -np.pi) and np.all(z[:, 1] < np.pi)
    residual = z[:, channel] - clean[channel]
    if channel == 1:
        residual = np.asarray(wrap_angle(residual))
    assert _variance_consistent(residual, expected)
    # Unbiased: |mean| within 4 standard errors.
    assert abs(residual.mean()) < 4 * np.sqrt(expected / n)

    # The same check rejects a sampler that uses the variance as standard deviation.
    bad = _buggy_sample(sensor, robot, targets, rng)
    bad_residual = bad[:, channel] - clean[channel]
    if channel == 1:
        bad_residual = np.asarray(wrap_angle(bad_residual))
    assert not _variance_consistent(bad_residual, expected)


def test_sample_is_reproducible_and_independent_per_channel() -> None:
    sensor = RangeBearingSensor(bearing_peak=200.0)
    robot = np.zeros(2)
    targets = np.repeat(np.array([[4.0, 3.0]]), 20_000, axis=0)
    a = sensor.sample(robot, targets, np.random.default_rng(7))
    b = sensor.sample(robot, targets, np.random.default_rng(7))
    np.testing.assert_array_equal(a, b)
    clean = sensor.predict(robot, targets[0])
    res = a - clean
    res[:, 1] = wrap_angle(res[:, 1])
    corr = np.corrcoef(res[:, 0], res[:, 1])[0, 1]
    assert abs(corr) < 4 / np.sqrt(len(res))


def test_information_numpy_and_casadi_forms_agree_with_their_derivatives():
    """The measurement model's information ``Hᵀ R⁻¹ H`` in NumPy, in CasADi, and the
    hand-derived derivatives the league NLP uses, against CasADi's differentiation."""
    import casadi as ca

    sensor = RangeBearingSensor(range_peak=12.0, range_shape=0.3, bearing_peak=9.0)
    rng = np.random.default_rng(5)
    robots, targets = rng.normal(size=(6, 2)) * 2, rng.normal(size=(6, 2)) * 2
    targets[0] = robots[0]  # on the target: the regularised model stays finite
    numeric = sensor.information(robots, targets)
    x, p, params = ca.SX.sym("x", 2), ca.SX.sym("p", 2), ca.SX.sym("s", sensor.N_PARAMETERS)
    m = ca.vertcat(*RangeBearingSensor.information_casadi(x, p, params))
    m_hand, jac_hand, hess_hand = RangeBearingSensor.information_derivatives_casadi(x, p, params)
    hessians = [ca.hessian(m[r], x)[0] for r in range(3)]
    reference = ca.Function(
        "ref",
        [x, p, params],
        [m, ca.jacobian(m, x), *[ca.vertcat(h[0, 0], h[0, 1], h[1, 1]) for h in hessians]],
    )
    hand = ca.Function("hand", [x, p, params], [m_hand, jac_hand, hess_hand])
    for k in range(len(robots)):
        m_ref, jac_ref, *hess_ref = (
            v.full() for v in reference(robots[k], targets[k], sensor.parameters)
        )
        m_h, jac_h, hess_h = (v.full() for v in hand(robots[k], targets[k], sensor.parameters))
        np.testing.assert_allclose(numeric[k], m_ref.ravel(), rtol=1e-12)
        np.testing.assert_allclose(m_h, m_ref, rtol=1e-12)
        np.testing.assert_allclose(jac_h, jac_ref, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(hess_h, np.hstack(hess_ref).T, rtol=1e-8, atol=1e-8)


def test_information_is_jacobian_weighted_by_inverse_noise_away_from_the_target():
    """Far from the regularisation, ``Hᵀ R⁻¹ H`` is the filter's Jacobian and noise model."""
    sensor = RangeBearingSensor(max_range=None)
    robot, target = np.array([0.3, -1.0]), np.array([4.0, 2.5])
    h = sensor.jacobian(robot, target)
    rinv = 1.0 / sensor.noise_variance(np.linalg.norm(target - robot))
    info = h.T @ np.diag(rinv) @ h
    expected = np.array([info[0, 0], info[0, 1], info[1, 1]])
    np.testing.assert_allclose(sensor.information(robot, target), expected, rtol=1e-3)


@pytest.mark.parametrize("seed", range(3))
def test_hessians_match_central_differences_of_the_jacobian(seed: int) -> None:
    """The closed-form range and bearing Hessians (range-bearing and bearing-only) against
    the generic default, central differences of the Jacobian; both symmetric."""
    from resilient_tracking.models.bearing_only import BearingOnlySensor
    from resilient_tracking.models.sensor import MeasurementModel

    rng = np.random.default_rng(seed)
    robots = rng.normal(size=(5, 1, 2)) * 2.0
    targets = rng.normal(size=(1, 4, 2)) * 2.0
    for sensor, dim in ((RangeBearingSensor(), 2), (BearingOnlySensor(), 1)):
        exact = sensor.hessian(robots, targets)
        assert exact.shape == (5, 4, dim, 2, 2)
        numeric = MeasurementModel.hessian(sensor, robots, targets)
        np.testing.assert_allclose(exact, numeric, rtol=1e-5, atol=1e-6)
        np.testing.assert_array_equal(exact, np.swapaxes(exact, -1, -2))
    # the bearing's Hessian is the one of the bearing-only sensor
    np.testing.assert_array_equal(
        RangeBearingSensor().hessian(robots, targets)[..., 1, :, :],
        BearingOnlySensor().hessian(robots, targets)[..., 0, :, :],
    )


def test_linearise_gives_the_bits_of_predict_jacobian_and_noise_variance():

    rng = np.random.default_rng(0)
    robots, targets = rng.uniform(-5, 5, (4, 1, 2)), rng.uniform(-5, 5, (1, 3, 2))
    targets[0, 0] = robots[1, 0]  # a target on a robot: the clamped distance

    class Shifted(RangeBearingSensor):
        """A subclass with its own prediction: linearise must use it."""

        def predict(self, robot, target):
            return super().predict(robot, target) + 1.0

    for sensor in (RangeBearingSensor(range_shape=0.3, max_range=4.0), Shifted()):
        h, jacobian, variance = sensor.linearise(robots, targets)
        expected_h = sensor.predict(robots, targets)
        assert np.array_equal(h, expected_h)
        assert np.array_equal(jacobian, sensor.jacobian(robots, targets))
        noise = sensor.noise_variance(sensor.noise_distance(robots, targets, expected_h))
        assert np.array_equal(variance, noise)


def test_sample_fast_path_is_the_general_one() -> None:
    """RangeBearingSensor.sample inlines predict, noise_variance and wrap_angle: the same
    numbers and draws as the general path a subclass takes."""

    class Same(RangeBearingSensor):  # a subclass: the general path
        def noise_variance(self, distance):  # type: ignore[no-untyped-def]
            return super().noise_variance(distance)

    fast = RangeBearingSensor(
        range_peak=15.0, range_shape=0.3, bearing_peak=20.0, bearing_shape=0.1
    )
    slow = Same(range_peak=15.0, range_shape=0.3, bearing_peak=20.0, bearing_shape=0.1)
    assert fast._own_sample and not slow._own_sample
    src = np.random.default_rng(7)
    for _ in range(50):
        robots, targets = src.uniform(-5, 5, (3, 1, 2)), src.uniform(-5, 5, (1, 4, 2))
        targets[0, 0] = robots[0, 0]  # zero range
        for r, t in ((robots, targets), (robots[1, 0], targets[0, 2])):
            a = fast.sample(r, t, np.random.default_rng(1))
            b = slow.sample(r, t, np.random.default_rng(1))
            assert a.shape == b.shape and a.tobytes() == b.tobytes()
