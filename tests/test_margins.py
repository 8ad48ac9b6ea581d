"""The keep-out margins of eqs. 7c/7d: symbolic (the NLP), numeric (the safe action) and the
disc lower bound (the reduced problem) are one margin."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from helpers import inputs, league_inputs, structure_of
from resilient_tracking.planning.adaptation import chance_margin
from resilient_tracking.planning.layout import (
    CommRow,
    ParameterLayout,
    SensingRow,
    VariableLayout,
    sensing_row,
)
from resilient_tracking.planning.league_problem import LeagueProblem
from resilient_tracking.planning.margins import (
    PLAN_EPS,
    SPREAD_EPS,
    keep_out,
    keep_out_lower_bound,
    keep_out_values,
    pair_distance,
    pair_distances,
)
from resilient_tracking.planning.nlp import LeagueNLP
from resilient_tracking.planning.safe_action import constraint_margins


def random_gaussians(rng: np.random.Generator, k: int) -> np.ndarray:
    """``k`` rows: a mean and the entries xx, xy, yy of a random covariance."""
    rows = []
    for _ in range(k):
        a = rng.normal(size=(2, 2)) * 0.3
        cov = a @ a.T + 0.01 * np.eye(2)
        rows.append([*rng.uniform(-2, 2, 2), cov[0, 0], cov[0, 1], cov[1, 1]])
    return np.array(rows)


@pytest.mark.parametrize("seed", range(5))
def test_numeric_keep_out_equals_the_symbolic_one(seed):
    rng = np.random.default_rng(seed)
    gaussians = random_gaussians(rng, 6)
    offset, beta = rng.uniform(0, 1, 6), rng.uniform(-0.5, 3, 6)
    xp, zone, off, b = ca.SX.sym("x", 2), ca.SX.sym("z", 5), ca.SX.sym("o"), ca.SX.sym("b")
    symbolic = ca.Function("h", [xp, zone, off, b], [keep_out(xp, zone, off, b)])
    for x in [rng.uniform(-3, 3, 2) for _ in range(10)] + [gaussians[0, :2]]:
        numeric = keep_out_values(x, gaussians, offset, beta)
        expected = [
            float(symbolic(x, g, o, bb)) for g, o, bb in zip(gaussians, offset, beta, strict=True)
        ]
        np.testing.assert_allclose(numeric, expected, rtol=1e-12, atol=1e-12)


def test_numeric_pair_distance_equals_the_symbolic_one():
    rng = np.random.default_rng(1)
    xp, xq = ca.SX.sym("x", 2), ca.SX.sym("q", 2)
    symbolic = ca.Function("rho", [xp, xq], [pair_distance(xp, xq)])
    x, others = rng.normal(size=2), rng.normal(size=(5, 2))
    others[0] = x  # the regularised distance at zero
    expected = [float(symbolic(x, o)) for o in others]
    np.testing.assert_allclose(pair_distances(x, others), expected, rtol=1e-12)


@pytest.mark.parametrize("seed", range(3))
def test_lower_bound_holds_over_the_reachable_disc(seed):
    rng = np.random.default_rng(seed)
    gaussians = random_gaussians(rng, 4)
    offset, beta = rng.uniform(0, 1, 4), rng.uniform(-0.5, 3, 4)
    robots, reach = rng.uniform(-2, 2, (3, 2)), rng.uniform(0.05, 0.5, 3)
    bound = keep_out_lower_bound(robots, reach, gaussians, offset, beta)
    for i in range(3):
        angles, radii = rng.uniform(0, 2 * np.pi, 300), reach[i] * np.sqrt(rng.uniform(0, 1, 300))
        points = robots[i] + radii[:, None] * np.column_stack([np.cos(angles), np.sin(angles)])
        lowest = np.min([keep_out_values(p, gaussians, offset, beta) for p in points], axis=0)
        assert np.all(bound[i] <= lowest + 1e-12)
    # tight for a disc of radius 0 without the spread term
    flat = keep_out_lower_bound(robots, np.zeros(3), gaussians, offset, np.zeros(4))
    exact = np.array([keep_out_values(x, gaussians, offset, np.zeros(4)) for x in robots])
    np.testing.assert_allclose(flat, exact, rtol=1e-12)


def test_safe_action_margins_are_the_nlp_rows_at_rest():
    """With zero velocities and slacks the NLP's rows are the safe action's margins (each
    comm zone's binding row: the farthest teammate)."""
    q = inputs(n=3, big_n=2, sensing_zones=2, comm_zones=1, seed=4)
    nlp = LeagueNLP(structure_of(q))
    g = np.asarray(nlp.functions["fg"](np.zeros(nlp.n_vars), ParameterLayout.pack(q))[1]).ravel()
    n, nl, nk = 3, 2, 1
    per_robot = nl + nk * (n - 1)
    for i in range(n):
        rows = g[i * per_robot : (i + 1) * per_robot]
        margins = constraint_margins(q, i)
        np.testing.assert_allclose(margins[:nl], rows[:nl], rtol=1e-12)
        np.testing.assert_allclose(margins[nl], rows[nl:].min(), rtol=1e-12)
    assert VariableLayout(n, nl, nk).n_vars == nlp.n_vars
    assert q.sensing_zones.shape[1] == SensingRow.WIDTH and q.comm_zones.shape[1] == CommRow.WIDTH


def regularised_only(x: np.ndarray, gaussians: np.ndarray, offset, beta) -> np.ndarray:
    """The margin with the regularised ``â`` alone (no completion in the zone's core)."""
    v = gaussians[:, 0:2] - x
    dist = np.sqrt(v[:, 0] ** 2 + v[:, 1] ** 2 + PLAN_EPS**2)
    a = v / dist[:, None]
    g = gaussians
    quad = (
        a[:, 0] * a[:, 0] * g[:, 2] + 2 * a[:, 0] * a[:, 1] * g[:, 3] + a[:, 1] * a[:, 1] * g[:, 4]
    )
    return np.asarray(dist - offset - beta * np.sqrt(2 * quad + SPREAD_EPS))


@pytest.mark.parametrize("sigma", [0.05, 0.3, 0.63, 1.0, 2.0, 5.0])
@pytest.mark.parametrize("beta", [0.5, 1.16, 2.33, 3.0])
def test_margin_grows_with_the_distance_from_an_isotropic_zone(sigma, beta):
    """No position inside a zone is safer than one farther from its mean: the margin rises
    along every ray, the mean included. The regularised ``â`` alone makes the mean a local
    maximum (checked too, so that this test can fail)."""
    zone = np.array([[0.3, -0.2, sigma**2, 0.0, sigma**2]])
    radii = np.linspace(0.0, 3.0, 3001)
    for angle in (0.0, 1.0, 2.5):
        ray = zone[0, :2] + radii[:, None] * np.array([np.cos(angle), np.sin(angle)])
        h = np.array([keep_out_values(x, zone, 1.2, beta)[0] for x in ray])
        assert np.all(np.diff(h) > 0)
        old = np.array([regularised_only(x, zone, 1.2, beta)[0] for x in ray])
        assert old[0] > old[5]


@pytest.mark.parametrize("seed", range(3))
def test_margin_is_the_regularised_one_to_the_bit_outside_the_core(seed):
    rng = np.random.default_rng(seed)
    gaussians = random_gaussians(rng, 6)
    offset, beta = rng.uniform(0, 1, 6), rng.uniform(-0.5, 3, 6)
    for _ in range(50):
        x = rng.uniform(-4, 4, 2)
        outside = np.hypot(*(gaussians[:, :2] - x).T) >= 1.0  # beyond every core here
        new = keep_out_values(x, gaussians, offset, beta)
        old = regularised_only(x, gaussians, offset, beta)
        assert np.array_equal(new[outside], old[outside])
        assert np.all(new[~outside] <= old[~outside])


def test_a_robot_near_a_known_zones_mean_plans_its_way_out():
    """A robot 4 cm from a known sensing zone's mean, no target near: the league problem
    converges, and the robot moves away from the mean at full speed (with the regularised
    ``â`` alone, the mean is where the violation is least and no solver converges there)."""
    beta = chance_margin(0.02)
    zone = np.array(sensing_row([-3.0, 2.5], 0.4 * np.eye(2), r_safe=1.2, beta=beta))
    x = np.array([[-3.04, 2.5]])
    q = league_inputs(
        x, np.array([[4.0, -4.0]]), [zone.tolist()], [], -np.ones((1, 2)), np.ones((1, 2))
    )
    problem = LeagueProblem(structure_of(q), "ipopt", {"codegen": False})
    solution, stats = problem.solve(q, None, "ipopt")
    assert stats["success"]
    u = problem.split(solution["x"])[0]
    away = (x[0] - zone[:2]) / np.linalg.norm(x[0] - zone[:2])
    assert u @ away > 0.9
