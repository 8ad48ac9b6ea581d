"""The SQP's reduced league problem: only the zones and teammates that can bind this step.

``LeagueProblem.reduction`` drops rows (and their slacks) that hold for every control within
the velocity bounds; these tests check that claim by brute force, that the reduced problem's
derivatives are right, and that solving it gives the full problem's solution.
"""

from __future__ import annotations

import numpy as np
import pytest

from helpers import automatic_derivatives, check_derivatives, league_inputs, structure_of
from resilient_tracking.planning import codegen
from resilient_tracking.planning.layout import (
    ProblemInputs,
    SensingRow,
    Slots,
    Structure,
    comm_row,
    sensing_row,
)
from resilient_tracking.planning.league_problem import LeagueProblem
from resilient_tracking.planning.nlp import LeagueNLP
from resilient_tracking.planning.reduction import reduced_slots
from resilient_tracking.planning.solver_options import SLOTS


def scene(n: int, big_n: int, nl: int, nk: int, seed: int) -> ProblemInputs:
    """Robots 0.5 m apart on a line, targets ahead of them, sensing zones just ahead of every
    other robot (each robot near at most two), comm zones just ahead of robots 3, 7, ...: some
    rows bind, most cannot."""
    rng = np.random.default_rng(seed)
    ys = 0.5 * (np.arange(n) - (n - 1) / 2)
    positions = np.column_stack([np.full(n, -0.5), ys]) + 0.03 * rng.standard_normal((n, 2))
    targets = np.column_stack([np.full(big_n, -0.2), rng.uniform(ys[0], ys[-1], big_n)])
    cov_s = np.array([[0.03, 0.005], [0.005, 0.03]])
    szones = [
        sensing_row([-0.05, ys[(2 * k) % n] + 0.05 * rng.standard_normal()], cov_s, 0.3, 1.45)
        for k in range(nl)
    ]
    czones = [
        comm_row(
            [-0.2, ys[(3 + 4 * k) % n] + 0.05 * rng.standard_normal()],
            0.02 * np.eye(2),
            0.05,
            0.73,
            0.1,
        )
        for k in range(nk)
    ]
    upper = rng.uniform(0.5, 1.0, (n, 2))
    return league_inputs(positions, targets, szones, czones, -upper[:, ::-1], upper)


def test_only_leagues_with_something_to_drop_are_reduced():
    assert reduced_slots(Structure(3, 3, 1, 1)) is None
    assert reduced_slots(Structure(5, 5, 2, 1)) is None
    assert reduced_slots(Structure(20, 20, 4, 2)) == Slots(2, 1, 6)
    assert reduced_slots(Structure(10, 10, 3, 0)) == Slots(2, 0, 0)
    assert reduced_slots(Structure(20, 20, 4, 2), None) is None


@pytest.mark.parametrize(
    ("shape", "slots"),
    [
        ((5, 3, 3, 2), Slots(2, 1, 2)),
        ((4, 2, 2, 1), Slots(1, 1, 1)),
        ((6, 2, 0, 2), Slots(0, 1, 3)),
    ],
)
def test_reduced_derivatives_equal_automatic_differentiation(shape, slots):
    """With one-hot (or zero) selections, as :meth:`LeagueProblem.reduction` makes them."""
    n, big_n, nl, nk = shape
    q = scene(n, big_n, nl, nk, seed=n)
    q.sensing[0] = 0.0
    nlp = LeagueNLP(structure_of(q), slots=slots)
    problem = LeagueProblem(structure_of(q))
    reference = automatic_derivatives(nlp)
    rng = np.random.default_rng(1)

    def selection(choices: int, columns: int) -> np.ndarray:
        out = np.zeros((columns, choices))
        for c in range(columns):
            if choices and rng.uniform() < 0.8:
                out[c, rng.integers(choices)] = 1.0
        return out.ravel()

    for _ in range(3):
        pv = np.concatenate(
            [
                problem.pack_params(q),
                selection(nl, n * slots.sensing),
                selection(nk, n * slots.comm),
                selection(n - 1, n * slots.mates),
            ]
        )
        xv = rng.uniform(-1, 1, nlp.n_vars)
        lg = rng.uniform(-3, 1, nlp.n_constraints)
        check_derivatives(nlp, reference, xv, pv, lg)


@pytest.mark.parametrize("seed", range(6))
def test_dropped_rows_hold_for_every_control_within_the_bounds(seed):
    """Brute force over controls in the velocity box (its corners included): a dropped
    (robot, zone) row holds with a zero slack; a dropped teammate's row is never tighter than
    the kept farthest teammate's."""
    n, big_n, nl, nk = 9, 3, 4, 2
    q = scene(n, big_n, nl, nk, seed=seed)
    problem = LeagueProblem(structure_of(q), options={"slots": Slots(3, 2, 5)})
    reduction = problem.reduction(q)
    assert reduction is not None
    kept = set(reduction.rows[reduction.active].tolist())
    assert 0 < len(kept) < problem.n_constraints  # something kept, something dropped
    rng = np.random.default_rng(seed)
    corners = np.array([[a, b] for a in (0, 1) for b in (0, 1)])
    samples = [rng.uniform(q.u_lower, q.u_upper) for _ in range(300)]
    samples += [np.where(corners[rng.integers(4, size=n)] == 1, q.u_upper, q.u_lower)]
    samples += [np.where(corners[np.full(n, c)] == 1, q.u_upper, q.u_lower) for c in range(4)]
    fg = problem.nlp.functions["fg"]
    p = problem.pack_params(q)
    per_robot = nl + nk * (n - 1)
    first_mate = {}  # (robot, zone) → the full row of its first (farthest) teammate slot
    for slot, row in enumerate(reduction.rows):
        i, local = divmod(int(row), per_robot)
        if reduction.active[slot] and local >= nl:
            first_mate.setdefault((i, (local - nl) // (n - 1)), int(row))
    for u in samples:
        x = np.concatenate([u.ravel(), np.zeros(n * (nl + nk))])
        g = fg(x, p)[1].full().ravel()
        for row in set(range(problem.n_constraints)) - kept:
            i, local = divmod(row, per_robot)
            zone = (i, (local - nl) // (n - 1))
            if local < nl or zone not in first_mate:
                assert g[row] > 0, (row, g[row])
            else:
                assert g[row] >= g[first_mate[zone]] - 1e-12


def moved(problem: LeagueProblem, q: ProblemInputs, solution) -> ProblemInputs:
    q.positions = q.positions + problem.split(solution["x"]) * q.dt
    q.targets = q.targets + np.array([0.03, 0.0])
    return q


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_reduced_sqp_gives_the_full_problems_solution(seed):
    """From the same primal–dual warm start, as in the loop, over two steps: the SQP on the
    reduced problem, the SQP on the full one and IPOPT agree, multipliers included (the SQP's
    tolerance 1e-6 on a weakly curved direction allows ≈ 1e-4 against IPOPT)."""
    q = scene(9, 4, 4, 2, seed=seed)
    problem = LeagueProblem(structure_of(q), options={"slots": Slots(2, 1, 5)})
    full = LeagueProblem(structure_of(q), options={"slots": None})
    previous, stats = problem.solve(q, method="ipopt")
    assert stats["success"]
    for _ in range(2):
        q = moved(problem, q, previous)
        assert problem.reduction(q) is not None and full.reduction(q) is None
        sqp, stats = problem.solve(q, previous, method="sqp")
        sqp_full, stats_full = full.solve(q, previous, method="sqp")
        ipopt, stats_i = problem.solve(q, previous, method="ipopt")
        assert stats["success"] and stats_full["success"] and stats_i["success"]
        assert stats["iter_count"] <= 10
        np.testing.assert_allclose(sqp["x"], sqp_full["x"], atol=1e-9)
        np.testing.assert_allclose(sqp["x"], ipopt["x"], atol=1e-4)
        assert sqp["f"][0] == pytest.approx(ipopt["f"][0], abs=1e-4)
        scale = 1 + np.abs(ipopt["lam_g"]).max()
        for key in ("lam_g", "lam_x"):
            np.testing.assert_allclose(sqp[key], sqp_full[key], atol=1e-7 * scale)
            np.testing.assert_allclose(sqp[key], ipopt[key], atol=1e-3 * scale)
        previous = sqp  # the next step warm-starts from the expanded solution


def test_a_robot_needing_more_slots_gets_the_full_problem():
    q = scene(9, 3, 4, 2, seed=3)
    q.sensing_zones[:3, SensingRow.MEAN] = q.positions[4] + np.array(
        [[0.2, 0.0], [0.0, 0.2], [-0.2, 0.0]]
    )
    problem = LeagueProblem(structure_of(q), options={"slots": Slots(2, 1, 5)})
    assert problem.reduction(q) is None
    sqp, stats = problem.solve(q, method="sqp")
    assert stats["success"]
    full = LeagueProblem(structure_of(q), options={"slots": None})
    np.testing.assert_array_equal(sqp["x"], full.solve(q, method="sqp")[0]["x"])


def test_a_robot_needing_more_slots_gets_the_next_wider_reduced_problem():
    """With two sizes of reduced problem, a step the smaller cannot hold is solved on the wider
    (its own method), which gives the full problem's solution; a step the smaller holds
    stays on it."""
    q = scene(9, 3, 4, 2, seed=3)
    q.sensing_zones[:3, SensingRow.MEAN] = q.positions[4] + np.array(
        [[0.2, 0.0], [0.0, 0.2], [-0.2, 0.0]]
    )
    levels = (Slots(2, 1, 5), Slots(4, 1, 5))
    problem = LeagueProblem(structure_of(q), options={"slots": levels})
    assert problem.slot_methods == {levels[0]: "sqp_slots", levels[1]: "sqp_slots1"}
    reduction = problem.reduction(q)
    assert reduction is not None and reduction.slots == levels[1]
    sqp, stats = problem.solve(q, method="sqp")
    assert stats["success"]
    assert problem._calls.keys() == {"sqp_slots1"}  # neither the smaller nor the full one
    full = LeagueProblem(structure_of(q), options={"slots": None})
    reference, _ = full.solve(q, method="sqp")
    np.testing.assert_allclose(sqp["x"], reference["x"], atol=1e-9)
    easy = scene(9, 3, 4, 2, seed=3)
    assert problem.reduction(easy).slots == levels[0]


def test_wider_slots_that_reduce_nothing_are_left_out():
    """A size capped to the structure's own (nothing to drop) is no reduced problem."""
    q = scene(5, 3, 2, 1, seed=0)
    problem = LeagueProblem(structure_of(q), options={"slots": (Slots(1, 1, 2), Slots(2, 1, 4))})
    assert list(problem.slot_methods) == [Slots(1, 1, 2)]


@pytest.mark.slow
@pytest.mark.skipif(not codegen.enabled(), reason="needs a C compiler and RTRACK_CODEGEN on")
def test_reduced_problem_on_compiled_code_gives_bit_for_bit_the_same_plans(tmp_path, monkeypatch):
    monkeypatch.setenv("RTRACK_CACHE_DIR", str(tmp_path))
    options = {"slots": Slots(2, 1, 2), "margin": 0.012}
    runs = []
    for use in (False, True):
        q = scene(4, 2, 2, 1, seed=7)
        problem = LeagueProblem(structure_of(q), "sqp", {**options, "codegen": use})
        if use:
            problem.wait_for_compiler(("sqp",))
            assert problem._call("sqp_slots").compiled
        warm, out = None, []
        for _ in range(4):
            assert problem.reduction(q) is not None
            solution, stats = problem.solve(q, warm, "sqp")
            assert stats["success"]
            out.append(solution["x"])
            warm = solution
            q = moved(problem, q, solution)
        runs.append(np.stack(out))
    np.testing.assert_array_equal(runs[0], runs[1])


def test_only_problems_with_many_rows_are_reduced_by_default():
    assert LeagueProblem(Structure(4, 3, 3, 0)).slots is None  # 12 rows: the paper's sizes
    assert LeagueProblem(Structure(3, 3, 1, 3)).slots is None
    assert LeagueProblem(Structure(10, 10, 3, 2)).slots == Slots(2, 1, 6)  # 210 rows
    assert LeagueProblem(Structure(4, 3, 3, 0), options={"slots": SLOTS}).slots == Slots(2, 0, 0)
