"""Target motions that react to the world's truth (docs/model.md §1): ``evasive`` targets flee
robots within a radius and ``lure`` targets lead them into a named zone; both return to their
base motion. The world hands them a ``Surroundings`` value before each step."""

from __future__ import annotations

import copy
from typing import Any, ClassVar

import numpy as np
import pytest

from helpers import shipped
from resilient_tracking.scenario import MotionSpec, ScenarioError, parse_scenario
from resilient_tracking.sim.episode import run_episode
from resilient_tracking.world import World
from resilient_tracking.world.lure import ARRIVED
from resilient_tracking.world.steering import ON_POINT
from resilient_tracking.world.target_motion import Surroundings, TargetMotion

DT = 0.1
STILL = {"type": "constant_velocity", "velocity": [0.0, 0.0]}
EAST = {"type": "constant_velocity", "velocity": [0.1, 0.0]}
WORKSPACE = {"xmin": -5.0, "xmax": 5.0, "ymin": -4.0, "ymax": 4.0}
FAR = [-4.9, 3.9]  # a robot parked here is more than 5 m from every target below
ZONE = {
    "name": "Z",
    "kind": "sensing",
    "mu": [2.0, 1.5],
    "sigma": [[0.2, 0.0], [0.0, 0.2]],
    "radius": 0.5,
    "persistence": "permanent",
}


def evasive(base: dict[str, Any] | None = None, **params: Any) -> dict[str, Any]:
    return {"type": "evasive", "base": base or STILL, "radius": 1.0, "speed": 0.4, **params}


def lure(base: dict[str, Any] | None = None, **params: Any) -> dict[str, Any]:
    spec = {"type": "lure", "base": base or EAST, "zone": "Z", "speed": 0.5, "after": 0.0}
    return spec | params


def world(
    motion: dict[str, Any],
    start: list[float],
    robots: list[list[float]] | None = None,
    zones: list[dict[str, Any]] | None = None,
    seed: int = 0,
) -> World:
    data = {
        "dt": DT,
        "workspace": WORKSPACE,
        "robots": [{"start": r} for r in robots or [FAR]],
        "targets": [{"start": start, "motion": motion}],
        "zones": zones or [],
    }
    return World(parse_scenario(data), seed)


def run(w: World, steps: int, robots: Any = None) -> np.ndarray:
    """Step the world with the robots held (or placed by ``robots(k)`` before step ``k``);
    the target's positions ``(steps + 1, 2)``."""
    out = [w.targets[0].position.copy()]
    for k in range(steps):
        if robots is not None:
            w.robot_positions = np.array(robots(k), dtype=float).reshape(-1, 2)
        w.advance(np.zeros((w.n_robots, 2)))
        out.append(w.targets[0].position.copy())
    return np.array(out)


# ---------------------------------------------------------------------------- the world's hook


class Recorder(TargetMotion):
    """A reacting plug-in motion that keeps what it is handed."""

    Spec = MotionSpec
    reacts = True
    seen: ClassVar[list[Surroundings]] = []

    def sense(self, surroundings: Surroundings) -> None:
        Recorder.seen.append(surroundings)

    def step(self, dt: float, rng: np.random.Generator) -> None:
        pass


class Scripted(Recorder):
    reacts = False


@pytest.mark.parametrize("motion", [Recorder, Scripted])
def test_the_world_hands_reacting_motions_the_truth_around_them(motion):
    Recorder.seen = []
    path = f"{__name__}:{motion.__name__}"
    comm = {"kind": "comm", "mu": [-1.0, 0.0], "sigma": [[0.1, 0.0], [0.0, 0.4]], "delta2": 0.2}
    w = world({"type": path}, [0.0, 0.0], robots=[[1.0, 1.0], [2.0, -1.0]], zones=[ZONE, comm])
    controls = np.array([[0.5, 0.0], [0.0, -0.5]])
    for _ in range(3):
        w.step(controls)
    if not motion.reacts:
        assert Recorder.seen == []  # a scripted motion is never handed anything
        return
    assert [s.time for s in Recorder.seen] == pytest.approx([0.0, 0.1, 0.2])
    last = Recorder.seen[-1]
    np.testing.assert_array_equal(last.robots, w.robot_positions)  # after the robots' move
    assert [z.name for z in last.zones] == ["Z", None] and last.zone("Z") is last.zones[0]
    assert last.zone("nowhere") is None
    for seen, true in zip(last.zones, w.zones, strict=True):
        np.testing.assert_array_equal(seen.center, true.center)
        assert seen.kind == true.kind and seen.size == true.size
        assert not seen.center.flags.writeable
    assert last.zones[0].radius == 0.5  # a sensing zone's disk; a comm zone's recovery scale
    assert last.zones[1].radius == pytest.approx(2.0 * np.sqrt(0.4))
    np.testing.assert_array_equal(last.lower, [-5.0, -4.0])
    np.testing.assert_array_equal(last.upper, [5.0, 4.0])


# ---------------------------------------------------------------------------- evasive


def test_an_evasive_target_with_no_robot_near_is_its_base_motion_bit_for_bit():
    ncv = {"type": "ncv", "velocity": [0.1, 0.05], "accel_std": 0.3}
    plain = run(world(ncv, [0.0, 0.0], seed=3), 100)
    wrapped = run(world(evasive(ncv, radius=2.0), [0.0, 0.0], seed=3), 100)
    np.testing.assert_array_equal(wrapped, plain)  # and the same draws from the stream


def test_an_evasive_target_flees_a_robot_within_the_radius_and_only_then():
    near = run(world(evasive(), [0.0, 0.0], robots=[[-0.6, 0.0]]), 10)
    assert near[-1][0] > 0.3 and abs(near[-1][1]) < 1e-9  # straight away from the robot
    away = np.linalg.norm(near - [-0.6, 0.0], axis=1)
    assert (np.diff(away) > 0).all() and away[-1] < 1.0
    outside = run(world(evasive(), [0.0, 0.0], robots=[[-1.05, 0.0]]), 20)
    np.testing.assert_array_equal(outside, np.zeros((21, 2)))


def test_the_closer_robot_weighs_more():
    # one robot 0.3 m west, one 0.8 m south: the target flees mostly east
    path = run(world(evasive(), [0.0, 0.0], robots=[[-0.3, 0.0], [0.0, -0.8]]), 3)
    step = path[-1] - path[0]
    assert step[0] > 3 * step[1] > 0


def test_an_evasive_target_keeps_its_speed_and_acceleration_bounds():
    speed, max_accel = 0.4, 0.8
    w = world(evasive(EAST, speed=speed, max_accel=max_accel), [0.0, 0.0], robots=[[0.5, 0.3]])
    velocities = []
    for k in range(80):  # a robot that circles the target at 0.4 m, its side changing
        angle = 0.15 * k
        w.robot_positions = w.targets[0].position + 0.4 * np.array([[np.cos(angle), np.sin(angle)]])
        w.advance(np.zeros((1, 2)))
        velocities.append(w.targets[0].velocity.copy())
    v = np.array(velocities)
    assert np.linalg.norm(v, axis=1).max() <= speed + 1e-12
    assert np.linalg.norm(v, axis=1).max() > 0.99 * speed  # it does run
    assert np.linalg.norm(np.diff(v, axis=0), axis=1).max() <= max_accel * DT + 1e-12


def test_an_evasive_target_stays_in_the_workspace_and_slides_out_of_a_corner():
    # the robot stands still on the diagonal of the south-west corner, the target between them
    w = world(evasive(radius=1.5), [-4.5, -3.5], robots=[[-3.8, -2.8]])
    path = run(w, 200)
    assert (path >= [-5.0, -4.0]).all() and (path <= [5.0, 4.0]).all()
    corner = np.linalg.norm(path - [-5.0, -4.0], axis=1)
    # driven into the corner, then out along its longer (southern) wall, away from the robot
    assert corner[:20].min() < 0.5 * np.sqrt(2)  # within the walls' margins
    assert corner[20:].max() > 1.0
    out = path[corner.argmax()]
    assert out[1] <= -4.0 + 0.5 and out[0] > -3.0  # along the southern wall, past the robot


def test_an_evasive_target_slides_along_a_wall_it_is_pushed_against():
    # a robot straight north of a target on the southern wall: it runs along the wall
    path = run(world(evasive(wall_margin=0.3), [0.0, -3.9], robots=[[0.0, -3.3]]), 30)
    assert (path[:, 1] >= -4.0).all()
    assert abs(path[-1][0]) > 0.5 and path[-1][1] < -3.8


def test_an_evasive_target_returns_to_its_base_motion_when_clear():
    spec = evasive(EAST, speed=0.4)
    # a robot near for 2 s, then gone
    robots = lambda k: [[-0.2 + 0.1 * k * DT, 0.5]] if k < 20 else [FAR]  # noqa: E731
    w = world(spec, [0.0, 0.0], robots=[FAR])
    path = run(w, 200, robots)
    base = run(world(EAST, [0.0, 0.0]), 200)
    assert np.linalg.norm(path[20] - base[20]) > 0.3  # it fled
    assert w.targets[0].motion.mode == "base"
    np.testing.assert_array_equal(path[-50:], base[-50:])  # back on its lane, bit for bit
    gap = np.linalg.norm(path - base, axis=1)
    rejoined = int(np.flatnonzero(gap > ON_POINT)[-1]) + 1
    assert rejoined < 120  # well before the end


def test_evasion_is_the_same_for_the_same_seed():
    ncv = {"type": "ncv", "velocity": [0.1, 0.0], "accel_std": 0.2}
    robots = lambda k: [[0.5 * np.cos(0.1 * k) - 1.0, 0.5 * np.sin(0.1 * k)]]  # noqa: E731
    a = run(world(evasive(ncv), [0.0, 0.0], seed=7), 150, robots)
    b = run(world(evasive(ncv), [0.0, 0.0], seed=7), 150, robots)
    c = run(world(evasive(ncv), [0.0, 0.0], seed=8), 150, robots)
    np.testing.assert_array_equal(a, b)
    assert not np.allclose(a, c)


# ---------------------------------------------------------------------------- lure


def lure_world(
    seed: int = 0,
    robots: list[list[float]] | None = None,
    start: tuple[float, float] = (-2.0, -1.0),
    **params: Any,
) -> World:
    return world(lure(**params), list(start), robots=robots, zones=[ZONE], seed=seed)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_lure_reaches_the_zones_true_centre_lingers_and_returns(seed):
    linger = 3.0
    w = lure_world(seed, linger=linger)
    center = w.zones[0].center
    path, modes = [w.targets[0].position.copy()], []
    for _ in range(400):
        w.advance(np.zeros((1, 2)))
        path.append(w.targets[0].position.copy())
        modes.append(w.targets[0].motion.mode)
    path = np.array(path)
    lingering = np.flatnonzero(np.array(modes) == "linger") + 1  # rows of path
    assert np.all(np.diff(lingering) == 1)  # one stay
    assert len(lingering) * DT == pytest.approx(linger, abs=1.01 * DT)
    assert (np.linalg.norm(path[lingering] - center, axis=1) <= ARRIVED).all()
    assert modes.index("go") == 0 and modes[-1] == "base"
    speeds = np.linalg.norm(np.diff(path, axis=0), axis=1) / DT
    assert speeds.max() <= 0.5 + 1e-9
    base = run(world(EAST, [-2.0, -1.0]), 400)
    np.testing.assert_array_equal(path[-20:], base[-20:])  # back on its base motion
    assert w.targets[0].motion.mode == "base"


def test_a_lure_stops_at_its_standoff_on_the_side_it_came_from():
    w = lure_world(standoff=0.8, linger=2.0)
    center = w.zones[0].center
    path = run(w, 150)
    gap = np.linalg.norm(path - center, axis=1)
    assert abs(gap[40:].min() - 0.8) <= ARRIVED + 1e-9
    closest = path[40:][gap[40:].argmin()]
    assert closest[0] < center[0]  # it came from the west


def departures(w: World, steps: int) -> list[float]:
    """Times (s) at which the lure target sets off for its zone."""
    out, before = [], "base"
    for k in range(steps):
        w.advance(np.zeros((1, 2)))
        mode = w.targets[0].motion.mode
        if mode == "go" and before != "go":
            out.append(round(k * DT, 6))
        before = mode
    return out


def test_lure_trips_repeat_every_period():
    near_zone = lure_world(start=(1.0, 1.0), linger=1.0, period=12.0, after=1.0, base=STILL)
    assert departures(near_zone, 400) == [1.0, 13.0, 25.0, 37.0]
    # a trip longer than the period: the next one starts once back on the base motion
    w = lure_world(linger=1.0, period=12.0, after=1.0, base=STILL)
    times = departures(w, 400)
    assert times[:2] == [1.0, 13.0] or (times[0] == 1.0 and times[1] > 13.0)
    assert len(times) >= 2 and times[1] > 13.0


def test_a_due_trip_waits_for_a_robot_near():
    robots = lambda k: [FAR] if k < 50 else [[-2.5, -1.0]]  # noqa: E731
    w = lure_world(near=1.0, base=STILL)
    path = run(w, 60, robots)
    np.testing.assert_array_equal(path[:51], np.tile([-2.0, -1.0], (51, 1)))
    assert w.targets[0].motion.mode == "go"
    assert np.linalg.norm(path[-1] - path[50]) > 0.1


def test_a_lure_outside_a_world_keeps_to_its_base_motion():
    # the generator advances a target without a world (its mean path): no zone to go to
    from resilient_tracking.experiments.generator import mean_path

    spec = parse_scenario(
        {
            "robots": [{"start": FAR}],
            "zones": [ZONE],
            "targets": [{"start": [0.0, 0.0], "motion": lure()}],
        }
    ).targets[0]
    plain = spec.model_copy(update={"motion": spec.motion.base})
    np.testing.assert_array_equal(mean_path(spec, 50), mean_path(plain, 50))


def test_zones_never_attack_a_lure_target():
    hot = ZONE | {"hazard": {"model": "gaussian", "kappa": 1e4}}
    w = world(lure(base=STILL, linger=20.0), [1.0, 1.5], robots=[FAR], zones=[hot])
    for _ in range(100):
        w.advance(np.zeros((1, 2)))
    assert w.capability_ok("sensing").all()  # only robots are ever attacked
    assert w.observe().attacks == ()


# ---------------------------------------------------------------------------- validation


def scenario_data(motion: dict[str, Any], zones: list[dict[str, Any]] | None = None) -> dict:
    return {
        "robots": [{"start": FAR}],
        "targets": [{"start": [0.0, 0.0], "motion": motion}],
        "zones": [ZONE] if zones is None else zones,
    }


def problems(data: dict[str, Any]) -> list[str]:
    with pytest.raises(ScenarioError) as err:
        parse_scenario(data)
    return err.value.problems


def test_a_lure_to_an_unknown_zone_is_refused_naming_the_field():
    (problem,) = problems(scenario_data(lure(zone="Y")))
    assert problem.startswith("targets.0.motion.zone: ")
    assert "'Y'" in problem and "Z" in problem
    (problem,) = problems(scenario_data(lure(), zones=[ZONE | {"name": None}]))
    assert problem.startswith("targets.0.motion.zone: ") and "no zone has a name" in problem
    (problem,) = problems(scenario_data(evasive(lure(zone="Y"))))
    assert problem.startswith("targets.0.motion.base.zone: ")


def test_zone_names_must_be_unique():
    other = ZONE | {"mu": [-2.0, 0.0]}
    (problem,) = problems(scenario_data(STILL, zones=[ZONE, other]))
    assert problem.startswith("zones.1.name: ") and "zones.0" in problem
    unnamed = {k: v for k, v in ZONE.items() if k != "name"}
    parse_scenario(scenario_data(STILL, zones=[unnamed, unnamed]))  # no name: no clash


@pytest.mark.parametrize(
    ("motion", "field", "message"),
    [
        (evasive(radius=0.0), "radius", "greater than 0"),
        (evasive(speed=-0.1), "speed", "greater than 0"),
        (evasive(speed=1e200), "speed", "less than or equal to 1000"),
        (evasive(max_accel=1e9), "max_accel", "less than or equal to 1000"),
        (evasive(wall_margin=-1.0), "wall_margin", "greater than or equal to 0"),
        (evasive(wall_margin=1e300), "wall_margin", "less than or equal to"),
        (lure(linger=-1.0), "linger", "greater than or equal to 0"),
        (lure(after=1e300), "after", "less than or equal to"),
        (lure(period=0.0), "period", "greater than 0"),
        (lure(near=1e200), "near", "less than or equal to"),
        (lure(standoff=-0.5), "standoff", "greater than or equal to 0"),
        (lure(speed=True), "speed", "number"),
        (evasive(base={"type": "circle", "center": [1.0, 0.0]}), "base.angular_speed", "required"),
        (evasive(base={"type": "teleport"}), "base", "unknown target motion 'teleport'"),
        ({"type": "evasive", "radius": 1.0, "speed": 0.3}, "base", "required"),
        (evasive(cunning=True), "cunning", "not permitted"),
    ],
)
def test_bad_numbers_and_fields_are_refused_naming_the_field(motion, field, message):
    found = problems(scenario_data(motion))
    hits = [p for p in found if p.startswith(f"targets.0.motion.{field}: ")]
    assert hits and message.lower() in hits[0].lower(), found


def test_a_circle_base_is_checked_like_a_circle_motion():
    base = {"type": "circle", "center": [0.0, 0.0], "angular_speed": 0.1}
    (problem,) = problems(scenario_data(evasive(base)))
    assert problem.startswith("targets.0.motion.base.center: equals the start")


# ---------------------------------------------------------------------------- shipped scenarios


def attacks(data: dict[str, Any], seed: int) -> int:
    events = run_episode(parse_scenario(data), seed=seed).tables["events"]
    return int((events.event == "attack").sum())


def test_the_failure_aware_team_comes_within_an_evasive_targets_radius():
    scenario = shipped("evasive-open").with_overrides(steps=100)
    result = run_episode(scenario, seed=1)
    robots = result.tables["robots"][["x", "y"]].to_numpy().reshape(-1, 3, 1, 2)
    targets = result.tables["targets"][["x", "y"]].to_numpy().reshape(-1, 1, 3, 2)
    closest = np.linalg.norm(robots - targets, axis=-1).min(axis=1)  # (steps, targets)
    radius = scenario.targets[0].motion.radius
    assert ((closest < radius).mean(axis=0) > 0.5).all()  # each target is chased, and evades
    base = shipped("evasive-open").targets[0].motion.base
    assert scenario.targets[0].motion.speed < scenario.robots[0].u_max
    assert scenario.targets[0].motion.speed > base.speed


@pytest.mark.parametrize("name", ["lure-sensing", "lure-comm"])
def test_a_lure_draws_the_failure_aware_team_into_its_zone(name):
    data = shipped(name).model_dump(mode="json")
    plain = copy.deepcopy(data)
    for target in plain["targets"]:
        target["motion"] = target["motion"].get("base", target["motion"])
    seeds = (1, 2, 3)
    lured = sum(attacks(data, s) for s in seeds)
    unlured = sum(attacks(plain, s) for s in seeds)
    assert lured >= len(seeds) - 1 > unlured  # the base lanes keep clear of the zone


# ---------------------------------------------------------------------------- the generator


def test_the_generator_wraps_some_targets_of_a_scenario_in_adversarial_motions():
    from resilient_tracking.experiments.generator import make_adversarial, stored_suite
    from resilient_tracking.rng import stream

    kinds = set()
    rng = stream(3, "generator_adversarial")
    for plain in stored_suite(8):
        data = plain.model_dump(mode="json")
        make_adversarial(data, rng)
        scenario = parse_scenario(data, plain.name)
        wrapped = [t for t in scenario.targets if t.motion.type in ("evasive", "lure")]
        assert wrapped and "Adversarial targets:" in scenario.description
        zone_names = {z.name for z in scenario.zones}
        for target, original in zip(scenario.targets, plain.targets, strict=True):
            motion = target.motion
            if motion.type in ("evasive", "lure"):
                assert motion.base == original.motion  # the lane stays its base motion
                assert motion.speed < min(r.u_max for r in scenario.robots)
                kinds.add(motion.type)
                if motion.type == "lure":
                    assert motion.zone in zone_names
            else:
                assert motion == original.motion
        assert scenario.zones == plain.zones and scenario.robots == plain.robots
    assert kinds == {"evasive", "lure"}


def test_an_adversarial_suite_is_the_plain_suite_with_targets_wrapped(tmp_path):
    from resilient_tracking.cli import main
    from resilient_tracking.experiments.generator import suite
    from resilient_tracking.scenario import load_scenario

    plain, adversarial = suite(5, 2), suite(5, 2, adversarial=True)
    for p, a in zip(plain, adversarial, strict=True):
        assert a.zones == p.zones and a.robots == p.robots
        bases = [getattr(t.motion, "base", t.motion) for t in a.targets]
        assert bases == [t.motion for t in p.targets]
        assert any(t.motion.type in ("evasive", "lure") for t in a.targets)
    assert (
        main(["generate", "-n", "1", "--seed", "5", "--adversarial", "--out", str(tmp_path)]) == 0
    )
    written = load_scenario(tmp_path / "g00.yaml")
    assert written.model_dump() == adversarial[0].model_dump()
    assert "--adversarial" in (tmp_path / "g00.yaml").read_text().splitlines()[0]


def test_rtrack_generate_adversarial_writes_the_stored_adversarial_suite(tmp_path):
    from resilient_tracking.cli import main
    from resilient_tracking.experiments.generator import stored_adversarial_suite
    from resilient_tracking.scenario import load_scenario

    assert main(["generate", "-n", "2", "--adversarial", "--out", str(tmp_path), "-q"]) == 0
    written = [load_scenario(tmp_path / f"g{i:02d}.yaml") for i in range(2)]
    stored = stored_adversarial_suite(2)
    assert [s.model_dump() for s in written] == [s.model_dump() for s in stored]
