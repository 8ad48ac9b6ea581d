"""Spreading compromise of a permanent comm zone (truth) and the quarantine that contains it
(docs/model.md §2, §6.2)."""

from __future__ import annotations

import copy
from typing import Any

import numpy as np
import pytest

from helpers import shipped
from resilient_tracking.observation import Attack, TeamObservation, ZoneClue
from resilient_tracking.policies.guards.quarantine import QuarantineParams, QuarantineWatch
from resilient_tracking.scenario import ScenarioError, overridden, parse_scenario
from resilient_tracking.sim.episode import run_episode
from resilient_tracking.world import World

STILL = {"type": "constant_velocity", "velocity": [0.0, 0.0]}
FAR = [30.0, 30.0]  # zones far from every robot: their hazard never fires, they jam nothing
SIGMA = [[0.01, 0.0], [0.0, 0.01]]


def comm_zone(spread: float | None = None, mu: list[float] = FAR, **extra: Any) -> dict[str, Any]:
    zone: dict[str, Any] = {
        "kind": "comm",
        "mu": mu,
        "sigma": SIGMA,
        "delta2": 0.1,
        "persistence": "permanent",
        "hazard": {"model": "disk", "p_hit": 0.0},
        **extra,
    }
    if spread is not None:
        zone["spread"] = {"probability": spread}
    return zone


def world(
    robots: list[list[float]], zones: list[dict[str, Any]], seed: int, comm_range: float = 2.0
) -> World:
    data = {
        "dt": 0.1,
        "comm_range": comm_range,
        "workspace": {"xmin": -40, "xmax": 40, "ymin": -40, "ymax": 40},
        "robots": [{"start": p} for p in robots],
        "targets": [{"start": [0.0, 5.0], "motion": STILL}],
        "zones": zones,
    }
    return World(parse_scenario(data), seed)


def compromise(w: World, robot: int, zone: int = 0) -> None:
    """The zone's hazard attack on ``robot`` now (as its draw would make it)."""
    w._fail(robot, w.zones[zone], "hazard", "comm")


def steps(w: World, n: int) -> list[Attack]:
    """``n`` steps standing still; every attack observed."""
    attacks: list[Attack] = []
    for _ in range(n):
        w.step(np.zeros((w.n_robots, 2)))
        attacks += w.observe().attacks
    return attacks


def spread_victims(attacks: list[Attack]) -> list[int]:
    return [a.robot for a in attacks if a.cause == "spread"]


# ---------------------------------------------------------------------------- truth


def test_spread_passes_at_about_its_probability_per_step_over_a_link() -> None:
    p, horizon, seeds = 0.2, 30, 300
    infected = exposure = 0
    for seed in range(seeds):
        w = world([[0.0, 0.0], [1.0, 0.0]], [comm_zone(p)], seed)
        compromise(w, 0)
        w.observe()
        for k in range(1, horizon + 1):
            w.step(np.zeros((2, 2)))
            if spread_victims(list(w.observe().attacks)):
                infected += 1
                exposure += k
                break
        else:
            exposure += horizon
    rate = infected / exposure  # maximum likelihood of a geometric per-step probability
    # about 300 infections: the standard error of the rate is about 0.011
    assert abs(rate - p) < 0.045


def test_the_victim_feels_the_zones_permanent_attack_with_its_clue() -> None:
    w = world([[0.0, 0.0], [1.0, 0.0]], [comm_zone(1.0)], seed=1)
    compromise(w, 0)
    w.observe()
    w.step(np.zeros((2, 2)))
    obs = w.observe()
    (attack,) = obs.attacks
    assert (attack.robot, attack.cause) == (1, "spread")
    assert attack.clue.zone_id == 0 and attack.clue.kind == "comm"
    assert attack.clue.persistence == "permanent"
    np.testing.assert_array_equal(attack.clue.mu, w.zones[0].mu)
    assert obs.comm_persistence == ("permanent", "permanent")
    assert not obs.comm_ok.any() and not obs.links.any()
    assert w.failures["comm"][1].source == 0  # type: ignore[union-attr]


def test_spread_needs_a_link_out_of_range_nothing_passes() -> None:
    w = world([[0.0, 0.0], [2.5, 0.0]], [comm_zone(1.0)], seed=2, comm_range=2.0)
    compromise(w, 0)
    assert spread_victims(steps(w, 100)) == []
    assert w.capability_ok("comm")[1]


def test_spread_needs_a_link_a_jammed_one_passes_nothing() -> None:
    # a second comm zone's true centre next to robot 1 jams its every link, robot 0's too
    jammer = comm_zone(mu=[1.0, 0.05], delta2=0.5, persistence="temporary")
    jammer["sigma"] = [[1e-6, 0.0], [0.0, 1e-6]]
    w = world([[0.0, 0.0], [1.0, 0.0]], [comm_zone(1.0), jammer], seed=3)
    compromise(w, 0)
    attacks = steps(w, 50)
    assert spread_victims(attacks) == []
    assert w.persistence("comm")[1] != "permanent"


def test_spread_chains_through_linked_teammates() -> None:
    # 0 and 2 are out of range of each other: 2 can only be infected by 1
    w = world([[0.0, 0.0], [1.5, 0.0], [3.0, 0.0]], [comm_zone(0.3)], seed=4)
    compromise(w, 0)
    victims = spread_victims(steps(w, 200))
    assert victims == [1, 2]
    sources = [w.failures["comm"][i].source for i in (1, 2)]  # type: ignore[union-attr]
    assert sources == [0, 1]


def test_only_a_spreading_zones_compromise_spreads() -> None:
    # zone 1 is permanent comm without spread; zone 0 spreads (so the spread stream exists)
    w = world([[0.0, 0.0], [1.0, 0.0]], [comm_zone(1.0), comm_zone()], seed=5)
    compromise(w, 0, zone=1)
    assert spread_victims(steps(w, 100)) == []
    assert w.capability_ok("comm")[1]


def test_a_robot_hit_this_step_spreads_from_the_next_step_on() -> None:
    w = world([[0.0, 0.0], [1.0, 0.0]], [comm_zone(1.0)], seed=6)
    w.step(np.zeros((2, 2)))
    compromise(w, 0)  # as if the zone hit it in this step
    w.observe()
    assert w.capability_ok("comm")[1]
    w.step(np.zeros((2, 2)))
    assert spread_victims(list(w.observe().attacks)) == [1]


# ---------------------------------------------------------------------------- schema


@pytest.mark.parametrize(
    ("zone", "field"),
    [
        (comm_zone(0.1, persistence="temporary"), "spread: only a permanent comm zone"),
        (
            {
                "kind": "sensing",
                "mu": [0, 0],
                "sigma": SIGMA,
                "radius": 0.5,
                "spread": {"probability": 0.1},
            },
            "spread: only a permanent comm zone",
        ),
        (comm_zone(1.5), "zones.0.spread.probability"),
        (comm_zone(0.0), "zones.0.spread.probability"),
        ({**comm_zone(), "spread": {"probability": 0.1, "rate": 2}}, "zones.0.spread.rate"),
    ],
)
def test_a_wrong_spread_is_an_error_naming_the_field(zone: dict[str, Any], field: str) -> None:
    data = {"robots": [{"start": [0, 0]}], "targets": [{"start": [1, 1]}], "zones": [zone]}
    with pytest.raises(ScenarioError) as err:
        parse_scenario(data)
    assert field in str(err.value)


# ---------------------------------------------------------------------------- episodes


def without_spread(name: str) -> Any:
    data = shipped(name).model_dump(mode="json")
    plain = copy.deepcopy(data)
    for zone in plain["zones"]:
        zone.pop("spread", None)
    return parse_scenario(plain)


def test_a_spreading_zone_changes_no_other_draw() -> None:
    spreading = shipped("comm-spread").with_overrides(steps=120)
    plain = without_spread("comm-spread").with_overrides(steps=120)
    a = run_episode(spreading, policy="vanilla", seed=102).tables
    b = run_episode(plain, policy="vanilla", seed=102).tables
    first = a["events"][a["events"].cause == "spread"].step.min()
    assert first < 120 and not (b["events"].cause == "spread").any()
    # up to the first infection, the same episode: same hazard attack, same targets and noise
    same = a["team"].step < first
    assert a["team"][same].equals(b["team"][same])
    truth = ["step", "target", "x", "y"]
    assert a["targets"][truth].equals(b["targets"][truth])


def test_comm_spread_is_deterministic() -> None:
    scenario = shipped("comm-spread").with_overrides(steps=120)
    a = run_episode(scenario, policy="failure_aware", seed=104).tables
    b = run_episode(scenario, policy="failure_aware", seed=104).tables
    for table in ("team", "robots", "events"):
        assert a[table].equals(b[table])
    assert (a["events"].cause == "spread").sum() >= 1


@pytest.mark.parametrize("policy", ["vanilla", "sog"])
def test_the_baselines_run_on_comm_spread(policy: str) -> None:
    result = run_episode(shipped("comm-spread").with_overrides(steps=60), policy=policy, seed=1)
    assert len(result.tables["team"]) == 60


def infections(scenario: Any, seeds: range) -> int:
    total = 0
    for seed in seeds:
        events = run_episode(scenario, policy="failure_aware", seed=seed).tables["events"]
        total += int(((events.event == "attack") & (events.cause == "spread")).sum())
    return total


@pytest.mark.slow
def test_quarantine_reduces_infections_on_comm_spread() -> None:
    scenario = shipped("comm-spread").with_overrides(steps=160)
    guarded = overridden(scenario, {"guards.quarantine.enabled": True})
    seeds = range(101, 106)
    plain, contained = infections(scenario, seeds), infections(guarded, seeds)
    assert plain >= 2 * len(seeds)
    assert contained <= plain / 2


# ---------------------------------------------------------------------------- the watch


def observation(
    step: int, positions: list[list[float]], links: np.ndarray, attacks: tuple[Attack, ...] = ()
) -> TeamObservation:
    m = len(positions)
    return TeamObservation(
        step=step,
        time=step * 0.1,
        positions=np.array(positions, dtype=float),
        measurements=np.full((m, 1, 2), np.nan),
        sensing_ok=np.ones(m, dtype=bool),
        comm_ok=np.ones(m, dtype=bool),
        sensing_persistence=("",) * m,
        comm_persistence=("",) * m,
        links=links,
        attacks=attacks,
    )


def clue(persistence: str = "permanent") -> ZoneClue:
    return ZoneClue(0, "comm", np.zeros(2), 0.01 * np.eye(2), 0.1, persistence)  # type: ignore[arg-type]


def chain_links(m: int, pairs: list[tuple[int, int]]) -> np.ndarray:
    links = np.zeros((m, m), dtype=bool)
    for i, j in pairs:
        links[i, j] = links[j, i] = True
    return links


def test_the_announcement_is_heard_by_the_robots_linked_at_the_tick_before() -> None:
    positions = [[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [9.0, 0.0]]
    watch = QuarantineWatch(4, QuarantineParams(), comm_range=2.0)
    watch.observe(observation(0, positions, chain_links(4, [(0, 1), (1, 2)])))
    hit = (Attack(1, clue()),)
    watch.observe(observation(1, positions, chain_links(4, [(0, 3)]), hit))
    assert watch.quarantined([0], 1) == [1] and watch.quarantined([2], 1) == [1]
    assert watch.quarantined([3], 1) == []
    # robot 3 learns it by sharing a league with robot 0
    assert watch.quarantined([0, 3], 2) == [1] and watch.quarantined([3], 2) == [1]
    rows = watch.rows([2], observation(2, positions, chain_links(4, [])), beta=1.0)
    assert rows.shape[0] == 1
    np.testing.assert_allclose(rows[0, :2], positions[1])
    assert rows[0, -2] == pytest.approx(2.0 + QuarantineParams().margin)


def test_jamming_degradations_and_temporary_failures_quarantine_nobody_and_one_can_end() -> None:
    positions = [[0.0, 0.0], [1.0, 0.0]]
    watch = QuarantineWatch(2, QuarantineParams(steps=5), comm_range=2.0)
    watch.observe(observation(0, positions, chain_links(2, [(0, 1)])))
    watch.observe(
        observation(1, positions, chain_links(2, [(0, 1)]), (Attack(1, clue(), "jamming"),))
    )
    # an announced degradation: a lossy radio that still works, with no compromise to pass on
    watch.observe(
        observation(1, positions, chain_links(2, [(0, 1)]), (Attack(1, clue(), "degradation"),))
    )
    watch.observe(
        observation(2, positions, chain_links(2, [(0, 1)]), (Attack(1, clue("temporary")),))
    )
    assert watch.quarantined([0], 2) == []
    watch.observe(observation(3, positions, chain_links(2, []), (Attack(1, clue(), "spread"),)))
    assert watch.quarantined([0], 3) == [1] and watch.quarantined([0], 7) == [1]
    assert watch.quarantined([0], 8) == []


def test_without_a_radio_range_the_watch_makes_no_rows() -> None:
    positions = [[0.0, 0.0], [1.0, 0.0]]
    watch = QuarantineWatch(2, QuarantineParams(), comm_range=None)
    watch.observe(observation(0, positions, chain_links(2, [(0, 1)])))
    watch.observe(observation(1, positions, chain_links(2, []), (Attack(1, clue()),)))
    assert watch.quarantined([0], 1) == [1]
    assert watch.rows([0], observation(1, positions, chain_links(2, [])), beta=1.0).shape[0] == 0
