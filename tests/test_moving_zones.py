"""Moving zones and zones of two kinds (docs/model.md §2.1): truth, clues, knowledge, schema."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from resilient_tracking.belief.knowledge import KnowledgeBase, ZoneEstimate
from resilient_tracking.build import zone_map
from resilient_tracking.runs.reading import run_data
from resilient_tracking.scenario import ScenarioError, parse_scenario
from resilient_tracking.sim.episode import run_episode
from resilient_tracking.viz.trajectories import plot_trajectory_map, zones_at
from resilient_tracking.world import World

STILL = {"type": "constant_velocity", "velocity": [0.0, 0.0]}
SIGMA = [[0.3, 0.1], [0.1, 0.2]]
VELOCITY = [0.3, -0.2]


def scenario(zones: list[dict[str, Any]], robots: list[list[float]] | None = None, **extra: Any):
    data: dict[str, Any] = {
        "dt": 0.1,
        "steps": 40,
        "robots": [{"start": p} for p in (robots or [[-3.0, 2.5], [-3.0, -2.5]])],
        "targets": [
            {"start": [3.0, 3.0], "motion": STILL},
            {"start": [-3.0, 0.0], "motion": {"type": "ncv", "velocity": [0.1, 0.0]}},
        ],
        "zones": zones,
        **extra,
    }
    return parse_scenario(data)


def sensing(**extra: Any) -> dict[str, Any]:
    return {"kind": "sensing", "mu": [1.0, -0.5], "sigma": SIGMA, "radius": 0.4, **extra}


def both(**extra: Any) -> dict[str, Any]:
    return {"kind": ["sensing", "comm"], "mu": [0.0, 0.0], "sigma": SIGMA, "radius": 0.4,
            "delta2": 0.2, **extra}  # fmt: skip


def advance(world: World, steps: int) -> None:
    for _ in range(steps):
        world.step(np.zeros((world.n_robots, 2)))


# ---------------------------------------------------------------------------- moving zones


def test_centre_and_prior_mean_follow_the_motion() -> None:
    world = World(
        scenario([sensing(motion={"type": "constant_velocity", "velocity": VELOCITY})]), 3
    )
    zone = world.zones[0]
    mu0, offset = zone.mu.copy(), zone.center - zone.mu
    advance(world, 25)
    expected = mu0 + np.array(VELOCITY) * 25 * world.dt
    np.testing.assert_allclose(zone.mu, expected, atol=1e-12)
    np.testing.assert_allclose(zone.center - zone.mu, offset, atol=1e-12)
    # the gaussian hazard is the density of the prior where it is now: highest at mu(t)
    p = zone.hazard.probability(np.array([expected, mu0]), world.step_index, world.dt)
    assert p[0] > p[1]
    # the influence region (temporary recovery) is around the current mean
    assert zone.in_influence(expected) and not zone.in_influence(mu0)


def test_disk_hazard_and_jammer_follow_the_true_centre() -> None:
    moving = {"type": "constant_velocity", "velocity": VELOCITY}
    disk = sensing(motion=moving, hazard={"model": "disk", "p_hit": 1.0, "f_act": 10.0})
    world = World(scenario([disk, {**both(motion=moving), "mu": [-1.0, 1.0]}]), 3)
    advance(world, 20)
    sensing_zone, comm_zone = world.zones
    hit = sensing_zone.hazard.probability(sensing_zone.center[None, :], 20, world.dt)
    assert hit[0] == 1.0
    np.testing.assert_array_equal(world._jammer_centers[0], comm_zone.center)


def test_clue_is_a_snapshot_at_the_attack() -> None:
    world = World(
        scenario([sensing(motion={"type": "constant_velocity", "velocity": VELOCITY})]), 3
    )
    advance(world, 10)
    clue = world.zones[0].clue()
    then = world.zones[0].mu.copy()
    advance(world, 10)
    np.testing.assert_array_equal(clue.mu, then)
    assert not np.allclose(clue.mu, world.zones[0].mu)


def test_a_robot_attacked_learns_where_the_zone_was() -> None:
    # a permanent, certain disk hazard that sweeps over the robots
    zone = sensing(
        mu=[-1.0, 1.5],
        sigma=[[0.01, 0.0], [0.0, 0.01]],
        radius=1.5,
        persistence="permanent",
        hazard={"model": "disk", "p_hit": 1.0, "f_act": 10.0},
        motion={"type": "constant_velocity", "velocity": [-0.5, 0.0]},
    )
    result = run_episode(scenario([zone]), policy="failure_aware", seed=2)
    knowledge = result.tables["knowledge"]
    learned = knowledge[(knowledge["zone"] == 0) & (knowledge["source"] == "attack")]
    assert len(learned), "the zone attacked nobody"
    first = learned.iloc[0]
    tracks = result.tables["zone_tracks"].set_index("step")
    step = int(first["step"])
    assert step > 0
    assert first["x"] == pytest.approx(tracks.at[step, "mu_x"])
    assert first["x"] != pytest.approx(-1.0)


def test_zone_tracks_table_records_moving_zones_only() -> None:
    moving = sensing(motion={"type": "circle", "center": [1.0, 0.0], "angular_speed": 0.5})
    result = run_episode(scenario([sensing(mu=[-1.0, -1.0]), moving]), "vanilla", seed=1)
    tracks = result.tables["zone_tracks"]
    assert set(tracks["zone"]) == {1}
    assert list(tracks["step"]) == list(range(40))
    radius = np.hypot(tracks["mu_x"] - 1.0, tracks["mu_y"] - 0.0)
    np.testing.assert_allclose(radius, 0.5, atol=1e-9)
    static = run_episode(scenario([sensing()]), "vanilla", seed=1).tables["zone_tracks"]
    assert static.empty and list(static.columns) == list(tracks.columns)


def test_static_zone_does_not_move_and_draws_nothing_new() -> None:
    world = World(scenario([sensing()]), 5)
    mu, center = world.zones[0].mu.copy(), world.zones[0].center.copy()
    advance(world, 30)
    np.testing.assert_array_equal(world.zones[0].mu, mu)
    np.testing.assert_array_equal(world.zones[0].center, center)
    assert world.zones[0].track == []


def test_random_zone_motion_has_its_own_stream() -> None:
    ncv = {"type": "ncv", "velocity": [0.1, 0.0], "accel_std": 0.5}
    still, moving = World(scenario([sensing()]), 7), World(scenario([sensing(motion=ncv)]), 7)
    again = World(scenario([sensing(motion=ncv)]), 7)
    other = World(scenario([sensing(motion=ncv)]), 8)
    for world in (still, moving, again, other):
        advance(world, 30)
    # the targets' own noisy motion draws the same numbers with or without a moving zone
    np.testing.assert_array_equal(still.target_states, moving.target_states)
    np.testing.assert_array_equal(moving.zones[0].mu, again.zones[0].mu)
    assert not np.allclose(moving.zones[0].mu, other.zones[0].mu)
    # the noisy zone wanders off a straight line
    straight = np.array([1.0, -0.5]) + np.array([0.1, 0.0]) * 3.0
    assert not np.allclose(moving.zones[0].mu, straight)


@pytest.mark.parametrize(
    ("motion", "field"),
    [
        ({"type": "evasive", "base": STILL, "radius": 1.0, "speed": 0.5}, "zones.0.motion.type"),
        ({"type": "circle", "center": [1.0, -0.5], "angular_speed": 0.1}, "zones.0.motion.center"),
        ({"type": "constant_velocity", "velocity": [0.1, 0.0], "speed": 1}, "zones.0.motion.speed"),
    ],
)
def test_bad_zone_motions_name_the_field(motion: dict[str, Any], field: str) -> None:
    with pytest.raises(ScenarioError) as err:
        scenario([sensing(motion=motion)])
    assert any(p.startswith(field + ":") for p in err.value.problems), err.value.problems


# ---------------------------------------------------------------------------- two kinds


def test_one_draw_fails_both_capabilities_and_the_clue_tells_both() -> None:
    zone = both(persistence="permanent", hazard={"model": "disk", "p_hit": 1.0, "f_act": 10.0})
    world = World(scenario([zone], robots=[[-3.0, 2.5], [-3.0, -2.5]]), 1)
    world.zones[0].center[:] = [-3.0, 2.5]  # truth put on robot 0, whatever was drawn
    advance(world, 1)
    assert not world.capability_ok("sensing")[0] and not world.capability_ok("comm")[0]
    assert world.capability_ok("sensing")[1] and world.capability_ok("comm")[1]
    attacks = world.observe().attacks
    hazard = [a for a in attacks if a.cause == "hazard"]
    assert sorted(a.clue.kind for a in hazard) == ["comm", "sensing"]
    assert all(a.robot == 0 for a in hazard)
    assert all(dict(a.clue.modes) == {"sensing": 0.4, "comm": 0.2} for a in hazard)
    assert {a.clue.kind: a.clue.size for a in hazard} == {"sensing": 0.4, "comm": 0.2}


def test_the_team_knows_both_kinds() -> None:
    world = World(scenario([both()]), 1)
    estimates = ZoneEstimate.all_from_clue(world.zones[0].clue("comm"), step=4)
    kb = KnowledgeBase()
    for e in estimates:
        assert kb.learn(e)
    assert [z.size for z in kb.of_kind("sensing")] == [0.4]
    assert [z.size for z in kb.of_kind("comm")] == [0.2]
    assert len({z.key for z in estimates}) == 2
    # a clue of a zone of one kind gives the one estimate it always gave
    single = World(scenario([sensing()]), 1).zones[0].clue()
    assert [e.key for e in ZoneEstimate.all_from_clue(single, 0)] == ["zone0"]


def test_a_mapped_zone_of_two_kinds_is_known_as_both() -> None:
    kinds = sorted((z.kind, z.size) for z in zone_map(scenario([both(known=True)])))
    assert kinds == [("comm", 0.2), ("sensing", 0.4)]


def test_episode_with_a_zone_of_two_kinds_learns_both_from_an_attack() -> None:
    zone = both(mu=[-3.0, 2.5], sigma=[[0.01, 0.0], [0.0, 0.01]], persistence="permanent",
                hazard={"model": "disk", "p_hit": 1.0, "f_act": 10.0})  # fmt: skip
    result = run_episode(scenario([zone]), policy="failure_aware", seed=1)
    attacks = result.tables["events"].query(
        "event == 'attack' and robot == 0 and cause == 'hazard'"
    )
    assert set(attacks["kind"]) == {"sensing", "comm"}
    assert attacks.groupby("kind")["step"].min().nunique() == 1  # both from the same draw
    learned = result.tables["knowledge"].query("robot == 0 and zone == 0")
    assert set(learned["kind"]) == {"sensing", "comm"}
    assert result.tables["zones"]["kind"].tolist() == ["sensing+comm"]


@pytest.mark.parametrize(
    ("kind", "field", "words"),
    [
        (["sensing"], "zones.0.kind", "at least 2"),
        (["sensing", "sensing"], "zones.0.kind", "sensing and comm"),
        (["sensing", "radio"], "zones.0.kind.1", "'sensing' or 'comm'"),
        ("radio", "zones.0", "kind must be"),
    ],
)
def test_bad_kinds_name_the_field(kind: Any, field: str, words: str) -> None:
    with pytest.raises(ScenarioError) as err:
        scenario([both(kind=kind)])
    assert any(p.startswith(field + ":") and words in p for p in err.value.problems), (
        err.value.problems
    )


def test_a_zone_of_two_kinds_needs_both_sizes() -> None:
    data = both()
    del data["delta2"]
    with pytest.raises(ScenarioError) as err:
        scenario([data])
    assert any(p.startswith("zones.0.delta2:") for p in err.value.problems)


def test_maps_draw_a_moving_zone_where_it_is_at_the_frame() -> None:
    moving = sensing(motion={"type": "constant_velocity", "velocity": VELOCITY})
    tables = run_episode(scenario([sensing(mu=[-1.0, -1.0]), moving]), "vanilla", seed=1).tables
    at = zones_at(tables["zones"], tables["zone_tracks"], 10).set_index("zone")
    row = tables["zone_tracks"].query("zone == 1 and step == 10").iloc[0]
    assert (at.at[1, "true_x"], at.at[1, "mu_y"]) == (row["true_x"], row["mu_y"])
    assert at.at[0, "true_x"] == tables["zones"].set_index("zone").at[0, "true_x"]
    run = run_data(run_episode(scenario([both(), moving]), "vanilla", 1))
    ax = plot_trajectory_map(run, None, until_step=10)
    assert len(ax.patches) >= 3  # the disk and ellipse of the zone of two kinds, the other disk
