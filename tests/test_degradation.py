"""Partial degradation by zones (``zones[i].effect: {type: degrade}``, docs/model.md §2): the
world's degraded measurements and lossy links, who learns of it, when it ends, the schema, and
that a scenario without it draws what it drew before."""

from __future__ import annotations

import copy
from typing import Any

import numpy as np
import pandas as pd
import pytest

from helpers import shipped
from resilient_tracking.events import TRUTH_EVENTS
from resilient_tracking.scenario import Scenario, ScenarioError
from resilient_tracking.sim.episode import run_episode
from resilient_tracking.team import Team
from resilient_tracking.world.world import World

N_DRAWS = 3000


def _scenario(base: str, **effect: Any) -> dict[str, Any]:
    data = copy.deepcopy(shipped(base).model_dump(mode="json"))
    data["zones"][0]["effect"] = {"type": "degrade", **effect}
    return data


def _world(data: dict[str, Any], seed: int = 3) -> World:
    return World(Scenario.parse(data), seed)


def _forced(base: str, robot: int = 0, persistence: str = "permanent", **effect: Any) -> World:
    """A world whose zone 0 is centred on ``robot`` and hits it at the first step for sure."""
    data = _scenario(base, **effect)
    zone = data["zones"][0]
    start = data["robots"][robot]["start"]
    zone.update(
        mu=list(start),
        sigma=[[1e-4, 0.0], [0.0, 1e-4]],
        persistence=persistence,
        hazard={"model": "disk", "f_act": 10.0, "p_hit": 1.0},
        m_recover=3.0,
    )
    if zone["kind"] == "sensing":
        zone["radius"] = 0.05
    else:
        zone["delta2"] = 1e-4  # a jammer too weak to cut the links measured here
    world = World(Scenario.parse(data), 5)
    world.place(world.robot_positions, world.target_states[:, :2])
    return world


def _residuals(world: World, draws: int = N_DRAWS) -> np.ndarray:
    """(draws, M, N, D) measurements minus their noise-free values, the world held still."""
    clean = world.sensor.predict(
        world.robot_positions[:, None, :], world.target_states[None, :, :2]
    )
    out = np.array([world.observe().measurements - clean for _ in range(draws)])
    for a in world.sensor.ANGLES:
        out[..., a] = (out[..., a] + np.pi) % (2 * np.pi) - np.pi
    return out


def _nominal_variance(world: World) -> np.ndarray:
    d = np.linalg.norm(
        world.target_states[None, :, :2] - world.robot_positions[:, None, :], axis=-1
    )
    return world.sensor.noise_variance(d)  # (M, N, D)


# ---------------------------------------------------------------------------- sensing


def test_degraded_noise_is_consistent_with_the_degraded_R_not_the_nominal_one() -> None:
    world = _forced("sensing-perm", noise_factor=5.0)
    assert world.degradations.degraded("sensing").tolist() == [True, False, False]
    e = _residuals(world)
    r = _nominal_variance(world)
    # normalised innovation squared against the truth, per robot: chi² with D = 2 channels
    nis_honest = np.einsum("kntd,ntd->knt", e**2, 1.0 / (25.0 * r))[:, 0].mean()
    nis_nominal = np.einsum("kntd,ntd->knt", e**2, 1.0 / r)[:, 0].mean()
    nis_healthy = np.einsum("kntd,ntd->knt", e**2, 1.0 / r)[:, 1:].mean()
    band = 4 * 2.0 / np.sqrt(N_DRAWS * 3)  # 4 σ of a mean of chi²(2) over draws × targets
    assert abs(nis_honest - 2.0) < band
    assert nis_nominal > 2.0 * 10  # 25 × 2 expected: far out of any band
    assert abs(nis_healthy - 2.0) < band * 0.8


def test_bias_shifts_the_mean_range() -> None:
    world = _forced("sensing-perm", bias=0.3)
    e = _residuals(world, 2000)
    std = np.sqrt(_nominal_variance(world))[0, :, 0]
    mean_range_error = e[:, 0, :, 0].mean(axis=0)
    assert np.all(np.abs(mean_range_error - 0.3) < 4 * std / np.sqrt(2000))
    assert np.all(np.abs(e[:, 1, :, 0].mean(axis=0)) < 4 * std / np.sqrt(2000))
    assert np.all(np.abs(e[:, 0, :, 1].mean(axis=0)) < 0.05)  # the bearing is not biased


def test_dropout_loses_that_share_of_the_robots_measurements_only() -> None:
    world = _forced("sensing-perm", dropout=0.3)
    lost = np.array([np.isnan(world.observe().measurements[..., 0]) for _ in range(N_DRAWS)])
    rate = lost[:, 0].mean()
    assert abs(rate - 0.3) < 4 * np.sqrt(0.3 * 0.7 / (N_DRAWS * 3))
    assert not lost[:, 1:].any()
    # both channels of a lost measurement are lost together
    z = world.observe().measurements
    assert (np.isnan(z[..., 0]) == np.isnan(z[..., 1])).all()


def test_bearing_only_sensor_degrades_its_bearing_noise() -> None:
    world = _forced("bearing-only", noise_factor=3.0, dropout=0.0)
    e = _residuals(world, 2000)
    ratio = (e[:, 0, :, 0] ** 2).mean(axis=0) / _nominal_variance(world)[0, :, 0]
    assert np.all(np.abs(ratio - 9.0) < 9.0 * 4 * np.sqrt(2 / 2000))


def test_a_bias_on_a_sensor_without_range_is_an_error_naming_it() -> None:
    with pytest.raises(ScenarioError, match=r"zones\.0\.effect\.bias: the bearing_only sensor"):
        Scenario.parse(_scenario("bearing-only", bias=0.2))


# ---------------------------------------------------------------------------- comm


def test_loss_probability_drops_links_of_the_degraded_robot_at_that_rate() -> None:
    world = _forced("comm-perm", robot=1, loss_probability=0.4)
    positions, targets = world.robot_positions.copy(), world.target_states[:, :2].copy()
    up = []
    for _ in range(N_DRAWS):
        world.place(positions, targets, first=True)
        up.append(world.links.copy())
    links = np.array(up)
    full = links.any(axis=0)  # the links that exist without loss
    assert full[0, 1] and full[1, 2] and full[0, 2]
    tol = 4 * np.sqrt(0.4 * 0.6 / N_DRAWS)
    assert abs(links[:, 0, 1].mean() - 0.6) < tol
    assert abs(links[:, 1, 2].mean() - 0.6) < tol
    assert links[:, 0, 2].all()  # neither end degraded: never lost
    assert (links == links.transpose(0, 2, 1)).all()
    # the two links of robot 1 are drawn independently
    both = (links[:, 0, 1] & links[:, 1, 2]).mean()
    assert abs(both - 0.36) < tol
    assert world.capability_ok("comm").all()  # a lossy radio still works


def test_a_link_between_two_degraded_robots_combines_both_losses() -> None:
    world = _forced("comm-perm", robot=1, loss_probability=0.4)
    world.degradations.start(0, world.zones[0], world.step_index)
    positions, targets = world.robot_positions.copy(), world.target_states[:, :2].copy()
    up = []
    for _ in range(N_DRAWS):
        world.place(positions, targets, first=True)
        up.append(world.links[0, 1])
    assert abs(np.mean(up) - 0.36) < 4 * np.sqrt(0.36 * 0.64 / N_DRAWS)


def test_comm_fields_on_a_sensing_zone_and_back_are_errors_naming_them() -> None:
    with pytest.raises(ScenarioError, match=r"zones\.0\.effect: .*loss_probability"):
        Scenario.parse(_scenario("sensing-perm", loss_probability=0.2))
    for name in ("noise_factor", "bias", "dropout"):
        with pytest.raises(ScenarioError, match=rf"zones\.0\.effect: .*{name}"):
            Scenario.parse(_scenario("comm-perm", **{name: 1.0}))


@pytest.mark.parametrize(
    ("base", "field", "value"),
    [
        ("sensing-perm", "noise_factor", 0.5),
        ("sensing-perm", "noise_factor", 1e5),
        ("sensing-perm", "bias", 1e8),
        ("sensing-perm", "dropout", 1.5),
        ("sensing-perm", "dropout", -0.1),
        ("comm-perm", "loss_probability", 1.01),
        ("sensing-perm", "announced", "yes"),
    ],
)
def test_out_of_bounds_effect_numbers_are_errors_naming_the_field(
    base: str, field: str, value: object
) -> None:
    with pytest.raises(ScenarioError, match=rf"zones\.0\.effect\.{field}:"):
        Scenario.parse(_scenario(base, **{field: value}))


def test_a_fail_effect_is_always_announced_and_the_type_is_checked() -> None:
    data = copy.deepcopy(shipped("sensing-perm").model_dump(mode="json"))
    data["zones"][0]["effect"] = {"type": "fail", "announced": False}
    with pytest.raises(ScenarioError, match=r"zones\.0\.effect\.announced:"):
        Scenario.parse(data)
    data["zones"][0]["effect"] = {"type": "weaken"}
    with pytest.raises(ScenarioError, match=r"zones\.0\.effect: type must be 'fail'"):
        Scenario.parse(data)


# ---------------------------------------------------------------------------- who knows


def test_silent_degradation_gives_the_team_no_event_and_the_truth_an_onset() -> None:
    world = _forced("sensing-perm", noise_factor=5.0, announced=False)
    truth = world.take_truth_events()
    assert [(e.event, e.robot, e.kind, e.cause) for e in truth] == [
        ("degraded", 0, "sensing", "silent")
    ]
    obs = world.observe()
    assert obs.attacks == () and obs.sensing_ok.all()
    team = Team.from_scenario(world.scenario, world.target_states)
    events = team.step(obs).events
    assert not [e for e in events if e.event in ("attack", "zone_learned", *TRUTH_EVENTS)]
    assert world.take_truth_events() == []  # taken once


def test_announced_degradation_gives_an_attack_event_and_the_clue() -> None:
    world = _forced("sensing-perm", noise_factor=5.0, announced=True)
    obs = world.observe()
    assert len(obs.attacks) == 1
    attack = obs.attacks[0]
    assert (attack.robot, attack.cause, attack.clue.zone_id) == (0, "degradation", 0)
    assert obs.sensing_ok.all()  # degraded, not failed
    team = Team.from_scenario(world.scenario, world.target_states)
    events = team.step(obs).events
    kinds = [(e.event, e.robot, e.cause) for e in events if e.event in ("attack", "zone_learned")]
    assert ("attack", 0, "degradation") in kinds
    assert any(e.event == "zone_learned" and e.source == "attack" for e in events)


@pytest.mark.parametrize("announced", [True, False])
def test_temporary_degradation_ends_outside_the_influence_region(announced: bool) -> None:
    world = _forced("sensing-perm", persistence="temporary", noise_factor=5.0, announced=announced)
    world.take_truth_events()
    world.observe()
    positions = world.robot_positions.copy()
    world.place(positions, world.target_states[:, :2])  # still inside: lasts
    assert world.degradations.degraded("sensing")[0]
    positions[0] += [0.0, 0.5]  # far outside m_recover · σ = 0.03 m
    world.place(positions, world.target_states[:, :2])
    assert not world.degradations.degraded("sensing").any()
    ended = world.take_truth_events()
    assert [(e.event, e.robot, e.zone) for e in ended] == [("degradation_ended", 0, 0)]
    obs = world.observe()
    assert obs.recoveries == (((0, "sensing"),) if announced else ())
    e = _residuals(world, 1000)
    nis = (e[:, 0] ** 2 / _nominal_variance(world)[0]).sum(axis=-1).mean()
    assert abs(nis - 2.0) < 4 * 2.0 / np.sqrt(3000)  # nominal noise again


def test_permanent_degradation_does_not_end() -> None:
    world = _forced("sensing-perm", persistence="permanent", noise_factor=5.0)
    positions = world.robot_positions.copy()
    positions[0] += [0.0, 0.5]
    world.place(positions, world.target_states[:, :2])
    assert world.degradations.degraded("sensing")[0]


# ---------------------------------------------------------------------------- bit for bit


def test_an_explicit_fail_effect_is_the_default_bit_for_bit() -> None:
    base = shipped("sensing-temp").with_overrides(steps=40)
    data = base.model_dump(mode="json")
    data["zones"][0]["effect"] = {"type": "fail"}
    explicit = Scenario.parse(data)
    a, b = run_episode(base, seed=2), run_episode(explicit, seed=2)
    for name in ("team", "robots", "targets", "events", "zones"):
        pd.testing.assert_frame_equal(a.tables[name], b.tables[name])


def test_degrading_zones_leave_the_existing_streams_alone() -> None:
    """Zone centres, attack draws and the nominal measurements are those of the same mission
    with a failing zone, until the first attack changes what happens."""
    fail, degrade = World(shipped("sensing-perm"), 4), World(shipped("sensing-degrade"), 4)
    assert np.array_equal(fail.zones[0].center, degrade.zones[0].center)
    for _ in range(3):
        za, zb = fail.observe().measurements, degrade.observe().measurements
        assert np.array_equal(za, zb)
    assert np.array_equal(fail._rng_attacks.random(5), degrade._rng_attacks.random(5))


def test_degraded_runs_are_deterministic_and_record_truth_rows() -> None:
    scenario = shipped("sensing-degrade").with_overrides(steps=120)
    a, b = run_episode(scenario, seed=1), run_episode(scenario, seed=1)
    for name in ("team", "robots", "targets", "events"):
        pd.testing.assert_frame_equal(a.tables[name], b.tables[name])
    events = a.tables["events"]
    onsets = events[events.event == "degraded"]
    assert len(onsets) >= 1
    assert set(onsets.cause) == {"silent"} and set(onsets.kind) == {"sensing"}
    assert (events.event != "attack").all()  # silent: the team saw nothing
    assert events.step.is_monotonic_increasing
    other = run_episode(scenario, seed=2).tables["events"]
    assert not events.equals(other)
