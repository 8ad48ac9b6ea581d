"""World truth: zone centers, random streams, controls, targets, noise (docs/model.md §1)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from resilient_tracking.scenario import parse_scenario
from resilient_tracking.world import World

STILL = {"type": "constant_velocity", "velocity": [0.0, 0.0]}

SIGMA_S = [[2.0, 0.6], [0.6, 0.5]]
SIGMA_C = [[0.3, -0.2], [-0.2, 0.8]]
ZONES = [
    {"kind": "sensing", "mu": [1.0, -2.0], "sigma": SIGMA_S, "radius": 0.5},
    {"kind": "comm", "mu": [-1.5, 0.5], "sigma": SIGMA_C, "delta2": 0.1},
]


def scenario(
    robots: list[list[float]] | np.ndarray,
    targets: list[dict[str, Any]] | None = None,
    zones: list[dict[str, Any]] | None = None,
    u_max: float | list[float] = 1.0,
    **extra: Any,
) -> Any:
    u = u_max if isinstance(u_max, list) else [u_max] * len(robots)
    data: dict[str, Any] = {
        "dt": 0.1,
        "robots": [
            {"start": [float(p[0]), float(p[1])], "u_max": um}
            for p, um in zip(robots, u, strict=True)
        ],
        "targets": targets or [{"start": [3.0, 3.0], "motion": STILL}],
        "zones": zones or [],
        **extra,
    }
    return parse_scenario(data)


def target_world(motion: dict[str, Any], start: list[float], seed: int = 0, **extra: Any) -> World:
    return World(scenario([[0.0, 0.0]], [{"start": start, "motion": motion}], **extra), seed)


# ---------------------------------------------------------------------------- zone centers


@pytest.mark.slow
def test_zone_centers_drawn_from_prior() -> None:
    sc = scenario([[0.0, 0.0]], zones=ZONES)
    n = 1500
    centers = np.array([[z.center for z in World(sc, seed).zones] for seed in range(n)])
    for k, zone in enumerate(ZONES):
        mu = np.array(zone["mu"])
        sigma = np.array(zone["sigma"])
        sample = centers[:, k]
        mean_err = np.abs(sample.mean(axis=0) - mu)
        assert (mean_err <= 4 * np.sqrt(np.diag(sigma) / n)).all(), (k, sample.mean(axis=0))
        cov = np.cov(sample.T)
        # Standard error of a sample covariance entry: sqrt((Σii Σjj + Σij²) / n).
        se = np.sqrt((np.outer(np.diag(sigma), np.diag(sigma)) + sigma**2) / n)
        assert (np.abs(cov - sigma) <= 4 * se).all(), (k, cov)


def test_zone_centers_reproducible_and_seed_dependent() -> None:
    sc = scenario([[0.0, 0.0]], zones=ZONES)
    a = [z.center for z in World(sc, 42).zones]
    b = [z.center for z in World(sc, 42).zones]
    c = [z.center for z in World(sc, 43).zones]
    for za, zb, zc in zip(a, b, c, strict=True):
        np.testing.assert_array_equal(za, zb)
        assert not np.allclose(za, zc)
    # Zones' true centers do not depend on the robots, the targets or anything that happens.
    other = scenario(
        [[1.0, 1.0], [-2.0, 0.5], [0.0, -3.0]],
        [{"start": [0.0, 0.0], "motion": {"type": "ncv", "accel_std": 0.5}}] * 2,
        zones=ZONES,
    )
    world = World(other, 42)
    for _ in range(20):
        world.step(np.ones((3, 2)))
        world.observe()
    for za, zone in zip(a, world.zones, strict=True):
        np.testing.assert_array_equal(za, zone.center)


# ---------------------------------------------------------------------------- stream independence

HOT_ZONE = {
    "kind": "sensing",
    "mu": [0.0, 0.0],
    "sigma": [[0.25, 0.0], [0.0, 0.25]],
    "radius": 0.3,
    "m_recover": 0.5,
    "hazard": {"model": "gaussian", "kappa": 15.0},
}


def attack_history(world: World, mover: np.ndarray, observe_every: int, steps: int) -> list[Any]:
    """Robot 0 held still; robot 1 moves with ``mover``; robot 0's failure after each step."""
    history = []
    controls = np.zeros((2, 2))
    for k in range(steps):
        controls[1] = mover[k]
        world.step(controls)
        if k % observe_every == 0:
            world.observe()
        f = world.failures["sensing"][0]
        history.append(None if f is None else (f.since_step, f.zone_id))
    return history


def test_attack_draws_independent_of_measurements_and_other_robots() -> None:
    steps = 300
    rng = np.random.default_rng(0)
    a = World(scenario([[0.5, 0.0], [2.0, 2.0]], zones=[HOT_ZONE]), 9)
    b_targets = [{"start": [3.0, 3.0], "motion": STILL}, {"start": [-3.0, 1.0], "motion": STILL}]
    b = World(scenario([[0.5, 0.0], [-2.0, -2.0]], b_targets, zones=[HOT_ZONE]), 9)
    hist_a = attack_history(a, rng.uniform(-1, 1, (steps, 2)), 1, steps)
    hist_b = attack_history(b, rng.uniform(-1, 1, (steps, 2)), 3, steps)
    assert not np.allclose(a.robot_positions[1], b.robot_positions[1])
    n_failed = sum(h is not None for h in hist_a)
    assert 10 < n_failed < steps - 10  # robot 0 is attacked, and recovers, many times
    assert hist_a == hist_b


def test_measurement_noise_aligned_across_robot_motion() -> None:
    # Standardised range residuals are the same draws whatever the robots do.
    sc = scenario([[0.0, 0.0], [1.0, -1.0]], [{"start": [2.0, 1.0], "motion": STILL}])
    a, b = World(sc, 4), World(sc, 4)
    rng = np.random.default_rng(1)
    for _ in range(50):
        a.step(rng.uniform(-1, 1, (2, 2)))
        b.step(rng.uniform(-1, 1, (2, 2)))
        za, zb = a.observe().measurements, b.observe().measurements
        res = []
        for world, z in ((a, za), (b, zb)):
            d = np.linalg.norm(world.robot_positions - world.target_states[0, :2], axis=1)
            var = world.sensor.noise_variance(d)[:, 0]
            res.append((z[:, 0, 0] - d) / np.sqrt(var))
        np.testing.assert_allclose(res[0], res[1], rtol=1e-9, atol=1e-9)
    assert not np.allclose(a.robot_positions, b.robot_positions)


def test_target_motion_independent_of_robots_and_observation() -> None:
    targets = [{"start": [0.0, 0.0], "motion": {"type": "ncv", "accel_std": 0.5}}]
    a = World(scenario([[1.0, 1.0]], targets), 2)
    b = World(scenario([[-1.0, 2.0], [2.0, 2.0]], targets, zones=[HOT_ZONE]), 2)
    for k in range(100):
        a.step(np.ones((1, 2)))
        b.step(-np.ones((2, 2)))
        if k % 2:
            a.observe()
        np.testing.assert_array_equal(a.target_states, b.target_states)


# ---------------------------------------------------------------------------- controls


def test_controls_clipped_per_component_to_each_robot_u_max() -> None:
    world = World(scenario([[0.0, 0.0], [1.0, 1.0]], u_max=[0.5, 2.0]), 0)
    applied = world.step(np.array([[10.0, 0.1], [-10.0, 1.5]]))
    # Per component (a box), not a norm bound.
    np.testing.assert_allclose(applied, [[0.5, 0.1], [-2.0, 1.5]])
    np.testing.assert_allclose(world.robot_positions, [[0.05, 0.01], [0.8, 1.15]])


def test_a_robot_with_a_control_that_is_not_finite_holds_position_with_a_warning(caplog) -> None:
    world = World(scenario([[0.0, 0.0], [1.0, 1.0]], u_max=[0.5, 2.0]), 0)
    applied = world.step(np.array([[np.nan, -3.0], [np.inf, 1.0]]))
    np.testing.assert_array_equal(applied, [[0.0, 0.0], [0.0, 0.0]])  # neither clipped nor half
    np.testing.assert_array_equal(world.robot_positions, [[0.0, 0.0], [1.0, 1.0]])
    assert "controls of robots [0, 1] are not finite; they hold position" in caplog.text
    applied = world.step(np.array([[0.1, 0.1], [-np.inf, 0.2]]))
    np.testing.assert_allclose(applied, [[0.1, 0.1], [0.0, 0.0]])


def test_controls_of_another_shape_are_refused() -> None:
    world = World(scenario([[0.0, 0.0], [1.0, 1.0]]), 0)
    with pytest.raises(ValueError, match=r"controls have shape \(3, 2\), expected \(2, 2\)"):
        world.step(np.zeros((3, 2)))
    assert world.step_index == 0


def test_positions_stay_in_workspace() -> None:
    ws = {"xmin": -1.3, "xmax": 2.9, "ymin": -0.7, "ymax": 1.1}
    targets = [{"start": [0.0, 0.0], "motion": STILL}]
    world = World(scenario([[2.85, 1.05], [0.0, 0.0]], targets, u_max=3.7, workspace=ws), 0)
    applied = world.step(np.array([[1.0, 1.0], [0.0, 0.0]]))
    np.testing.assert_allclose(world.robot_positions[0], [2.9, 1.1])
    np.testing.assert_allclose(applied[0], [0.5, 0.5])
    rng = np.random.default_rng(3)
    lower, upper = np.array([-1.3, -0.7]), np.array([2.9, 1.1])
    for _ in range(2000):
        u = world.step(rng.normal(0, 10, (2, 2)))
        assert (np.abs(u) <= 3.7 + 1e-12).all()
        assert (world.robot_positions >= lower).all() and (world.robot_positions <= upper).all()


def test_the_worlds_clipping_is_clip_velocities() -> None:
    """``World.clip_controls`` (bounds made once) gives ``clip_velocities``' numbers exactly,
    non-finite commands included."""
    from resilient_tracking.models.robot_motion import clip_velocities

    ws = {"xmin": -1.3, "xmax": 2.9, "ymin": -0.7, "ymax": 1.1}
    robots = [[2.85, 1.05], [0.0, 0.0], [-1.2, 0.3]]
    targets = [{"start": [0.0, 0.0], "motion": STILL}]
    world = World(scenario(robots, targets, u_max=[0.4, 3.7, 1.1], workspace=ws), 0)
    lower, upper = np.array([-1.3, -0.7]), np.array([2.9, 1.1])
    rng = np.random.default_rng(5)
    for k in range(300):
        u = rng.normal(0, 3, (3, 2))
        if k % 7 == 0:
            u[k % 3, k % 2] = (np.nan, np.inf, -np.inf)[k % 3]
        expected = clip_velocities(world.robot_positions, u, world.u_max, lower, upper, world.dt)
        assert world.clip_controls(u).tobytes() == expected.tobytes()
        world.robot_positions = world.robot_positions + expected * world.dt


# ---------------------------------------------------------------------------- target motions


def test_constant_velocity_target() -> None:
    world = target_world({"type": "constant_velocity", "velocity": [0.3, -0.2]}, [1.0, 2.0])
    for k in range(1, 51):
        world.step(np.zeros((1, 2)))
        np.testing.assert_allclose(world.target_states[0], [1 + 0.03 * k, 2 - 0.02 * k, 0.3, -0.2])


def test_waypoints_reach_points_at_speed_and_stop() -> None:
    motion = {"type": "waypoints", "points": [[1.0, 0.0], [1.0, 1.0]], "speed": 0.5}
    world = target_world(motion, [0.0, 0.0])
    np.testing.assert_allclose(world.target_states[0, 2:], [0.5, 0.0])
    path = [world.target_states[0, :2].copy()]
    for _ in range(60):
        world.step(np.zeros((1, 2)))
        path.append(world.target_states[0, :2].copy())
    path_arr = np.array(path)
    # 0.05 m per step along the polyline: (1, 0) after 20 steps, (1, 1) after 40.
    np.testing.assert_allclose(path_arr[10], [0.5, 0.0], atol=1e-9)
    np.testing.assert_allclose(path_arr[20], [1.0, 0.0], atol=1e-9)
    np.testing.assert_allclose(path_arr[30], [1.0, 0.5], atol=1e-9)
    np.testing.assert_allclose(path_arr[40], [1.0, 1.0], atol=1e-9)
    # Speed: straight-line steps cover speed·dt.
    steps = np.linalg.norm(np.diff(path_arr[:20], axis=0), axis=1)
    np.testing.assert_allclose(steps, 0.05, atol=1e-9)
    # Stops at the end.
    np.testing.assert_allclose(path_arr[40:], np.tile([1.0, 1.0], (21, 1)), atol=1e-9)
    np.testing.assert_allclose(world.target_states[0, 2:], [0.0, 0.0])


def test_waypoints_corner_keeps_path_length() -> None:
    # 0.07 m per step; the corner at (1, 0) is passed mid-step, the remainder goes up the y leg.
    motion = {"type": "waypoints", "points": [[1.0, 0.0], [1.0, 1.0]], "speed": 0.7}
    world = target_world(motion, [0.0, 0.0])
    for _ in range(15):
        world.step(np.zeros((1, 2)))
    np.testing.assert_allclose(world.target_states[0, :2], [1.0, 0.05], atol=1e-9)
    np.testing.assert_allclose(world.target_states[0, 2:], [0.0, 0.7], atol=1e-9)


def test_waypoints_loop() -> None:
    square = [[1.0, 0.0], [1.0, 1.0], [0.0, 1.0], [0.0, 0.0]]
    motion = {"type": "waypoints", "points": square, "speed": 0.5, "loop": True}
    world = target_world(motion, [0.0, 0.0])
    positions = []
    for _ in range(200):
        world.step(np.zeros((1, 2)))
        positions.append(world.target_states[0, :2].copy())
    # Perimeter 4 m at 0.05 m per step: period 80 steps, never stops.
    np.testing.assert_allclose(positions[79], [0.0, 0.0], atol=1e-9)
    np.testing.assert_allclose(positions[99], [1.0, 0.0], atol=1e-9)
    np.testing.assert_allclose(positions[159], [0.0, 0.0], atol=1e-9)
    np.testing.assert_allclose(positions[149], [0.0, 0.5], atol=1e-9)
    moved = np.linalg.norm(np.diff(np.array(positions), axis=0), axis=1)
    assert moved.min() > 0.035  # a corner step cuts the chord; it never stalls
    np.testing.assert_allclose(np.linalg.norm(world.target_states[0, 2:]), 0.5)


@pytest.mark.parametrize("omega", [0.5, -0.8])
def test_circle_target(omega: float) -> None:
    motion = {"type": "circle", "center": [1.0, -1.0], "angular_speed": omega}
    world = target_world(motion, [3.0, -1.0])  # radius 2, starting angle 0
    for k in range(1, 101):
        world.step(np.zeros((1, 2)))
        p, v = world.target_states[0, :2], world.target_states[0, 2:]
        rel = p - np.array([1.0, -1.0])
        np.testing.assert_allclose(np.linalg.norm(rel), 2.0, rtol=1e-12)
        angle = omega * 0.1 * k
        np.testing.assert_allclose(rel, 2.0 * np.array([np.cos(angle), np.sin(angle)]), atol=1e-9)
        np.testing.assert_allclose(np.linalg.norm(v), abs(omega) * 2.0, rtol=1e-9)
        np.testing.assert_allclose(v, omega * np.array([-rel[1], rel[0]]), atol=1e-9)


def test_ncv_target_increment_covariance() -> None:
    q, dt, n = 0.5, 0.1, 6000
    world = target_world({"type": "ncv", "velocity": [0.2, -0.1], "accel_std": q}, [0.0, 0.0])
    states = [world.target_states[0].copy()]
    for _ in range(n):
        world.step(np.zeros((1, 2)))
        states.append(world.target_states[0].copy())
    s = np.array(states)
    dv = np.diff(s[:, 2:], axis=0)
    dp = np.diff(s[:, :2], axis=0) - s[:-1, 2:] * dt  # position noise
    var_v = q**2 * dt
    tol = 4 * math.sqrt(2 / n)
    np.testing.assert_allclose(dv.var(axis=0), [var_v, var_v], rtol=tol)
    np.testing.assert_allclose(dp.var(axis=0), [q**2 * dt**3 / 3] * 2, rtol=tol)
    assert abs(dv.mean(axis=0)).max() <= 4 * math.sqrt(var_v / n)
    # Axes independent; position and velocity noise correlated by √3/2 on each axis.
    assert abs(np.corrcoef(dv[:, 0], dv[:, 1])[0, 1]) < 4 / math.sqrt(n)
    for axis in (0, 1):
        rho = np.corrcoef(dp[:, axis], dv[:, axis])[0, 1]
        assert abs(rho - math.sqrt(3) / 2) < 0.02


def test_ncv_target_with_zero_accel_std_moves_at_constant_velocity() -> None:
    world = target_world({"type": "ncv", "velocity": [0.2, -0.1], "accel_std": 0.0}, [0.0, 0.0])
    for _ in range(10):
        world.step(np.zeros((1, 2)))
    np.testing.assert_allclose(world.target_states[0], [0.2, -0.1, 0.2, -0.1], atol=1e-12)


def test_ncv_motion_follows_a_change_of_step_length() -> None:
    """The NCV matrices are kept between steps; a step of another length gets its own."""
    from resilient_tracking.scenario import NoisyConstantVelocity
    from resilient_tracking.world.motions import NoisyConstantVelocityMotion

    spec = NoisyConstantVelocity(type="ncv", velocity=[0.2, -0.1], accel_std=0.0)
    motion = NoisyConstantVelocityMotion(spec, np.zeros(2))
    rng = np.random.default_rng(0)
    for dt in (0.1, 0.1, 0.3):
        motion.step(dt, rng)
    np.testing.assert_allclose(motion.position, [0.1, -0.05], atol=1e-12)


# ---------------------------------------------------------------------------- measurements

SENSOR = {"range": {"peak": 4.0, "shape": 0.5}, "bearing": {"peak": 50.0, "shape": 0.25}}


def test_measurement_noise_variance_is_R_of_distance() -> None:
    distances = np.array([1.0, 3.0, 5.0, 7.0])
    copies = 3
    target = np.array([0.0, 0.0])
    angles = np.linspace(0.3, 2.5, copies)
    robots = np.array(
        [target - d * np.array([np.cos(a), np.sin(a)]) for d in distances for a in angles]
    )
    sc = scenario(
        robots,
        [{"start": [0.0, 0.0], "motion": STILL}],
        sensor=SENSOR,
        workspace={"xmin": -10, "xmax": 10, "ymin": -10, "ymax": 10},
    )
    world = World(sc, 0)
    n = 3000
    z = np.array([world.observe().measurements[:, 0, :] for _ in range(n)])  # (n, M, 2)
    true_range = np.linalg.norm(robots - target, axis=1)
    true_bearing = np.arctan2(target[1] - robots[:, 1], target[0] - robots[:, 0])
    range_res = (z[..., 0] - true_range).reshape(n, len(distances), copies)
    bearing_res = ((z[..., 1] - true_bearing + np.pi) % (2 * np.pi) - np.pi).reshape(
        n, len(distances), copies
    )
    samples = n * copies
    tol = 4 * math.sqrt(2 / samples)
    for k, d in enumerate(distances):
        var_r = math.exp(0.5 * d) / 4.0
        var_b = math.exp(0.25 * d) / 50.0
        emp_r = float(np.mean(range_res[:, k] ** 2))
        emp_b = float(np.mean(bearing_res[:, k] ** 2))
        assert abs(emp_r / var_r - 1) < tol, (d, emp_r, var_r)
        assert abs(emp_b / var_b - 1) < tol, (d, emp_b, var_b)
        # The test can tell variance from std: using sqrt(R) as variance (R as std) is rejected,
        # as is using the inverse variance.
        for wrong in (math.sqrt(var_r), 1.0 / var_r):
            if abs(wrong / var_r - 1) > 3 * tol:
                assert abs(emp_r / wrong - 1) > tol
        assert abs(float(range_res[:, k].mean())) < 4 * math.sqrt(var_r / samples)


def test_bearings_wrapped_to_minus_pi_pi() -> None:
    # Target due west of the robot: true bearing π, noise pushes it across the cut.
    sc = scenario([[2.0, 0.0]], [{"start": [-2.0, 0.0], "motion": STILL}], sensor=SENSOR)
    world = World(sc, 1)
    b = np.array([world.observe().measurements[0, 0, 1] for _ in range(500)])
    assert (b >= -np.pi).all() and (b < np.pi).all()
    assert (b > 2.5).sum() > 100 and (b < -2.5).sum() > 100  # both sides of the cut occur
    wrapped_res = (b - np.pi + np.pi) % (2 * np.pi) - np.pi
    assert np.abs(wrapped_res).max() < 1.5


def test_observe_reports_truth_free_fields() -> None:
    sc = scenario([[0.0, 0.0], [1.0, 0.0]], [{"start": [2.0, 2.0], "motion": STILL}] * 3)
    world = World(sc, 0)
    obs = world.observe()
    assert obs.measurements.shape == (2, 3, 2)
    assert obs.positions.shape == (2, 2) and obs.links.shape == (2, 2)
    assert obs.step == 0 and obs.time == 0.0
    world.step(np.zeros((2, 2)))
    obs = world.observe()
    assert obs.step == 1 and obs.time == pytest.approx(0.1)
    # observe returns copies: mutating them does not touch the world.
    obs.positions[:] = 99.0
    obs.links[:] = False
    assert world.robot_positions.max() < 2 and world.links[0, 1]


def test_the_worlds_observations_pass_the_checks_they_skip() -> None:
    """``World.observe`` builds observations without ``TeamObservation``'s checks: every field
    must be what the checked constructor would make of it, attacks and recoveries included."""
    from dataclasses import fields

    from resilient_tracking import builtin_scenarios
    from resilient_tracking.observation import TeamObservation
    from resilient_tracking.scenario import load_scenario

    world = World(load_scenario(builtin_scenarios.folder() / "combined-temp.yaml"), 3)
    seen = {"attacks": 0, "recoveries": 0}
    for step in range(200):
        obs = world.observe()
        checked = TeamObservation(**{f.name: getattr(obs, f.name) for f in fields(obs)})
        for f in fields(obs):
            made, expected = getattr(obs, f.name), getattr(checked, f.name)
            assert type(made) is type(expected), f.name
            if isinstance(made, np.ndarray):
                assert made.dtype == expected.dtype and made.shape == expected.shape, f.name
                np.testing.assert_array_equal(made, expected)
            else:
                assert made == expected, f.name
        seen["attacks"] += len(obs.attacks)
        seen["recoveries"] += len(obs.recoveries)
        # robots walk into the zones, then out again (so temporary failures recover)
        zones = [world.zones[i % len(world.zones)] for i in range(world.n_robots)]
        toward = np.array([z.center for z in zones]) - world.robot_positions
        world.step(toward if step < 100 else -toward)
    assert seen["attacks"] and seen["recoveries"], seen


@pytest.mark.parametrize("max_range", [None, 2.0])
def test_observe_asks_a_sensors_own_in_range(max_range: float | None) -> None:
    """Without a range limit the world skips the distances (``in_range_everywhere``); a sensor
    whose ``in_range`` is its own (here: blind within 1.5 m) is asked, limit or not."""
    from dataclasses import dataclass

    from resilient_tracking.models.range_bearing import RangeBearingSensor

    @dataclass(frozen=True)
    class Blind(RangeBearingSensor):
        def in_range(self, distance: Any) -> np.ndarray:
            return np.asarray(super().in_range(distance)) & (np.asarray(distance) > 1.5)

    targets = [{"start": [x, 0.0], "motion": STILL} for x in (1.0, 1.8, 3.0)]
    world = World(scenario([[0.0, 0.0]], targets), 0)

    def measured(sensor: RangeBearingSensor) -> list[bool]:
        world.sensor = sensor
        world._in_range_everywhere = sensor.in_range_everywhere()  # as World.__init__ finds it
        return (~np.isnan(world.observe().measurements[0, :, 0])).tolist()

    assert RangeBearingSensor(max_range=max_range).in_range_everywhere() is (max_range is None)
    assert not Blind(max_range=max_range).in_range_everywhere()
    assert measured(RangeBearingSensor(max_range=max_range)) == [True, True, max_range is None]
    assert measured(Blind(max_range=max_range)) == [False, True, max_range is None]


# ---------------------------------------------------------------------------- cached flags


def test_observe_flags_and_links_follow_failures_set_from_outside() -> None:
    """observe's flags and the radio-only links are cached per failure state: a failure list
    edited or replaced from outside is seen, and they equal what the general path makes."""
    from resilient_tracking.world.links import link_matrix
    from resilient_tracking.world.world import Failure

    world = World(scenario([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]]), 0)
    world.observe()
    world.failures["sensing"] = [None, Failure("temporary", 0, 0), None]
    world.failures["comm"][2] = Failure("permanent", 0, 0)
    world.links = world._compute_links()
    obs = world.observe()
    assert obs.sensing_ok.tolist() == world.capability_ok("sensing").tolist() == [1, 0, 1]
    assert obs.comm_ok.tolist() == world.capability_ok("comm").tolist() == [1, 1, 0]
    assert obs.sensing_persistence == world.persistence("sensing") == ("", "temporary", "")
    assert obs.comm_persistence == world.persistence("comm") == ("", "", "permanent")
    assert np.isnan(obs.measurements[1]).all() and not np.isnan(obs.measurements[0]).any()
    radio = np.array([True, True, False])
    expected = link_matrix(world.robot_positions, radio, np.zeros((0, 3, 3), bool), None)
    assert (obs.links == expected).all() and (world.links == expected).all()
    obs.sensing_ok[:] = False  # the observation's own copy
    assert world.observe().sensing_ok.tolist() == [1, 0, 1]


def test_waypoints_kept_goal_is_the_arrays_one() -> None:
    """WaypointsMotion keeps goal − position between steps: positions and velocities are those
    of the array form, step after step, also when the position is set from outside."""
    from resilient_tracking.models.geometry import vector_length

    motion = {"type": "waypoints", "points": [[1.0, 0.3], [1.3, -2.0], [-0.7, 0.1]]}
    world = target_world({**motion, "speed": 0.37, "loop": True}, [0.1, 0.2])
    m = world.targets[0].motion
    for k in range(300):
        if k == 100:
            m.position = np.array([0.5, 0.5])
        before = (m.position.copy(), m._next_waypoint)
        m.step(0.1, np.random.default_rng(0))
        if m._next_waypoint == before[1]:  # along one segment: the array form's numbers
            delta = m._points[before[1]] - before[0]
            dist = vector_length(delta)
            assert m.position.tobytes() == (before[0] + delta / dist * (0.37 * 0.1)).tobytes()
        delta = m._points[m._next_waypoint] - m.position
        assert m.velocity.tobytes() == (delta / vector_length(delta) * 0.37).tobytes()


def test_step_moves_by_the_clipped_controls() -> None:
    """World.step applies clip_controls' velocities and moves each robot by ``u dt``, at the
    workspace's edges too."""
    rng = np.random.default_rng(5)
    robots = [[3.95, 0.0], [-3.0, 2.95], [0.0, 0.0]]
    world = World(scenario(robots, u_max=[0.5, 1.0, 2.0]), 0)
    for _ in range(300):
        u = rng.normal(0.0, 2.0, (3, 2))
        u[rng.random((3, 2)) < 0.1] = 0.0
        positions = world.robot_positions.copy()
        expected = world.clip_controls(u)
        applied = world.step(u)
        assert applied.tobytes() == expected.tobytes()
        moved = positions + np.multiply(expected, world.dt)
        assert world.robot_positions.tobytes() == moved.tobytes()
