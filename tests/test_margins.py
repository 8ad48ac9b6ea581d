"""The keep-out margins of eqs. 7c/7d: symbolic (the NLP), numeric (the safe action) and the
disc lower bound (the reduced problem) are one margin."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from helpers import inputs, structure_of
from resilient_tracking.planning.layout import (
    CommRow,
    ParameterLayout,
    SensingRow,
    VariableLayout,
)
from resilient_tracking.planning.margins import (
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
