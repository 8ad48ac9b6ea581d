"""The league NLP's structured derivatives and the solver ladder (SQP → IPOPT → safe)."""

from __future__ import annotations

import threading
from dataclasses import replace

import numpy as np
import pytest

from helpers import automatic_derivatives, check_derivatives, inputs, structure_of
from resilient_tracking.planning import codegen
from resilient_tracking.planning.layout import ProblemInputs
from resilient_tracking.planning.league_problem import LeagueProblem
from resilient_tracking.planning.nlp import LeagueNLP
from resilient_tracking.planning.planner import BUILDING, LeaguePlanner
from resilient_tracking.scenario import ScenarioError, parse_scenario


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


def with_route(q: ProblemInputs, seed: int) -> ProblemInputs:
    """``q`` on the route program: random route rows around the robots (offsets on both sides
    of the hinge) and the route program's information standoff."""
    rng = np.random.default_rng(seed)
    n = len(q.positions)
    rows = np.column_stack(
        [q.positions + rng.uniform(-1, 1, (n, 2)), rng.uniform(-1, 1, n), rng.uniform(0, 2, n)]
    )
    return replace(q, route=rows, standoff=0.2)


@pytest.mark.parametrize("shape", [(1, 2, 1, 0), (3, 3, 1, 1), (2, 3, 0, 2)])
def test_route_program_derivatives_equal_automatic_differentiation(shape):
    n, big_n, nl, nk = shape
    q = with_route(inputs(n, big_n, seed=n, sensing_zones=nl, comm_zones=nk), seed=n)
    structure = q.structure()
    assert structure.route and structure.standoff == 0.2
    nlp = LeagueNLP(structure)
    reference = automatic_derivatives(nlp)
    pv = LeagueProblem(structure).pack_params(q)
    assert len(pv) == nlp.n_params
    rng = np.random.default_rng(2)
    for _ in range(3):
        xv = rng.uniform(-1, 1, structure.n_vars)
        check_derivatives(nlp, reference, xv, pv, rng.uniform(-3, 1, nlp.n_constraints))


def test_route_rows_pull_a_far_robot_along_its_route():
    """Far from a well-tracked target, the one-step program barely moves; the route program
    heads for the waypoint at about the speed its weight is set for."""
    q = inputs(1, 1, seed=0, sensing_zones=0, comm_zones=0)
    # a well-tracked target (5 cm), 8 m away: one more measurement is worth little
    q = replace(
        q,
        positions=np.array([[-4.0, 0.0]]),
        targets=np.array([[4.0, 0.0]]),
        prior_info=np.eye(2)[None] * 400.0,
    )
    speed = 0.8
    weight = 2 * q.weights[1] * speed / q.dt
    routed = replace(q, route=np.array([[0.0, 3.0, 5.0, weight]]), standoff=0.2)
    plain = LeagueProblem(q.structure()).solve(q, method="ipopt")[0]["x"][:2]
    pulled = LeagueProblem(routed.structure()).solve(routed, method="ipopt")[0]["x"][:2]
    assert np.linalg.norm(plain) < 0.2
    heading = np.array([4.0, 3.0]) / 5.0
    assert np.dot(pulled, heading) == pytest.approx(speed, abs=0.1)


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


@pytest.mark.parametrize("method", ["sqp", "ipopt"])
def test_solvers_do_not_build_the_unused_lagrangian_gradient(method):
    """``nlp_grad`` serves only the parameters' multipliers, which nothing asks for; CasADi
    derived it by reverse AD at every solver creation (0.05-0.5 s at 20×20)."""
    q = inputs(seed=5)
    solver = LeagueProblem(structure_of(q), method).solver()
    assert solver.has_function("nlp_hess_l") or method == "ipopt"
    assert not solver.has_function("nlp_grad")


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


@pytest.mark.slow
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


class _GatedPlanner(LeaguePlanner):
    """Builds only once ``gate`` is set, so a test controls when a background build ends."""

    def __init__(self, **kwargs):
        super().__init__(background_builds=True, **kwargs)
        self.gate = threading.Event()

    def build(self, structure):
        assert self.gate.wait(60), "the test never opened the gate"
        return super().build(structure)


def _finish(planner: LeaguePlanner, q: ProblemInputs) -> None:
    planner.gate.set()
    planner._building[structure_of(q)].result(timeout=120)


def test_a_background_build_answers_with_the_safe_rung_until_ready_then_plans_as_usual():
    q = inputs(seed=5)
    planner = _GatedPlanner()
    first = planner.plan(structure_of(q), (0, 1, 2), q)  # returns although the build is held
    assert not first.success and first.fallback == "safe"
    assert first.status == BUILDING and first.attempts == (("build", BUILDING),)
    np.testing.assert_array_equal(first.controls, np.zeros((3, 2)))
    assert planner.plan(structure_of(q), (0, 1, 2), q).status == BUILDING
    _finish(planner, q)
    blocking = LeaguePlanner()
    for _ in range(3):  # once built, the same plans as a planner that waited for its build
        ours, theirs = (p.plan(structure_of(q), (0, 1, 2), q) for p in (planner, blocking))
        assert ours.success and ours.rung == "sqp"
        np.testing.assert_array_equal(ours.controls, theirs.controls)
        q.positions = q.positions + ours.controls * q.dt
    planner.close()


def test_a_failed_background_build_gives_the_safe_action_and_is_retried():
    class Broken(_GatedPlanner):
        def build(self, structure):
            assert self.gate.wait(60)
            raise MemoryError("out of memory")

    q = inputs()
    planner = Broken()
    assert planner.plan(structure_of(q), (0, 1, 2), q).status == BUILDING
    failed = planner._building[structure_of(q)]
    planner.gate.set()
    with pytest.raises(MemoryError):
        failed.result(timeout=60)
    result = planner.plan(structure_of(q), (0, 1, 2), q)
    assert not result.success and result.attempts == (("build", "exception: MemoryError"),)
    assert planner.plan(structure_of(q), (0, 1, 2), q).status == BUILDING  # built again
    planner.close()
