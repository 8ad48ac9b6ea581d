"""Hazard models and the failure process (docs/model.md §2).

Empirical attack rates through ``World`` are compared with the formulas using binomial bounds
(4 sigma). Robots are held still outside the recovery ball, so every temporary hit recovers on
the next step; trials are counted only on steps where the robot was healthy before the draw.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from scipy.stats import multivariate_normal

from resilient_tracking.models.graph import components
from resilient_tracking.scenario import parse_scenario
from resilient_tracking.world import World
from resilient_tracking.world.zones import DiskHazardModel, GaussianHazardModel, gaussian_pdf

STILL_TARGET = {"start": [4.0, 4.0], "motion": {"type": "constant_velocity", "velocity": [0, 0]}}


def make_world(
    robots: list[list[float]] | np.ndarray,
    zones: list[dict[str, Any]],
    seed: int,
    u_max: float = 1.0,
    **extra: Any,
) -> World:
    data: dict[str, Any] = {
        "dt": 0.1,
        "robots": [{"start": [float(p[0]), float(p[1])], "u_max": u_max} for p in robots],
        "targets": [STILL_TARGET],
        "zones": zones,
        **extra,
    }
    return World(parse_scenario(data), seed)


def binomial_ok(hits: int, trials: int, p: float, sigmas: float = 4.0) -> bool:
    return abs(hits - trials * p) <= sigmas * math.sqrt(trials * p * (1 - p)) + 1.0


def mahalanobis2(x: np.ndarray, mu: np.ndarray, sigma: np.ndarray) -> float:
    d = np.asarray(x, float) - mu
    return float(d @ np.linalg.solve(sigma, d))


# ---------------------------------------------------------------------------- model formulas

SIGMA_A = np.array([[0.36, 0.1], [0.1, 0.16]])


def test_gaussian_pdf_matches_scipy() -> None:
    mu = np.array([0.5, -0.3])
    x = np.array([[0.5, -0.3], [1.0, 0.0], [-0.7, 0.4], [3.0, -2.0]])
    expected = multivariate_normal(mu, SIGMA_A).pdf(x)
    np.testing.assert_allclose(gaussian_pdf(x, mu, SIGMA_A), expected, rtol=1e-12)


@pytest.mark.parametrize(("kappa", "f_act", "dt"), [(1.0, 1.0, 0.1), (20.0, 0.5, 0.05)])
def test_gaussian_probability_formula(kappa: float, f_act: float, dt: float) -> None:
    mu = np.array([0.5, -0.3])
    model = GaussianHazardModel(mu, SIGMA_A, f_act, kappa)
    x = np.array([[0.5, -0.3], [1.0, 0.0], [-0.7, 0.4], [3.0, -2.0]])
    pdf = multivariate_normal(mu, SIGMA_A).pdf(x)
    expected = 1.0 - np.exp(-kappa * f_act * dt * pdf)
    for step in (1, 7, 123):  # the Gaussian hazard does not depend on the step
        np.testing.assert_allclose(model.probability(x, step, dt), expected, rtol=1e-12)


def test_gaussian_probability_empirical_with_own_draws() -> None:
    mu = np.array([0.0, 0.0])
    model = GaussianHazardModel(mu, SIGMA_A, 1.0, 20.0)
    x = np.array([[0.0, 0.0], [0.5, 0.5], [1.0, -0.4]])
    rng = np.random.default_rng(5)
    n = 20_000
    p = model.probability(x, 1, 0.1)
    hits = (rng.random((n, len(x))) < p).sum(axis=0)
    expected = 1.0 - np.exp(-2.0 * multivariate_normal(mu, SIGMA_A).pdf(x))
    for k in range(len(x)):
        assert binomial_ok(int(hits[k]), n, float(expected[k]))


@pytest.mark.parametrize(("f_act", "dt", "period"), [(1.0, 0.1, 10), (2.5, 0.1, 4), (0.5, 0.2, 10)])
def test_disk_ticks_every_period(f_act: float, dt: float, period: int) -> None:
    model = DiskHazardModel(np.zeros(2), 1.0, f_act, 0.5)
    ticks = [s for s in range(1, 201) if model.is_tick(s, dt)]
    assert ticks == list(range(period, 201, period))


def test_disk_tick_count_for_non_integer_period() -> None:
    # f_act = 3 Hz at dt = 0.1 s: 1/(f dt) = 3.33 steps; 3 ticks per second of simulated time.
    model = DiskHazardModel(np.zeros(2), 1.0, 3.0, 0.5)
    ticks = [s for s in range(1, 1001) if model.is_tick(s, 0.1)]
    assert len(ticks) == 300
    assert set(np.diff(ticks)) <= {3, 4}


def test_disk_probability_inside_outside_and_off_tick() -> None:
    model = DiskHazardModel(np.array([1.0, 2.0]), 0.5, 1.0, 0.3)
    x = np.array([[1.0, 2.0], [1.5, 2.0], [1.0, 2.51], [0.0, 0.0]])  # centre, boundary, out, out
    np.testing.assert_array_equal(model.probability(x, 10, 0.1), [0.3, 0.3, 0.0, 0.0])
    np.testing.assert_array_equal(model.probability(x, 11, 0.1), np.zeros(4))
    np.testing.assert_array_equal(model.probability(x, 9, 0.1), np.zeros(4))


# ---------------------------------------------------------------------------- rates through World


def run_and_count(world: World, steps: int) -> tuple[np.ndarray, np.ndarray, list[int]]:
    """Hold robots still; per robot: healthy-before-step trials, hits; steps with any attack."""
    m = world.n_robots
    trials = np.zeros(m, int)
    hits = np.zeros(m, int)
    attack_steps: list[int] = []
    still = np.zeros((m, 2))
    start = world.robot_positions.copy()
    world.observe()
    for _ in range(steps):
        healthy = world.capability_ok("sensing")
        world.step(still)
        obs = world.observe()
        trials += healthy
        hit_now = np.zeros(m, bool)
        for attack in obs.attacks:
            assert attack.cause == "hazard"
            assert healthy[attack.robot], "a failed robot was attacked again"
            hit_now[attack.robot] = True
        # Outside the recovery ball, a hit of the previous step has recovered by now.
        assert obs.sensing_ok[~hit_now].all()
        assert not obs.sensing_ok[hit_now].any()
        hits += hit_now
        if hit_now.any():
            attack_steps.append(obs.step)
    np.testing.assert_array_equal(world.robot_positions, start)
    return trials, hits, attack_steps


@pytest.mark.slow
def test_world_gaussian_attack_rate_matches_formula() -> None:
    mu = np.array([0.5, -0.3])
    zone = {
        "kind": "sensing",
        "mu": mu.tolist(),
        "sigma": SIGMA_A.tolist(),
        "radius": 0.3,
        "m_recover": 0.5,
        "persistence": "temporary",
        "hazard": {"model": "gaussian", "kappa": 20.0, "f_act": 1.0},
    }
    offsets = np.array(
        [[0.3, 0.0], [0.0, 0.3], [-0.5, 0.2], [-0.8, -0.5], [1.2, 0.0], [-1.0, 0.6], [1.5, -0.6]]
    )
    per_position = 5
    robots = np.repeat(mu + offsets, per_position, axis=0)
    world = make_world(robots, [zone], seed=3)
    # The hazard marginalises over the center: it uses the prior μ, not the drawn center.
    assert np.linalg.norm(world.zones[0].center - mu) > 0.3
    for p in robots:
        assert mahalanobis2(p, mu, SIGMA_A) > 0.5**2  # outside the recovery ball
    trials, hits, _ = run_and_count(world, 2500)
    pdf = multivariate_normal(mu, SIGMA_A).pdf(mu + offsets)
    expected = 1.0 - np.exp(-20.0 * 1.0 * 0.1 * pdf)
    assert expected.max() > 0.4 and expected.min() < 0.05  # a spread of rates is tested
    for k, p in enumerate(expected):
        rows = slice(k * per_position, (k + 1) * per_position)
        n, h = int(trials[rows].sum()), int(hits[rows].sum())
        assert binomial_ok(h, n, float(p)), (offsets[k], h / n, p)


def test_world_disk_attacks_only_at_ticks_inside_true_disk_at_p_hit() -> None:
    p_hit, radius = 0.3, 0.8
    zone = {
        "kind": "sensing",
        "mu": [0.0, 0.0],
        "sigma": [[1.0, 0.0], [0.0, 1.0]],
        "radius": radius,
        "m_recover": 0.05,
        "persistence": "temporary",
        "hazard": {"model": "disk", "p_hit": p_hit, "f_act": 1.0},
    }
    seed = 3
    center = make_world([[0.0, 0.0]], [zone], seed).zones[0].center
    assert np.linalg.norm(center) > radius + 0.5  # so a robot at μ is well outside the disk
    inside = np.array([[0.0, 0.0], [0.3, 0.0], [-0.5, 0.2], [0.1, -0.7], [0.55, 0.55]])
    outside = np.array([[0.85, 0.0], [0.0, -1.0], [-1.5, 0.5]])
    copies = 4
    robots = np.vstack(
        [np.repeat(center + inside, copies, axis=0), center + outside, np.zeros((1, 2))]
    )
    n_in = len(inside) * copies
    world = make_world(robots, [zone], seed)
    np.testing.assert_array_equal(world.zones[0].center, center)
    trials, hits, attack_steps = run_and_count(world, 3000)
    # Only at activation ticks: every 1/(f_act dt) = 10 steps.
    assert attack_steps and all(s % 10 == 0 for s in attack_steps)
    # Only inside the true disk around the drawn center (not around μ).
    assert hits[n_in:].sum() == 0
    # At rate p_hit per tick: healthy-at-tick trials (every robot recovers before the next tick).
    n_ticks = 300
    assert (hits[:n_in] <= n_ticks).all()
    total = int(hits[:n_in].sum())
    assert binomial_ok(total, n_in * n_ticks, p_hit), total / (n_in * n_ticks)
    # Each hit costs exactly one step of health (a hit on the last step costs none yet).
    assert ((trials == 3000 - hits) | (trials == 3001 - hits)).all()


# ---------------------------------------------------------------------------- failure lifecycle


def lifecycle_zone(persistence: str) -> dict[str, Any]:
    # Disk hazard with p_hit = 1 ticking every 20 steps (f_act = 0.5 Hz at dt = 0.1): the true
    # center is within ~1 m of μ = 0, so the 3 m disk surely covers robots near the origin.
    return {
        "kind": "sensing",
        "mu": [0.0, 0.0],
        "sigma": [[0.09, 0.0], [0.0, 0.01]],
        "radius": 3.0,
        "m_recover": 2.0,  # ball: |x| ≤ 0.6 along x, |y| ≤ 0.2 along y
        "persistence": persistence,
        "hazard": {"model": "disk", "p_hit": 1.0, "f_act": 0.5},
    }


def step_n(world: World, n: int, controls: np.ndarray | None = None) -> None:
    u = np.zeros((world.n_robots, 2)) if controls is None else controls
    for _ in range(n):
        world.step(u)


def test_temporary_failure_lasts_while_inside_mahalanobis_ball() -> None:
    # Robot 0 starts at μ (inside the ball); robot 1 inside the disk but outside the ball;
    # robot 2 far outside the disk.
    world = make_world([[0.0, 0.0], [0.0, 0.5], [4.5, -4.5]], [lifecycle_zone("temporary")], 1, 3)
    assert np.linalg.norm(world.zones[0].center - [4.5, -4.5]) > 3.0
    step_n(world, 19)
    assert world.capability_ok("sensing").all()
    assert world.observe().attacks == ()
    step_n(world, 1)  # step 20: activation tick, p_hit = 1
    obs = world.observe()
    assert obs.step == 20
    assert sorted(a.robot for a in obs.attacks) == [0, 1]
    assert obs.sensing_ok.tolist() == [False, False, True]
    assert obs.sensing_persistence == ("temporary", "temporary", "")
    clue = obs.attacks[0].clue
    assert clue.kind == "sensing" and clue.persistence == "temporary" and clue.zone_id == 0
    # Robot 1, outside the ball, lasts exactly one step; robot 0 stays failed at μ.
    step_n(world, 1)
    obs = world.observe()
    assert obs.sensing_ok.tolist() == [False, True, True]
    assert obs.recoveries == ((1, "sensing"),)
    step_n(world, 4)
    assert not world.capability_ok("sensing")[0]
    # Move robot 0 to (0.3, 0): Mahalanobis² = 1 ≤ 4, still inside the ball → still failed.
    u = np.zeros((3, 2))
    u[0] = [3.0, 0.0]
    step_n(world, 1, u)
    np.testing.assert_allclose(world.robot_positions[0], [0.3, 0.0])
    step_n(world, 3)
    assert not world.capability_ok("sensing")[0]
    assert world.observe().recoveries == ()
    # Move to (0, 0.3): Euclidean distance unchanged, but Mahalanobis² = 9 > 4 → recovers.
    u[0] = [-3.0, 3.0]
    step_n(world, 1, u)
    np.testing.assert_allclose(world.robot_positions[0], [0.0, 0.3], atol=1e-12)
    assert world.step_index < 40  # before the next tick
    obs = world.observe()
    assert obs.sensing_ok.tolist() == [True, True, True]
    assert obs.recoveries == ((0, "sensing"),)


def test_permanent_failure_never_recovers_and_blanks_measurements() -> None:
    world = make_world([[0.0, 0.0], [4.5, -4.5]], [lifecycle_zone("permanent")], 1, 3)
    step_n(world, 19)
    obs = world.observe()
    assert np.isfinite(obs.measurements).all()
    step_n(world, 1)
    obs = world.observe()
    assert [a.robot for a in obs.attacks] == [0]
    assert obs.attacks[0].clue.persistence == "permanent"
    assert obs.sensing_ok.tolist() == [False, True]
    assert obs.sensing_persistence == ("permanent", "")
    # A sensing failure removes that robot's measurements (NaN), not the others'.
    assert np.isnan(obs.measurements[0]).all()
    assert np.isfinite(obs.measurements[1]).all()
    # Leave the ball and the disk, wait long: never recovers.
    u = np.array([[-3.0, 3.0], [0.0, 0.0]])
    step_n(world, 15, u)
    assert mahalanobis2(world.robot_positions[0], np.zeros(2), np.diag([0.09, 0.01])) > 100
    step_n(world, 200)
    obs = world.observe()
    assert obs.sensing_ok.tolist() == [False, True]
    assert obs.recoveries == ()
    assert np.isnan(obs.measurements[0]).all()


def test_comm_hazard_failure_removes_all_links() -> None:
    zone = {
        "kind": "comm",
        "mu": [0.0, 0.0],
        "sigma": [[0.01, 0.0], [0.0, 0.01]],
        "delta2": 0.01,  # jamming negligible at these distances
        "m_recover": 20.0,
        "persistence": "permanent",
        "hazard": {"model": "disk", "p_hit": 1.0, "f_act": 1.0},
    }
    world = make_world([[0.0, 0.0], [4.0, 0.0], [4.0, 1.0]], [zone], 0)
    center = world.zones[0].center
    assert np.linalg.norm(center) < 0.5
    obs = world.observe()
    assert obs.links.sum() == 6  # fully linked before the tick
    assert obs.comm_ok.all()
    step_n(world, 10)
    obs = world.observe()
    assert [(a.robot, a.cause, a.clue.kind) for a in obs.attacks] == [(0, "hazard", "comm")]
    assert obs.comm_ok.tolist() == [False, True, True]
    assert obs.comm_persistence == ("permanent", "", "")
    assert not obs.links[0].any() and not obs.links[:, 0].any()
    assert obs.links[1, 2] and obs.links[2, 1]
    assert components(obs.links) == [[0], [1, 2]]
    # Sensing is untouched by a comm failure.
    assert obs.sensing_ok.all() and np.isfinite(obs.measurements).all()


def test_all_links_jammed_gives_temporary_comm_failure_until_geometry_changes() -> None:
    zone = {
        "kind": "comm",
        "mu": [0.0, 0.0],
        "sigma": [[1e-4, 0.0], [0.0, 1e-4]],
        "delta2": 0.5,
        "m_recover": 1000.0,  # the whole workspace is inside the ball: jamming ignores it
        "persistence": "permanent",  # the hazard's persistence must not leak into jamming
        "hazard": {"model": "disk", "p_hit": 0.0},
    }
    world = make_world([[0.1, 0.0], [3.0, 0.0], [3.0, 0.5]], [zone], 0, u_max=20.0)
    obs = world.observe()
    assert [(a.robot, a.cause) for a in obs.attacks] == [(0, "jamming")]
    assert obs.attacks[0].clue.kind == "comm"
    assert obs.comm_ok.tolist() == [False, True, True]
    assert obs.comm_persistence == ("temporary", "", "")
    assert components(obs.links) == [[0], [1, 2]]
    step_n(world, 5)
    obs = world.observe()
    assert obs.attacks == () and obs.recoveries == ()
    assert not obs.comm_ok[0]
    # Move robot 0 to (2, 2): no link of it is jammed any more → recovers at once.
    u = np.zeros((3, 2))
    u[0] = [19.0, 20.0]
    step_n(world, 1, u)
    np.testing.assert_allclose(world.robot_positions[0], [2.0, 2.0])
    obs = world.observe()
    assert obs.recoveries == ((0, "comm"),)
    assert obs.comm_ok.all()
    assert obs.links.sum() == 6
    assert components(obs.links) == [[0, 1, 2]]
    # Back next to the jammer: isolated again.
    step_n(world, 1, -u)
    obs = world.observe()
    assert [(a.robot, a.cause) for a in obs.attacks] == [(0, "jamming")]
    assert not obs.comm_ok[0]


def test_hazard_hit_on_jammed_robot_is_not_lost() -> None:
    zone = {
        "kind": "comm",
        "mu": [0.0, 0.0],
        "sigma": [[1e-4, 0.0], [0.0, 1e-4]],
        "delta2": 0.2,
        "m_recover": 100.0,  # influence ball and hazard disk: radius 1 m around μ
        "persistence": "temporary",
        "hazard": {"model": "disk", "p_hit": 1.0, "f_act": 1.0},
    }
    world = make_world([[0.1, 0.0], [3.0, 0.0], [3.0, 0.5]], [zone], 0, u_max=20.0)
    obs = world.observe()
    assert [(a.robot, a.cause) for a in obs.attacks] == [(0, "jamming")]
    step_n(world, 10)  # activation tick: robot 0 (inside the disk) is hit with p_hit = 1
    obs = world.observe()
    assert [(a.robot, a.cause) for a in obs.attacks] == [(0, "hazard")]
    # Move to (0, 0.8): no link jammed any more, but still inside the influence ball.
    u = np.zeros((3, 2))
    u[0] = [-1.0, 8.0]
    step_n(world, 1, u)
    assert mahalanobis2(world.robot_positions[0], np.zeros(2), np.eye(2) * 1e-4) < 100.0**2
    assert not world.capability_ok("comm")[0]
