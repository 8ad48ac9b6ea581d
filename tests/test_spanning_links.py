"""The route program's spanning links: eq. 7d kept for the edges of the league's shortest
spanning tree only (``planner.route.links: spanning``)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.sparse.csgraph import connected_components

from helpers import automatic_derivatives, check_derivatives, league_inputs
from resilient_tracking.models.sensor import PLAN_EPS
from resilient_tracking.planning.layout import ProblemInputs, RouteRow, Slots, comm_row
from resilient_tracking.planning.league_problem import LeagueProblem
from resilient_tracking.planning.spanning import spanning_unlinked


@pytest.mark.parametrize("seed", range(5))
def test_the_kept_links_are_a_spanning_tree(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 12))
    positions = rng.uniform(-3, 3, (n, 2))
    positions[-1] = positions[0]  # two robots at one point still get a link
    kept = spanning_unlinked(positions) < 0.5
    assert np.array_equal(kept, kept.T)
    assert not kept.diagonal().any()
    assert kept.sum() == 2 * (n - 1)
    assert connected_components(kept, directed=False)[0] == 1


def test_a_robot_alone_has_no_link():
    assert spanning_unlinked(np.zeros((1, 2))).tolist() == [[1.0]]


def spread_league(links: bool) -> ProblemInputs:
    """Six robots on a 4 m line, a comm zone ahead of the middle, on the route program."""
    n = 6
    positions = np.column_stack([np.zeros(n), np.linspace(-2, 2, n)])
    targets = np.array([[0.6, 0.0], [0.6, 1.0]])
    czones = [comm_row([0.5, 0.1], 0.02 * np.eye(2), 0.3, 0.73, 0.0)]
    q = league_inputs(positions, targets, [], czones, -np.ones((n, 2)), np.ones((n, 2)))
    q.route = np.zeros((n, RouteRow.WIDTH))  # no pull: the zone rows are what is tested
    q.standoff = 0.2
    if links:
        q.unlinked = spanning_unlinked(positions)
    return q


def test_a_left_out_link_drops_the_teammate_term_only():
    """A left-out row is ``h_i + ξ``: the kept row plus ``δ2 ‖x_i − x_q‖``; kept rows agree."""
    q_all, q_tree = spread_league(False), spread_league(True)
    problem = LeagueProblem(q_all.structure(), options={"slots": None})
    fg = problem.nlp.functions["fg"]
    x = np.zeros(problem.nlp.n_vars)
    g_all = fg(x, problem.pack_params(q_all))[1].full().ravel()
    g_tree = fg(x, problem.pack_params(q_tree))[1].full().ravel()
    n = len(q_all.positions)
    rows = [(i, j) for i in range(n) for j in range(n) if j != i]  # one comm zone
    left_out = 0
    for r, (i, j) in enumerate(rows):
        if q_tree.unlinked[i, j] > 0.5:
            left_out += 1
            rho = np.sqrt(np.sum((q_all.positions[i] - q_all.positions[j]) ** 2) + PLAN_EPS**2)
            assert g_tree[r] == pytest.approx(g_all[r] + 0.3 * rho, abs=1e-9)
        else:
            assert g_tree[r] == g_all[r]
    assert left_out == n * (n - 1) - 2 * (n - 1)


def test_derivatives_with_links_left_out_equal_automatic_differentiation():
    q = spread_league(True)
    problem = LeagueProblem(q.structure(), options={"slots": None})
    nlp = problem.nlp
    rng = np.random.default_rng(3)
    xv = rng.uniform(-0.5, 0.5, nlp.n_vars)
    lg = rng.uniform(0, 2, nlp.n_constraints)
    check_derivatives(nlp, automatic_derivatives(nlp), xv, problem.pack_params(q), lg)


def test_reduced_sqp_with_links_left_out_gives_the_full_problems_solution():
    q = spread_league(True)
    problem = LeagueProblem(q.structure(), options={"slots": Slots(0, 1, 2)})
    full = LeagueProblem(q.structure(), options={"slots": None})
    assert problem.reduction(q) is not None
    start, stats = full.solve(q, method="ipopt")
    assert stats["success"]
    reduced, stats = problem.solve(q, start, method="sqp")
    whole, stats_full = full.solve(q, start, method="sqp")
    assert stats["success"] and stats_full["success"]
    np.testing.assert_allclose(reduced["x"], whole["x"], atol=1e-9)


def test_spanning_links_let_the_middle_robots_nearer_the_zone():
    """The point of the option: with every link protected the middle robots of a spread
    league must keep about δ2 × 2 m from the zone; with the tree's links, about δ2 × 0.8 m."""
    steps = {}
    for links in (False, True):
        q = spread_league(links)
        problem = LeagueProblem(q.structure(), options={"slots": None})
        solution, stats = problem.solve(q, method="ipopt")
        assert stats["success"]
        steps[links] = problem.split(solution["x"])
    toward = np.array([1.0, 0.0])
    assert (steps[True] @ toward).max() > (steps[False] @ toward).max() + 0.05
