"""The league NLP's structured derivatives and the solver ladder (SQP → IPOPT → safe)."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from resilient_tracking.planning import codegen
from resilient_tracking.planning.adaptation import chance_margin
from resilient_tracking.planning.layout import ProblemInputs, Structure
from resilient_tracking.planning.league_problem import LeagueProblem
from resilient_tracking.planning.nlp import LeagueNLP
from resilient_tracking.planning.planner import LeaguePlanner
from resilient_tracking.scenario import ScenarioError, parse_scenario


def inputs(n: int = 3, big_n: int = 3, seed: int = 0, sensing_zones: int = 1, comm_zones: int = 1):
    """A league near its targets with known zones on their path (constraints near binding)."""
    rng = np.random.default_rng(seed)
    positions = np.column_stack([np.full(n, -1.0), np.linspace(-1, 1, n)])
    positions += 0.1 * rng.standard_normal((n, 2))
    targets = np.column_stack([np.full(big_n, -0.6), np.linspace(-1, 1, big_n)])
    targets += 0.1 * rng.standard_normal((big_n, 2))
    szones = [[0.0, 0.2 * k, 0.2, 0.0, 0.2, 0.5, chance_margin(0.02)] for k in range(sensing_zones)]
    czones = [
        [0.1, -0.5 + 0.3 * k, 0.15, 0.0, 0.15, 0.3, chance_margin(0.15), 0.0]
        for k in range(comm_zones)
    ]
    return league_inputs(positions, targets, szones, czones, -np.ones((n, 2)), np.ones((n, 2)))


def league_inputs(positions, targets, szones, czones, u_lower, u_upper) -> ProblemInputs:
    """Inputs with every robot sensing, a common prior, the tests' weights and sensor."""
    return ProblemInputs(
        positions=positions,
        sensing=np.ones(len(positions)),
        targets=targets,
        prior_info=np.repeat(np.eye(2)[None] * 3.0, len(targets), axis=0),
        weights=np.array([50.0, 0.05, 200.0, 100.0]),
        sensor=np.array([15.0, 0.2, 15.0, 0.2]),
        dt=0.1,
        u_lower=u_lower,
        u_upper=u_upper,
        sensing_zones=np.array(szones, dtype=float).reshape(-1, 7),
        comm_zones=np.array(czones, dtype=float).reshape(-1, 8),
    )


def structure_of(q: ProblemInputs) -> Structure:
    return Structure(len(q.positions), len(q.targets), len(q.sensing_zones), len(q.comm_zones))


def automatic_derivatives(nlp: LeagueNLP) -> ca.Function:
    """∇f, ∂g/∂x and ∇²L by CasADi's automatic differentiation: the reference for ours."""
    x, p = nlp.x, nlp.p
    lam_f, lam_g = ca.SX.sym("lf"), ca.SX.sym("lg", nlp.n_constraints)
    lagrangian = lam_f * nlp.nlp["f"] + ca.dot(lam_g, nlp.nlp["g"])
    return ca.Function(
        "ref",
        [x, p, lam_f, lam_g],
        [ca.gradient(nlp.nlp["f"], x), ca.jacobian(nlp.nlp["g"], x), ca.hessian(lagrangian, x)[0]],
    )


def check_derivatives(nlp: LeagueNLP, reference: ca.Function, xv, pv, lg) -> np.ndarray:
    """Our ∇f, ∂g/∂x and ∇²L (λ_f = 0.7) against ``reference`` at one point; the exact ∇²L."""
    grad, jac, hess = (m.full() for m in reference(xv, pv, 0.7, lg))
    f = nlp.functions
    np.testing.assert_allclose(f["grad_f"](xv, pv)[1].full().ravel(), grad.ravel(), atol=1e-9)
    np.testing.assert_allclose(f["jac_g"](xv, pv)[1].full(), jac, atol=1e-9)
    np.testing.assert_allclose(f["hess_exact"](xv, pv, 0.7, lg).full(), hess, atol=1e-8)
    return hess


@pytest.mark.parametrize("shape", [(1, 2, 1, 0), (3, 3, 1, 1), (4, 2, 2, 2), (2, 3, 0, 0)])
def test_structured_derivatives_equal_automatic_differentiation(shape):
    n, big_n, nl, nk = shape
    q = inputs(n, big_n, seed=n, sensing_zones=nl, comm_zones=nk)
    q.sensing[0] = 0.0  # a robot without its sensor drops out of the tracking term
    nlp = LeagueNLP(structure_of(q))
    problem = LeagueProblem(structure_of(q))
    reference = automatic_derivatives(nlp)
    rng = np.random.default_rng(1)
    for _ in range(3):
        xv = rng.uniform(-1, 1, nlp.structure.n_vars)
        lg = rng.uniform(-3, 1, nlp.n_constraints)
        pv = problem.pack_params(q)
        hess = check_derivatives(nlp, reference, xv, pv, lg)
        f = nlp.functions
        np.testing.assert_allclose(
            f["hess_exact_triu"](xv, pv, 0.7, lg).full(), np.triu(hess), atol=1e-8
        )
        # the SQP's Hessian: the exact one with each robot's 2×2 diagonal block clipped
        clipped = f["hess_clip"](xv, pv, 0.7, lg).full()
        for i in range(n):
            block = clipped[2 * i : 2 * i + 2, 2 * i : 2 * i + 2]
            assert np.linalg.eigvalsh(block).min() >= nlp.margin - 1e-9
            if np.linalg.eigvalsh(hess[2 * i : 2 * i + 2, 2 * i : 2 * i + 2]).min() > nlp.margin:
                np.testing.assert_allclose(block, hess[2 * i : 2 * i + 2, 2 * i : 2 * i + 2])
        off = ~np.kron(np.eye(n, dtype=bool), np.ones((2, 2), dtype=bool))
        np.testing.assert_allclose(clipped[: 2 * n, : 2 * n][off], hess[: 2 * n, : 2 * n][off])


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_sqp_solution_matches_ipopt_from_the_same_warm_start(seed):
    """As in the loop: both start from the previous step's primal–dual solution."""
    q = inputs(3, 3, seed=seed)
    problem = LeagueProblem(structure_of(q))
    previous, stats = problem.solve(q, method="ipopt")
    assert stats["success"]
    q.positions = q.positions + previous["x"][:6].reshape(3, 2) * q.dt
    q.targets = q.targets + np.array([0.02, 0.0])
    ipopt, stats_i = problem.solve(q, previous, method="ipopt")
    sqp, stats_s = problem.solve(q, previous, method="sqp")
    assert stats_i["success"] and stats_s["success"]
    assert stats_s["iter_count"] <= 10
    np.testing.assert_allclose(sqp["x"], ipopt["x"], atol=1e-5)
    # IPOPT relaxes bounds by 1e-8 (bound_relax_factor), so its slacks dip to ≈ −1e-8
    assert sqp["f"][0] == pytest.approx(ipopt["f"][0], abs=1e-4)


def test_sqp_and_ipopt_agree_from_a_cold_start_on_a_convex_case():
    """Far from the targets and the zones the problem is benign: one optimum, found by both."""
    q = inputs(3, 3, seed=0, sensing_zones=0, comm_zones=0)
    q.targets = q.targets + np.array([1.5, 0.0])
    problem = LeagueProblem(structure_of(q))
    ipopt, _ = problem.solve(q, method="ipopt")
    sqp, stats = problem.solve(q, method="sqp")
    assert stats["success"]
    np.testing.assert_allclose(sqp["x"], ipopt["x"], atol=1e-5)


class Recorder:
    """A fault hook that records every attempt and fails the rungs it is told to."""

    def __init__(self, fail: set[str] | None = None, raise_in: set[str] | None = None):
        self.fail = fail or set()
        self.raise_in = raise_in or set()
        self.calls: list[str] = []

    def __call__(self, rung, solution, stats):
        self.calls.append(rung)
        if rung in self.raise_in:
            raise RuntimeError(f"injected in {rung}")
        if rung in self.fail:
            return solution, {**stats, "success": False, "return_status": f"injected {rung}"}
        return solution, stats


def plan_twice(planner: LeaguePlanner, q: ProblemInputs):
    """A first solve (no warm start yet), then a second one warm-started from it."""
    s = structure_of(q)
    first = planner.plan(s, (0, 1, 2), q)
    second = planner.plan(s, (0, 1, 2), q)
    return first, second


def test_ladder_uses_sqp_warm_started_and_reports_no_fallback():
    hook = Recorder()
    first, second = plan_twice(LeaguePlanner(fault_hook=hook), inputs())
    assert hook.calls == ["sqp", "sqp"]
    for result in (first, second):
        assert result.success and result.fallback == "" and result.rung == "sqp"


@pytest.mark.parametrize(
    ("fail", "calls", "fallback"),
    [
        ({"sqp"}, ["sqp", "warm"], "warm"),
        ({"sqp", "warm"}, ["sqp", "warm", "cold"], "cold"),
        ({"sqp", "warm", "cold"}, ["sqp", "warm", "cold"], "safe"),
    ],
)
def test_each_failed_rung_falls_to_the_next_and_is_reported(fail, calls, fallback):
    hook = Recorder()
    planner = LeaguePlanner(fault_hook=hook)
    q = inputs()
    planner.plan(structure_of(q), (0, 1, 2), q)  # leaves a warm start
    hook.fail, hook.calls = fail, []
    result = planner.plan(structure_of(q), (0, 1, 2), q)
    assert hook.calls == calls
    assert result.fallback == fallback
    assert [rung for rung, _ in result.attempts] == calls
    assert result.success == (fallback != "safe")
    if fallback == "safe":  # hold position, within the bounds
        np.testing.assert_array_equal(result.controls, np.zeros((3, 2)))


def test_an_exception_in_a_rung_is_a_failed_attempt():
    hook = Recorder(raise_in={"sqp"})
    planner = LeaguePlanner(fault_hook=hook)
    q = inputs()
    result = planner.plan(structure_of(q), (0, 1, 2), q)  # no warm start: sqp, then cold
    assert hook.calls == ["sqp", "cold"]
    assert result.success and result.fallback == "cold"
    assert result.attempts[0] == ("sqp", "exception: RuntimeError")


def test_after_a_safe_action_the_next_solve_starts_cold():
    hook = Recorder(fail={"sqp", "warm", "cold"})
    planner = LeaguePlanner(fault_hook=hook)
    q = inputs()
    assert planner.plan(structure_of(q), (0, 1, 2), q).fallback == "safe"
    hook.fail, hook.calls = set(), []
    result = planner.plan(structure_of(q), (0, 1, 2), q)
    assert hook.calls == ["sqp"] and result.success


def test_ipopt_only_planner_uses_warm_then_cold_ipopt():
    hook = Recorder()
    planner = LeaguePlanner("ipopt", fault_hook=hook)
    first, second = plan_twice(planner, inputs())
    assert hook.calls == ["cold", "warm"]
    assert first.fallback == second.fallback == ""
    hook.fail, hook.calls = {"warm"}, []
    q = inputs()
    assert planner.plan(structure_of(q), (0, 1, 2), q).fallback == "cold"
    assert hook.calls == ["warm", "cold"]


def test_ladder_and_ipopt_plan_the_same_controls_on_a_benign_case():
    q = inputs(seed=4, sensing_zones=0, comm_zones=0)
    q.targets = q.targets + np.array([1.5, 0.0])
    ladder = LeaguePlanner().plan(structure_of(q), (0, 1, 2), q)
    ipopt = LeaguePlanner("ipopt").plan(structure_of(q), (0, 1, 2), q)
    np.testing.assert_allclose(ladder.controls, ipopt.controls, atol=1e-5)


def test_plans_are_reproducible_bit_for_bit():
    runs = []
    for _ in range(2):
        planner = LeaguePlanner()
        q = inputs(seed=5)
        controls = []
        for _ in range(5):
            result = planner.plan(structure_of(q), (0, 1, 2), q)
            controls.append(result.controls)
            q.positions = q.positions + result.controls * q.dt
        runs.append(np.stack(controls))
    np.testing.assert_array_equal(runs[0], runs[1])


def test_unknown_solver_names_are_rejected():
    with pytest.raises(ValueError, match="solver"):
        LeaguePlanner("snopt")
    with pytest.raises(ScenarioError, match="planner.solver"):
        parse_scenario(
            {
                "robots": [{"start": [0, 0]}],
                "targets": [{"start": [1, 0], "motion": {"type": "ncv"}}],
                "planner": {"solver": "snopt"},
            }
        )


@pytest.mark.skipif(not codegen.enabled(), reason="needs a C compiler and RTRACK_CODEGEN on")
def test_compiled_code_gives_bit_for_bit_the_same_plans(tmp_path, monkeypatch):
    """The cache can fill between two runs; the results must not notice."""
    monkeypatch.setenv("RTRACK_CACHE_DIR", str(tmp_path))
    q0 = inputs(2, 2, seed=6)
    runs = []
    for use in (False, True):
        problem = LeagueProblem(structure_of(q0), "sqp", {"codegen": use, "margin": 0.011})
        if use:
            problem.wait_for_compiler()
            assert problem.compiled("sqp") and problem.compiled("ipopt")
            assert list(tmp_path.glob("*.so"))
        q = inputs(2, 2, seed=6)
        warm, out = None, []
        for _ in range(4):
            for method in ("sqp", "ipopt"):
                solution, stats = problem.solve(q, warm, method)
                assert stats["success"]
                out.append(solution["x"])
            warm = solution
            q.positions = q.positions + problem.split(solution["x"]) * q.dt
        runs.append(np.stack(out))
    np.testing.assert_array_equal(runs[0], runs[1])


def test_a_problem_that_cannot_be_built_gives_the_safe_action():
    class Broken(LeaguePlanner):
        def build(self, structure):
            raise MemoryError("out of memory")

    q = inputs()
    result = Broken().plan(structure_of(q), (0, 1, 2), q)
    assert not result.success and result.fallback == "safe"
    assert result.attempts == (("build", "exception: MemoryError"),)
    np.testing.assert_array_equal(result.controls, np.zeros((3, 2)))


def test_a_malformed_solution_is_a_failed_attempt():
    planner = LeaguePlanner(fault_hook=lambda rung, sol, stats: ({"x": np.ones(1)}, stats))
    q = inputs()
    result = planner.plan(structure_of(q), (0, 1, 2), q)
    assert result.fallback == "safe"
    assert [status for _, status in result.attempts] == ["exception: ValueError"] * 2
