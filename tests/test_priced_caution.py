"""Caution priced by what a failure costs (the ``priced`` guard, docs/model.md §6.7)."""

from __future__ import annotations

import numpy as np
import pytest

from helpers import shipped
from resilient_tracking.belief.estimate import TargetEstimate
from resilient_tracking.belief.knowledge import KnowledgeBase, ZoneEstimate
from resilient_tracking.build import team_config
from resilient_tracking.observation import Attack, TeamObservation, ZoneClue
from resilient_tracking.planning.adaptation import chance_margin, risk_level
from resilient_tracking.planning.layout import (
    CommRow,
    SensingRow,
    comm_row,
    comm_table,
    sensing_row,
    sensing_table,
)
from resilient_tracking.policies.guards import GuardsSpec
from resilient_tracking.policies.guards.base import LeagueRows
from resilient_tracking.policies.guards.priced import PricedCautionGuard
from resilient_tracking.scenario.overrides import overridden

EPS1, EPS2 = 0.02, 0.15
#: three robots on a circle around one target: each sensor's information share is equal
ANGLES = np.deg2rad([0.0, 120.0, 240.0])
POSITIONS = np.column_stack([np.cos(ANGLES), np.sin(ANGLES)])
TARGETS = np.zeros((1, 4))


def guard(**settings) -> PricedCautionGuard:
    s = shipped("sensing-perm")  # 3 robots, 300 steps
    spec = GuardsSpec.model_validate({"priced": {"enabled": True, **settings}})
    params = s.policy.params_for("failure_aware")
    built = [g for g in spec.build(team_config(s), params) if g.name == "priced"]
    return built[0]


def observation(step=0, sensing=("", "", ""), comm=("", "", ""), attacks=(), recoveries=()):
    return TeamObservation(
        step=step,
        time=0.1 * step,
        positions=POSITIONS,
        measurements=np.full((3, 1, 2), np.nan),
        sensing_ok=np.array([p == "" for p in sensing]),
        comm_ok=np.array([p == "" for p in comm]),
        sensing_persistence=tuple(sensing),
        comm_persistence=tuple(comm),
        links=np.ones((3, 3), bool),
        attacks=tuple(attacks),
        recoveries=tuple(recoveries),
    )


def zone(kind="sensing", persistence="permanent", robot=None, zone_id=0) -> ZoneEstimate:
    """A zone at the target (near every robot), or beside ``robot`` (near it alone)."""
    return ZoneEstimate(
        f"zone{zone_id}",
        kind,
        np.zeros(2) if robot is None else 1.5 * POSITIONS[robot],
        0.05 * np.eye(2),
        0.3,
        persistence,
        "attack",
        1,
        zone_id=zone_id,
    )


def priced_levels(g, zones, obs, discs=()) -> tuple[list[float], list[float]]:
    """The risk levels the guard gives the eq. 7c rows of the sensing ``zones`` and comm
    ``discs`` (keep-out discs of a comm zone's hazard) and the eq. 7d rows of the comm ``zones``
    for one league of every robot (the rows made at the paper's levels)."""
    knowledge = KnowledgeBase()
    for z in [*zones, *discs]:
        knowledge.learn(z)
    s_rows = [z for z in zones if z.kind == "sensing"] + list(discs)
    c_rows = [z for z in zones if z.kind == "comm"]
    rows = LeagueRows(
        sensing_table([sensing_row(z.mean, z.cov, z.size, chance_margin(EPS1)) for z in s_rows]),
        [z.key for z in s_rows],
        comm_table([comm_row(z.mean, z.cov, z.size, chance_margin(EPS2), 0.0) for z in c_rows]),
        [z.key for z in c_rows],
    )
    g.observe(obs)
    estimate = TargetEstimate.initial(TARGETS, 0.1, 0.1)
    g.price_rows(rows, [0, 1, 2], estimate, knowledge, obs)
    return (
        list(risk_level(rows.sensing[:, SensingRow.BETA])),
        list(risk_level(rows.comm[:, CommRow.BETA])),
    )


def test_the_risk_level_is_recovered_from_its_margin():
    for eps in (0.001, 0.02, 0.15, 0.45):
        assert risk_level(np.array(chance_margin(eps))) == pytest.approx(eps, rel=1e-9)


def test_a_permanent_failure_of_one_of_equal_sensors_at_the_start_keeps_the_papers_level():
    (eps,), _ = priced_levels(guard(), [zone()], observation(step=0))
    assert eps == pytest.approx(EPS1, rel=1e-6)


def test_reading_the_papers_levels_as_set_for_a_shorter_failure_prices_permanent_ones_higher():
    # D̄ = ½: a permanent failure of one of equal sensors costs twice what the levels are set for
    (eps,), _ = priced_levels(guard(reference_share=0.5), [zone()], observation(step=0))
    assert eps == pytest.approx(EPS1 / 2, rel=1e-6)
    ratio = guard(reference_share=0.5).cost_ratio(zone(persistence="temporary"), False, 1 / 3)
    assert ratio == pytest.approx(2 * 10 / 300)


def test_a_permanent_loss_is_never_priced_below_the_papers_level():
    # late in the mission, and for a robot that adds less than an equal share now
    (late,), _ = priced_levels(guard(), [zone()], observation(step=290))
    assert late == pytest.approx(EPS1, rel=1e-6)
    g = guard(reach=0.5)
    g.observe(observation())
    far_targets = TargetEstimate.initial(np.array([[5.0, 0.0, 0.0, 0.0]]), 0.1, 0.1)
    values = g.sensor_values(far_targets, observation())
    assert values.min() < values.max()  # unequal shares
    (eps,), _ = priced_levels(g, [zone(robot=int(np.argmin(values)))], observation())
    assert eps == pytest.approx(EPS1, rel=1e-6)


def test_a_robot_that_adds_more_than_an_equal_share_is_priced_above_it():
    g = guard(reach=0.5)
    far_targets = TargetEstimate.initial(np.array([[5.0, 0.0, 0.0, 0.0]]), 0.1, 0.1)
    values = g.sensor_values(far_targets, observation())
    best = int(np.argmax(values))
    assert values[best] > 1 / 3
    ratio = g.cost_ratio(zone(robot=best), True, float(values[best]))
    assert ratio == pytest.approx(3 * values[best])


def test_the_last_working_sensor_is_worth_the_mission():
    lost = ("permanent", "permanent", "")
    (eps,), _ = priced_levels(guard(), [zone(robot=2)], observation(sensing=lost))
    assert eps == pytest.approx(EPS1 / 3, rel=1e-6)  # ρ = M · 1 · T/T
    tight = guard(max_ratio=2.0)
    (eps,), _ = priced_levels(tight, [zone(robot=2)], observation(sensing=lost))
    assert eps == pytest.approx(EPS1 / 2, rel=1e-6)  # no tighter than ε / ρ_max


def test_a_sensor_lost_for_good_has_nothing_left_to_lose_to_a_sensing_zone():
    lost = ("permanent", "", "")
    # only robot 0 is near the zone: its sensor is gone, so the row costs nothing
    (eps,), _ = priced_levels(guard(reach=0.5), [zone(robot=0)], observation(sensing=lost))
    assert eps == pytest.approx(0.45, rel=1e-6)
    (eps,), _ = priced_levels(guard(reach=0.5), [zone(robot=0)], observation())
    assert eps == pytest.approx(EPS1, rel=1e-6)


def test_a_temporary_failure_costs_its_expected_length_learned_from_those_seen():
    g = guard()
    (eps,), (jam,) = priced_levels(
        g, [zone(persistence="temporary"), zone("comm", "temporary", zone_id=1)], observation()
    )
    # prior 10 steps of 300: ρ = 1/30, looser than ε_max allows
    assert eps == pytest.approx(0.45) and jam == pytest.approx(0.45)
    clue = ZoneClue(0, "sensing", np.zeros(2), np.eye(2), 0.3, "temporary")
    g.observe(observation(step=10, attacks=[Attack(1, clue)]))
    g.observe(observation(step=100, recoveries=[(1, "sensing")]))
    assert g.temporary_length("sensing") == pytest.approx((10 + 90) / 2)
    assert g.temporary_length("comm") == pytest.approx(10)


def test_a_zone_that_degrades_costs_its_share():
    g = guard(degrade_fraction=0.25)
    clue = ZoneClue(0, "sensing", np.zeros(2), np.eye(2), 0.3, "permanent")
    g.observe(observation(attacks=[Attack(1, clue, cause="degradation")]))
    (eps,), _ = priced_levels(g, [zone()], observation(step=0))
    assert eps == pytest.approx(EPS1 / 0.25, rel=1e-6)


def test_a_comm_zones_hazard_costs_the_tracking_of_the_radio_it_destroys():
    hazard = [zone("comm", zone_id=1)]
    (healthy,), _ = priced_levels(guard(), [], observation(), discs=hazard)
    assert healthy == pytest.approx(EPS1, rel=1e-6)  # the disc's level, as a sensor's loss
    none = ("permanent", "permanent", "permanent")
    (gone,), _ = priced_levels(guard(), [], observation(comm=none), discs=hazard)
    assert gone == pytest.approx(0.45)  # no radio left to lose


def test_the_default_team_prices_caution_and_moves_otherwise_than_the_fixed_levels():
    from resilient_tracking.sim.episode import run_episode

    s = shipped("sensing-temp").with_overrides(steps=120)
    adaptive = {"estimator.type": "adaptive"}  # the same estimator, to see the guard alone
    fixed = run_episode(overridden(s.with_team("route"), adaptive), seed=1)
    priced = run_episode(s, seed=1)
    assert np.all(np.isfinite(priced["team"]["trace"]))
    assert not fixed["robots"].equals(priced["robots"])


def test_without_the_information_share_a_robot_is_worth_the_redundancy_left():
    g = guard(reach=0.5, information_share=False)
    far_targets = TargetEstimate.initial(np.array([[5.0, 0.0, 0.0, 0.0]]), 0.1, 0.1)
    np.testing.assert_allclose(g.sensor_values(far_targets, observation()), [1 / 3] * 3)
    lost = ("permanent", "", "")
    np.testing.assert_allclose(
        g.sensor_values(far_targets, observation(sensing=lost)), [0, 0.5, 0.5]
    )
