"""Helpers shared by several test files: the shipped scenarios and league-problem inputs."""

from __future__ import annotations

import copy

import casadi as ca
import numpy as np

from resilient_tracking import builtin_scenarios
from resilient_tracking.models.range_bearing import RangeBearingSensor
from resilient_tracking.observation import TeamObservation
from resilient_tracking.planning.adaptation import chance_margin
from resilient_tracking.planning.layout import (
    ProblemInputs,
    Structure,
    comm_row,
    comm_table,
    sensing_row,
    sensing_table,
)
from resilient_tracking.planning.nlp import LeagueNLP
from resilient_tracking.scenario import Scenario, load_scenario

SCENARIOS = builtin_scenarios.folder()


def shipped(name: str) -> Scenario:
    return load_scenario(builtin_scenarios.path(name))


def inputs(n: int = 3, big_n: int = 3, seed: int = 0, sensing_zones: int = 1, comm_zones: int = 1):
    """A league near its targets with known zones on their path (constraints near binding)."""
    rng = np.random.default_rng(seed)
    positions = np.column_stack([np.full(n, -1.0), np.linspace(-1, 1, n)])
    positions += 0.1 * rng.standard_normal((n, 2))
    targets = np.column_stack([np.full(big_n, -0.6), np.linspace(-1, 1, big_n)])
    targets += 0.1 * rng.standard_normal((big_n, 2))
    szones = [
        sensing_row([0.0, 0.2 * k], 0.2 * np.eye(2), r_safe=0.5, beta=chance_margin(0.02))
        for k in range(sensing_zones)
    ]
    czones = [
        comm_row([0.1, -0.5 + 0.3 * k], 0.15 * np.eye(2), 0.3, chance_margin(0.15), 0.0)
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
        sensor=RangeBearingSensor(15.0, 0.2, 15.0, 0.2).parameters,
        dt=0.1,
        u_lower=u_lower,
        u_upper=u_upper,
        sensing_zones=sensing_table(szones),
        comm_zones=comm_table(czones),
    )


def structure_of(q: ProblemInputs) -> Structure:
    return q.structure()


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


def run_checked(cmd: list[str], cwd, env: dict[str, str] | None = None, timeout: float = 600):
    """Run a command; fail the test with its output if it exits non-zero."""
    import subprocess

    done = subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)
    assert done.returncode == 0, f"{cmd} failed:\n{done.stdout}\n{done.stderr}"
    return done


#: What a built-in policy needs from its scenario to be built: the learned one, its function.
POLICY_NEEDS = {"callable": {"callable": {"function": "learned_agents:chase"}}}


def with_policy_needs(data: dict, policy: str) -> dict:
    """A copy of the scenario mapping ``data`` with what ``policy`` needs to be built."""
    data = copy.deepcopy(data)
    section = data.setdefault("policy", {})
    for key, needed in POLICY_NEEDS.get(policy, {}).items():
        section[key] = {**section.get(key, {}), **needed}
    if policy == "onnx":  # a model for any team
        from onnx_models import shared_pursuer

        section["onnx"] = {**section.get("onnx", {}), "model": str(shared_pursuer())}
    return data


def healthy_observation(
    step: int, positions: np.ndarray, measurements: np.ndarray, links: np.ndarray
) -> TeamObservation:
    """One tick of a team whose every sensor and radio works (``dt`` 0.1 s)."""
    m = len(positions)
    return TeamObservation(
        step=step,
        time=0.1 * step,
        positions=positions,
        measurements=measurements,
        sensing_ok=np.ones(m, bool),
        comm_ok=np.ones(m, bool),
        sensing_persistence=("",) * m,
        comm_persistence=("",) * m,
        links=links,
    )
