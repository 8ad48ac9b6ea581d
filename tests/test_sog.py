"""The risk-aware SOG baseline (docs/model.md §7, a reconstruction of Mayya et al., RA-L 2022)."""

from __future__ import annotations

import json
from typing import Any

import casadi as ca
import numpy as np
import pandas as pd
import pytest

from helpers import SCENARIOS, shipped
from resilient_tracking.belief.ekf import ExtendedKalmanFilter
from resilient_tracking.belief.estimate import TargetEstimate
from resilient_tracking.belief.knowledge import KnowledgeBase
from resilient_tracking.build import make_policy, team_config
from resilient_tracking.cli import main
from resilient_tracking.models.motion import NearlyConstantVelocity
from resilient_tracking.models.range_bearing import RangeBearingSensor
from resilient_tracking.observation import Attack, TeamObservation, ZoneClue
from resilient_tracking.planning.sog_nlp import SogNLP
from resilient_tracking.planning.sog_problem import (
    SogInputs,
    SogPlanner,
    SogProblem,
    SogStructure,
    failure_likelihood,
    information_function,
    likelihood_function,
    zone_rows,
)
from resilient_tracking.policies import POLICIES, SogPolicy
from resilient_tracking.policies.sog import SogParams, abundance_weights
from resilient_tracking.runs.schema import REPRODUCIBLE
from resilient_tracking.scenario import parse_scenario
from resilient_tracking.sim.episode import run_episode
from resilient_tracking.team import Team
from resilient_tracking.world.zones import GaussianHazardModel

MU = np.array([0.1, 0.0])
SIGMA = 0.3 * np.eye(2)
STILL = {"type": "constant_velocity", "velocity": [0.0, 0.0]}


def sog_scenario(**sog: Any):
    """Three robots west of a zone, one still target at the zone's mean."""
    return parse_scenario(
        {
            "name": "sog-test",
            "steps": 1,
            "workspace": {"xmin": -4, "xmax": 4, "ymin": -3, "ymax": 3},
            "robots": [{"start": [-1.2, 0.3]}, {"start": [-3.0, 2.0]}, {"start": [-3.0, -2.0]}],
            "targets": [{"start": [0.1, 0.0], "motion": STILL}],
            "policy": {"name": "sog", "sog": sog},
        }
    )


def observe(positions: np.ndarray, sensing_ok: list[bool], step: int = 0, attacks=()):
    m = len(positions)
    return TeamObservation(
        step=step,
        time=0.1 * step,
        positions=np.asarray(positions, dtype=float),
        measurements=np.full((m, 1, 2), np.nan),
        sensing_ok=np.array(sensing_ok),
        comm_ok=np.ones(m, dtype=bool),
        sensing_persistence=tuple("" if ok else "permanent" for ok in sensing_ok),
        comm_persistence=("",) * m,
        links=~np.eye(m, dtype=bool),
        attacks=tuple(attacks),
    )


def clue() -> ZoneClue:
    return ZoneClue(0, "sensing", MU, SIGMA, 0.5, "permanent")


def team_knowing_the_zone(scenario, positions, sensing_ok) -> Team:
    """A SOG team that learned the zone from an attack clue at step 0."""
    config = team_config(scenario)
    estimate = TargetEstimate.initial(np.array([[0.1, 0.0, 0.0, 0.0]]), 0.3, 0.1)
    team = Team(make_policy("sog", scenario, config), estimate)
    team.step(observe(positions, sensing_ok, attacks=[Attack(2, clue())]))
    return team


# ---------------------------------------------------------------------------- failure likelihood


def test_phi_rises_toward_a_known_zone_centre_and_is_zero_without_knowledge():
    zones = zone_rows([MU], [SIGMA])
    ray = MU + np.outer(np.linspace(3.0, 0.0, 31), [1.0, 0.5])
    phi = failure_likelihood(ray, zones, scale=10.0)
    assert np.all(np.diff(phi) > 0) and phi.min() >= 0 and phi.max() < 1
    assert phi[0] < 0.01 and phi[-1] > 0.9
    # nothing known, nothing feared (belief only: the knowledge base is what counts)
    none = SogPolicy.known_zones(KnowledgeBase())
    assert none.shape == (0, 6)
    np.testing.assert_array_equal(failure_likelihood(ray, none, scale=10.0), 0.0)
    # the NLP's expression is the same function
    f = likelihood_function(1)
    for x in ray[::5]:
        assert float(f(x, zones.T, 10.0)) == pytest.approx(failure_likelihood(x, zones, 10.0)[0])


def test_phi_over_one_step_is_the_worlds_gaussian_hazard_at_the_estimate():
    """docs/model.md §2: ``1 − exp(−κ f_act dt pdf)``; φ is that hazard with ``c = κ f_act T``."""
    hazard = GaussianHazardModel(MU, SIGMA, f_act=1.0, kappa=2.0)
    x = np.array([[0.0, 0.0], [0.5, -0.4], [1.2, 0.9]])
    np.testing.assert_allclose(
        failure_likelihood(x, zone_rows([MU], [SIGMA]), scale=2.0 * 1.0 * 0.1),
        hazard.probability(x, step=3, dt=0.1),
        rtol=1e-12,
    )


# ---------------------------------------------------------------------------- the Gramian


def test_sog_information_is_the_ekf_information_when_phi_is_zero_and_scales_with_survival():
    sensor = RangeBearingSensor()
    ekf = ExtendedKalmanFilter(NearlyConstantVelocity(0.1, 0.2), sensor)
    prior = TargetEstimate.initial(np.array([[1.0, 0.5, 0.0, 0.0], [-0.5, 1.5, 0, 0]]), 0.4, 0.2)
    robots = np.array([[-1.0, 0.0], [2.0, 2.0], [0.5, -1.5]])
    posterior = ekf.update(prior, robots, np.zeros((3, 2, 2)))  # P⁺ does not depend on z
    ekf_info = np.linalg.inv(posterior.cov[:, :2, :2]) - np.linalg.inv(prior.cov[:, :2, :2])

    sensor_row = np.array([15.0, 0.2, 15.0, 0.2])
    info = information_function(3, 2)
    o = np.asarray(info(robots.T, np.ones(3), prior.mean[:, :2].T, sensor_row))
    as_matrix = np.stack([[[c[0], c[1]], [c[1], c[2]]] for c in o.T])
    # equal up to the planner's distance regularisation √(d² + 0.05²)
    np.testing.assert_allclose(as_matrix, ekf_info, rtol=2e-3)

    # each sensor's information weighted by its survival 1 − φ
    alone = [
        np.asarray(info(robots.T, np.eye(3)[i], prior.mean[:, :2].T, sensor_row)) for i in (0, 2)
    ]
    weighted = np.asarray(
        info(robots.T, np.array([0.5, 0.0, 0.8]), prior.mean[:, :2].T, sensor_row)
    )
    np.testing.assert_allclose(weighted, 0.5 * alone[0] + 0.8 * alone[1], rtol=1e-12)


# ---------------------------------------------------------------------------- the program


def test_sog_is_a_policy_name_with_documented_defaults():
    assert "sog" in POLICIES.builtin_names()
    params = SogParams()
    assert params.rho2 == 0.3 and params.rho1 > 0
    assert SogPolicy.learns_zones
    with pytest.raises(ValueError, match="rho2"):
        sog_scenario(rho2=1.5)


def test_abundance_weights_move_from_aggressive_to_risk_averse():
    params = SogParams()
    track = [abundance_weights(params, a)[0] for a in (0.0, 1 / 3, 2 / 3, 1.0)]
    risk = [abundance_weights(params, a)[1] for a in (0.0, 1 / 3, 2 / 3, 1.0)]
    assert np.all(np.diff(track) > 0) and np.all(np.diff(risk) < 0)
    assert abundance_weights(params, 1.0) == (params.abundant.track, params.abundant.risk)
    assert abundance_weights(params, 0.0) == (params.scarce.track, params.scarce.risk)


def test_fewer_working_sensors_make_the_plan_more_risk_averse():
    """Robot 0 sits at the ρ2 boundary with its target inside the zone: a full team lets it
    step in (aggressive); with two sensors gone it does not go deeper (risk-averse)."""
    s = sog_scenario(rho2=0.3)
    scale = s.policy.params_for("sog").hazard_rate * s.policy.params_for("sog").risk_window
    zones = zone_rows([MU], [SIGMA])
    # where φ = ρ2 on the ray from the zone's mean toward the west
    d = np.linspace(0.5, 2.5, 2001)
    boundary = MU + [
        -d[np.argmin(abs(failure_likelihood(np.c_[MU[0] - d, 0 * d], zones, scale) - 0.3))],
        0,
    ]
    positions = np.array([boundary, [-3.0, 2.0], [-3.0, -2.0]])
    phi_next = {}
    for label, ok in (("abundant", [True, True, True]), ("scarce", [True, False, False])):
        team = team_knowing_the_zone(s, positions, ok)
        out = team.step(observe(positions, ok, step=1))
        x_next = positions[0] + 0.1 * out.controls[0]
        phi_next[label] = failure_likelihood(x_next, zones, scale)[0]
        assert out.decision.plans and all(p.success for p in out.decision.plans)
    assert phi_next["abundant"] > 0.3 + 1e-3
    assert phi_next["scarce"] <= 0.3 + 1e-3


@pytest.mark.parametrize("seed", [1, 2])
def test_lower_rho2_keeps_robots_further_from_a_known_zone(seed):
    """A still target sits at a known zone's mean; the team closes in only as far as ρ2 allows."""
    distances = {}
    for rho2 in (0.6, 0.2):
        s = sog_scenario(rho2=rho2)
        rng = np.random.default_rng(seed)
        positions = np.array([[-1.6, 0.4], [-1.2, -0.8], [0.3, 1.6]]) + rng.normal(0, 0.1, (3, 2))
        team = team_knowing_the_zone(s, positions, [True] * 3)
        for step in range(1, 60):
            out = team.step(observe(positions, [True] * 3, step=step))
            positions = positions + 0.1 * out.controls
        distances[rho2] = np.linalg.norm(positions - MU, axis=1)
    assert np.all(distances[0.2] > distances[0.6] + 0.1), distances


@pytest.mark.slow
def test_risky_team_is_hit_more_often_than_a_conservative_one_in_sensing_perm():
    attacks = {}
    for rho2 in (0.6, 0.2):
        base = shipped("sensing-perm")
        policy = base.policy.model_dump()
        policy.setdefault("sog", {})["rho2"] = rho2
        s = base.with_overrides(policy=policy)
        counts = []
        for seed in (1, 2, 3):
            events = run_episode(s, policy="sog", seed=seed)["events"]
            counts.append(int((events.event == "attack").sum()))
            assert not (events.event == "solver_fallback").any()
        attacks[rho2] = sum(counts)
    assert attacks[0.6] > attacks[0.2], attacks


# ---------------------------------------------------------------------------- robustness


def test_a_solver_failure_holds_position_and_is_recorded(monkeypatch):
    def broken(self, q, warm=None, method=None):
        raise RuntimeError("injected")

    monkeypatch.setattr(SogProblem, "solve", broken)
    s = sog_scenario()
    positions = np.array([[-1.2, 0.3], [-3.0, 2.0], [-3.0, -2.0]])
    team = team_knowing_the_zone(s, positions, [True] * 3)
    out = team.step(observe(positions, [True] * 3, step=1))
    np.testing.assert_array_equal(out.controls, 0.0)
    fallbacks = [e for e in out.events if e.event == "solver_fallback"]
    assert sorted(e.robot for e in fallbacks) == [0, 1, 2]
    assert all(e.fallback == "safe" and e.action in ("escape", "hold") for e in fallbacks)


def test_the_episode_fault_hook_reaches_the_sog_planner():
    """SOG solves through the same ladder as the league planner, so injected faults reach it."""

    def infeasible(rung, solution, stats):
        return solution, {**stats, "success": False, "return_status": "Infeasible_Problem_Detected"}

    s = shipped("sensing-temp").with_overrides(steps=5)
    events = run_episode(s, policy="sog", seed=1, fault_hook=infeasible)["events"]
    fallbacks = events[events.event == "solver_fallback"]
    assert len(fallbacks) == 5 * 3 and (fallbacks.fallback == "safe").all()


@pytest.mark.parametrize("solver, first", [("ladder", "sqp"), ("ipopt", "cold")])
def test_the_scenarios_solver_choice_holds_for_sog(solver, first):
    rungs: list[str] = []

    def record(rung, solution, stats):
        rungs.append(rung)
        return solution, stats

    base = shipped("sensing-temp")
    s = base.with_overrides(steps=3, planner={**base.planner.model_dump(), "solver": solver})
    run_episode(s, policy="sog", seed=1, fault_hook=record)
    assert rungs and rungs[0] == first
    assert ("sqp" in rungs) == (solver == "ladder")


@pytest.mark.slow
def test_rtrack_run_with_sog_writes_the_run_folder(tmp_path, capsys):
    out = tmp_path / "run"
    path = str(SCENARIOS / "sensing-temp.yaml")
    command = ["run", path, "--team", "sog", "--policy", "sog", "--steps", "150"]
    assert main([*command, "--out", str(out), "-q"]) == 0
    assert "wrote" in capsys.readouterr().out
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["policy"] == "sog"
    robots = pd.read_parquet(out / "robots.parquet")
    events = pd.read_parquet(out / "events.parquet")
    assert set(robots["mode"]) <= {"league", "individual"}
    assert (events.event == "attack").any() and not (events.event == "solver_fallback").any()
    assert any((out / "figures").glob("*.png"))


def test_a_sog_episode_is_reproducible_bit_for_bit():
    s = shipped("sensing-perm").with_overrides(steps=130).with_team("sog")
    a, b = (run_episode(s, policy="sog", seed=1) for _ in range(2))
    assert (a["events"].event == "attack").any()  # knowledge and the zone term are exercised
    for table in REPRODUCIBLE:
        pd.testing.assert_frame_equal(a[table], b[table], check_exact=True)


# ---------------------------------------------------------------------------- the fast path


def _recorded_inputs(name: str, seed: int, steps: int) -> list[tuple[tuple[int, ...], SogInputs]]:
    """The SOG league inputs of an episode, in order."""
    found: list[tuple[tuple[int, ...], SogInputs]] = []

    class Recording(SogPlanner):
        def plan_sog(self, members, q):
            found.append((members, q))
            return super().plan_sog(members, q)

    s = shipped(name).with_overrides(steps=steps).with_team("sog")
    import resilient_tracking.policies.sog as sog_module

    original = sog_module.SogPlanner
    sog_module.SogPlanner = Recording  # type: ignore[misc]
    try:
        run_episode(s, policy="sog", seed=seed)
    finally:
        sog_module.SogPlanner = original  # type: ignore[misc]
    return found


@pytest.mark.slow
def test_the_sqp_ladder_plans_what_ipopt_plans_within_solver_tolerance():
    """Every step of a bench-risk episode (a zone learned on the way): the SQP rung solves
    it (no fallback) and its velocities match IPOPT's on the same problem to 1e-3 m/s."""
    steps = _recorded_inputs("bench-risk", 4, 160)
    assert any(len(q.zones) for _, q in steps)  # the zone term is exercised
    ladder, ipopt = SogPlanner(), SogPlanner(solver="ipopt")
    worst = 0.0
    for members, q in steps:
        fast, reference = ladder.plan_sog(members, q), ipopt.plan_sog(members, q)
        assert fast.rung == "sqp" and not fast.fallback, fast.attempts
        assert reference.success
        worst = max(worst, float(np.abs(fast.controls - reference.controls).max()))
    assert worst < 1e-3, worst  # measured: 2.2e-4 m/s (a flat optimum: tolerances 1e-6)


def test_the_sog_derivatives_are_casadis_and_the_sqp_hessian_is_convex():
    structure = SogStructure(3, 2, 1)
    nlp = SogNLP(structure)
    rng = np.random.default_rng(3)
    x = rng.normal(0, 0.1, nlp.n_vars)
    p = np.concatenate(
        [
            [0.3, 0.1, -1.0, 1.0, 0.8, -0.6],  # positions: robot 0 next to target 0
            [1.0, 0.0, 1.0],  # sensing
            [0.4, 0.15, 1.0, -1.0],  # targets
            [[4.0, 0.5, 3.0], [2.0, -0.3, 5.0]],  # prior information
            [15.0, 0.2, 15.0, 0.2, 0.1],  # sensor, dt
            zone_rows([MU], [SIGMA]).ravel(),
            [0.05, 0.3, 1e-3, 100.0, 2.0, 10.0, 0.1],  # scalars: little effort weight
        ],
        axis=None,
    )
    lam_g = -np.abs(rng.normal(0, 100, nlp.n_constraints))
    xs, ps = ca.SX.sym("x", nlp.n_vars), ca.SX.sym("p", nlp.n_params)
    f, g = nlp.functions["fg"](xs, ps)
    lagrangian = ca.Function("l", [xs, ps], [ca.hessian(f + ca.dot(lam_g, g), xs)[0]])
    exact = np.asarray(lagrangian(x, p))
    triu = np.asarray(ca.DM(nlp.functions["hess_exact_triu"](x, p, 1.0, lam_g)))
    np.testing.assert_allclose(np.triu(exact), triu, rtol=1e-9, atol=1e-12)
    jac = ca.Function("j", [xs, ps], [ca.jacobian(g, xs)])
    np.testing.assert_allclose(
        np.asarray(ca.DM(nlp.functions["jac_g"](x, p)[1])), np.asarray(jac(x, p)), rtol=1e-12
    )
    clipped = np.asarray(ca.DM(nlp.functions["hess_clip"](x, p, 1.0, lam_g)))
    assert np.linalg.eigvalsh(exact[:6, :6]).min() < 0  # a point where the exact one is not
    for i in range(3):
        block = clipped[2 * i : 2 * i + 2, 2 * i : 2 * i + 2]
        assert np.linalg.eigvalsh(block).min() >= 1e-2 - 1e-12
    # off-diagonal blocks stay exact
    np.testing.assert_allclose(clipped[0:2, 2:6], exact[0:2, 2:6], rtol=1e-9, atol=1e-12)
