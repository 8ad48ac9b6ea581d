"""Large leagues planned as sub-teams: partition, windows, padding, and quality against the
joint solve of the same league problem."""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np
import pytest
from pydantic import ValidationError

from helpers import league_inputs
from resilient_tracking.models.range_bearing import RangeBearingSensor
from resilient_tracking.planning.adaptation import chance_margin
from resilient_tracking.planning.layout import (
    ProblemInputs,
    _information_entries,
    comm_row,
    sensing_row,
)
from resilient_tracking.planning.planner import LeaguePlanner
from resilient_tracking.planning.reduction import zone_needs
from resilient_tracking.planning.spec import PlannerSpec, SubteamSpec
from resilient_tracking.planning.subteams import (
    ZONE_BUCKET,
    SubteamPlanner,
    _padded,
    _window_inputs,
    partition,
)

SMALL = SubteamSpec(above=8, size=4, pinned=2)
#: the sensor of tests/helpers.py's league inputs
SENSOR = RangeBearingSensor(15.0, 0.2, 15.0, 0.2)


def big_league(n: int = 12, big_n: int = 6, seed: int = 1) -> ProblemInputs:
    """``n`` robots spread around ``big_n`` targets, one sensing and one comm zone nearby."""
    rng = np.random.default_rng(seed)
    positions = rng.uniform(-3, 3, (n, 2))
    targets = rng.uniform(-2.5, 2.5, (big_n, 2))
    szones = [sensing_row([0.5, 0.5], 0.2 * np.eye(2), r_safe=0.5, beta=chance_margin(0.02))]
    czones = [comm_row([-1.0, 1.0], 0.15 * np.eye(2), 0.3, chance_margin(0.15), 0.0)]
    return league_inputs(positions, targets, szones, czones, -np.ones((n, 2)), np.ones((n, 2)))


def total_trace(q: ProblemInputs, controls: np.ndarray) -> float:
    """``Σ_j tr P⁺_j`` of the league at ``controls`` (the tracking term of eq. 6)."""
    moved = q.positions + controls * q.dt
    info = SENSOR.information(moved[:, None, :], q.targets[None, :, :], q.standoff)
    abc = _information_entries(q.prior_info) + (q.sensing[:, None, None] * info).sum(axis=0)
    a, b, c = abc[:, 0], abc[:, 1], abc[:, 2]
    return float(np.sum((a + c) / (a * c - b * b)))


def test_partition_covers_every_robot_once_in_balanced_spatial_groups():
    positions = np.random.default_rng(0).uniform(-5, 5, (37, 2))
    groups = partition(positions, 10)
    assert len(groups) == 4
    assert sorted(np.concatenate(groups).tolist()) == list(range(37))
    assert max(len(g) for g in groups) - min(len(g) for g in groups) <= 1
    # spatial: the groups' spans are smaller than the whole team's
    span = np.ptp(positions, axis=0).prod()
    assert all(np.ptp(positions[g], axis=0).prod() < span for g in groups)


def test_a_window_sees_the_same_information_as_the_league():
    """Prior plus the window's sensing robots equals prior plus every robot: the window's
    tracking term is the league's with the others held at their plan."""
    q = big_league()
    planner = SubteamPlanner(SMALL, lambda *a: None)  # type: ignore[arg-type, return-value]
    info = planner._information(q)
    velocity = np.random.default_rng(2).uniform(-0.5, 0.5, (12, 2))
    gained = q.sensing[:, None, None] * info(q.positions + velocity * q.dt)
    free = np.array([0, 3, 5, 7])
    rest = np.setdiff1d(np.arange(12), free)
    pinned = rest[:2]
    shared = replace(q, prior_info=_information_entries(q.prior_info))
    robots = np.concatenate([free, pinned])
    sub = _window_inputs(shared, robots, 4, velocity, gained[rest].sum(0), np.arange(6))
    window = _information_entries(sub.prior_info) + gained[free].sum(0)
    league = _information_entries(q.prior_info) + gained.sum(0)
    np.testing.assert_allclose(window, league, rtol=1e-12)
    # pinned robots hold their planned step and add no information of their own
    np.testing.assert_array_equal(sub.u_lower[4:], velocity[pinned])
    np.testing.assert_array_equal(sub.u_upper[4:], velocity[pinned])
    assert not sub.sensing[4:].any()


def test_padding_zones_bind_nothing():
    """A window with its zones padded to the bucket plans exactly as without the padding."""
    q = big_league(n=5, big_n=3)
    padded = replace(
        q,
        sensing_zones=_padded(q.sensing_zones, _far("sensing")),
        comm_zones=_padded(q.comm_zones, _far("comm")),
    )
    assert padded.structure().n_sensing_zones == ZONE_BUCKET
    assert padded.structure().n_comm_zones == ZONE_BUCKET
    planner = LeaguePlanner(solver="ipopt")
    plain = planner.plan(q.structure(), tuple(range(5)), q)
    with_padding = planner.plan(padded.structure(), tuple(range(5)), padded)
    assert plain.success and with_padding.success
    np.testing.assert_allclose(with_padding.controls, plain.controls, atol=1e-6)


def _far(kind: str) -> np.ndarray:
    from resilient_tracking.planning import subteams

    return subteams._FAR_SENSING if kind == "sensing" else subteams._FAR_COMM


def test_small_leagues_are_planned_jointly_bit_for_bit():
    q = big_league(n=8)
    joint = LeaguePlanner().plan(q.structure(), tuple(range(8)), q)
    split = LeaguePlanner(subteams=SMALL).plan(q.structure(), tuple(range(8)), q)
    np.testing.assert_array_equal(split.controls, joint.controls)
    assert split.attempts == joint.attempts


@pytest.mark.parametrize("targets", [6, 4])
def test_sub_teams_track_within_five_percent_of_the_joint_solve_with_one_structure(targets):
    """Over a closed loop of 12 robots, the sub-team plans' summed trace stays within 5 % of
    the joint plans' (with every target in each window, and with the 4 nearest), and every
    window shares one problem structure."""
    joint_planner = LeaguePlanner()
    spec = SubteamSpec(above=8, size=4, pinned=2, targets=targets)
    split_planner = LeaguePlanner(subteams=spec)
    q0 = big_league()
    members = tuple(range(12))
    traces = {"joint": [], "split": []}
    for name, planner in (("joint", joint_planner), ("split", split_planner)):
        q = q0
        for _ in range(8):
            result = planner.plan(q.structure(), members, q)
            assert result.success, result.status
            assert np.all(result.controls >= q.u_lower - 1e-9)
            assert np.all(result.controls <= q.u_upper + 1e-9)
            traces[name].append(total_trace(q, result.controls))
            q = replace(q, positions=q.positions + result.controls * q.dt)
    ratio = np.sum(traces["split"]) / np.sum(traces["joint"])
    assert ratio <= 1.05, ratio
    window_structures = list(split_planner.windows._problems)
    assert len(window_structures) == 1
    assert window_structures[0].n_targets == targets
    assert not list(split_planner._problems)  # no league structure was built


def test_the_window_structure_is_built_before_a_run():
    planner = LeaguePlanner(subteams=SMALL)
    structure = planner.prepare_team(12, 6, SENSOR)
    assert structure is not None and structure.n_robots == 6
    assert structure in planner.windows._problems
    assert planner.subteams is not None and planner.subteams.sensor is SENSOR
    assert LeaguePlanner(subteams=SMALL).prepare_team(8, 6, SENSOR) is None


def test_in_a_large_team_every_league_plans_on_windows():
    """In a team of more than ``above`` robots a league smaller than ``above`` (8 robots, split
    into windows) and one smaller than a window (1 robot, a window of its own) build no
    problem of their own; in a small team they are solved jointly."""
    planner = LeaguePlanner(subteams=SMALL)
    q = big_league(n=8)
    assert planner.subteams is not None and not planner.subteams.applies(q.structure())
    planner.prepare_team(12, 6, SENSOR)
    for n in (8, 1):
        league = big_league(n=n)
        assert planner.subteams.applies(league.structure())
        result = planner.plan(league.structure(), tuple(range(n)), league)
        assert result.success and result.controls.shape == (n, 2)
    assert not list(planner._problems)


def test_the_sensors_numpy_information_is_the_nlps():
    """The fast path (the sensor's NumPy twin) gives the NLP's own information piece."""
    q = big_league()
    positions = np.random.default_rng(3).uniform(-3, 3, (7, 2))
    twin = SubteamPlanner(SMALL, lambda *a: None, SENSOR)  # type: ignore[arg-type, return-value]
    piece = SubteamPlanner(SMALL, lambda *a: None)  # type: ignore[arg-type, return-value]
    np.testing.assert_allclose(
        twin._information(q)(positions), piece._information(q)(positions), rtol=1e-12
    )


def test_subteam_settings_are_checked_naming_the_field():
    with pytest.raises(ValidationError, match="size \\+ pinned"):
        SubteamSpec(above=10, size=8, pinned=4)
    with pytest.raises(ValidationError, match="subteams"):
        PlannerSpec.model_validate({"subteams": {"size": 0}})


def test_background_builds_reach_the_sub_team_windows():
    planner = LeaguePlanner(subteams=SMALL)
    planner.background_builds = True
    assert planner.windows is not None and planner.windows.background_builds
    planner.close()


def test_a_window_keeps_only_the_zones_that_can_bind_it():
    """Zones far from every robot of a window are left out (then padded): the window plans the
    same as with every zone."""
    from resilient_tracking.planning.subteams import _binding_zones

    q = big_league(n=5, big_n=3)
    far = sensing_row([40.0, 40.0], 0.2 * np.eye(2), r_safe=0.5, beta=chance_margin(0.02))
    many = replace(q, sensing_zones=np.vstack([q.sensing_zones, [far] * 5]))
    window = _binding_zones(many)
    assert window.structure().n_sensing_zones == ZONE_BUCKET  # 6 known, 1 near
    planner = LeaguePlanner(solver="ipopt")
    every = planner.plan(many.structure(), tuple(range(5)), many)
    kept = planner.plan(window.structure(), tuple(range(5)), window)
    np.testing.assert_allclose(kept.controls, every.controls, atol=1e-6)


def test_a_window_carries_the_zone_needs_its_solve_would_judge():
    """The needs a window carries (padding columns false) are those judged afresh on it."""
    from resilient_tracking.planning.subteams import _binding_zones

    binding = 0
    for seed in range(5):
        q = big_league(n=6, big_n=3, seed=seed)
        far = sensing_row([40.0, 40.0], 0.2 * np.eye(2), r_safe=0.5, beta=chance_margin(0.02))
        many = replace(q, sensing_zones=np.vstack([q.sensing_zones, [far] * 3]))
        window = _binding_zones(many)
        carried = window.zone_needs
        fresh = zone_needs(replace(window))  # replace() drops what the window carries
        assert carried is not None and fresh is not None
        assert zone_needs(window) is carried
        for name in ("sensing", "comm", "near", "far"):
            np.testing.assert_array_equal(getattr(carried, name), getattr(fresh, name))
        binding += int(fresh.sensing.any() or fresh.comm.any())
    assert binding  # the test sees rows that bind, not only padding


def test_past_its_deadline_a_league_leaves_the_sub_teams_not_yet_planned():
    """With no time to spare only the first sub-team is planned: the others keep their last
    planned velocity where no zone row can bind them this step, else hold position, and are
    named in the result; the next step plans them first. Without a deadline every sub-team
    is planned."""
    from resilient_tracking.planning.subteams import _free_to_coast

    planner = LeaguePlanner(subteams=SMALL)
    planner.prepare_team(12, 6, SENSOR)
    q, members = big_league(), tuple(range(100, 112))
    free = planner.plan(q.structure(), members, q)
    assert free.success and not free.held
    planner.deadline = 0.0  # long past
    assert planner.subteams is not None and planner.subteams.deadline == 0.0
    none = planner.plan(q.structure(), members, q)  # past it before planning: none planned
    assert none.success and none.held == members
    held = np.arange(12)
    coast = _free_to_coast(q, held)
    assert coast.any() and not coast.all()  # the scene has both kinds
    np.testing.assert_array_equal(none.controls[held[~coast]], 0.0)
    np.testing.assert_array_equal(none.controls[held[coast]], free.controls[held[coast]])
    first = planner.plan(q.structure(), members, q)  # never two steps without a plan
    assert first.success and len(first.held) == 8  # 3 sub-teams of 4: two unplanned
    assert len(planner.plan(q.structure(), members, q).held) == 12
    second = planner.plan(q.structure(), members, q)
    assert len(second.held) == 8
    assert set(first.held) - set(second.held)  # an unplanned sub-team went first


def test_past_its_deadline_a_league_of_one_window_is_still_planned():
    """A league that fits one window (in a large team it plans on windows, where a small
    team would solve it jointly) is planned whatever the deadline, as the joint solve was."""
    planner = LeaguePlanner(subteams=SMALL)
    planner.prepare_team(12, 6, SENSOR)
    planner.deadline = 0.0  # long past
    for _ in range(3):
        for n in (12, 5):
            q = big_league(n=n)
            result = planner.plan(q.structure(), tuple(range(n)), q)
            assert result.success
        assert not result.held  # the 5-robot league, every time


def test_robots_held_over_the_budget_are_events():
    from resilient_tracking.planning.plan_result import OVER_BUDGET, PlanResult
    from resilient_tracking.policies.base import Decision
    from resilient_tracking.policies.planning_helpers import PlanningPolicy

    result = PlanResult(np.zeros((3, 2)), "Solve_Succeeded", True, 2, 1.0, held=(7, 9))
    decision = Decision(controls=np.zeros((3, 2)), modes=["league"] * 3)
    PlanningPolicy.settle(None, lambda: result, [5, 7, 9], big_league(n=3), 4, decision)  # type: ignore[arg-type]
    budget = [e for e in decision.events if e.fallback == "budget"]
    assert [(e.robot, e.status) for e in budget] == [(7, OVER_BUDGET), (9, OVER_BUDGET)]


def test_a_sub_team_whose_solve_fails_takes_the_safe_action_alone():
    """One window's solve fails: its free robots take the safe action (named in the result with
    what each did, one event each), the league's other robots keep their planned controls, and
    the league counts as a failed solve."""
    from dataclasses import replace

    from resilient_tracking.planning.safe_action import safe_action
    from resilient_tracking.policies.base import Decision
    from resilient_tracking.policies.planning_helpers import PlanningPolicy

    planner = LeaguePlanner(subteams=SMALL)
    planner.prepare_team(12, 6, SENSOR)
    q, members = big_league(), tuple(range(100, 112))
    sub = planner.subteams
    assert sub is not None
    solve, windows = sub.plan_window, []

    def first_fails(structure, robots, window):
        windows.append(robots)
        result = solve(structure, robots, window)
        if len(windows) > 1:
            return result
        return replace(result, success=False, status="Maximum_Iterations_Exceeded", rung="safe")

    sub.plan_window = first_fails
    result = planner.plan(q.structure(), members, q)
    failed = np.array([members.index(robot) for robot, _ in result.safe])
    assert not result.success and len(failed) == SMALL.size
    assert {members[i] for i in failed} <= set(windows[0])
    expected, actions = safe_action(q, failed)
    np.testing.assert_array_equal(result.controls[failed], expected[failed])
    assert [action for _, action in result.safe] == [actions[i] for i in failed]
    others = np.setdiff1d(np.arange(12), failed)
    assert np.all(np.linalg.norm(result.controls[others], axis=1) > 0.1)  # planned, moving
    decision = Decision(controls=np.zeros((12, 2)), modes=["league"] * 12)
    controls = PlanningPolicy.settle(None, lambda: result, list(members), q, 4, decision)  # type: ignore[arg-type]
    np.testing.assert_array_equal(controls, result.controls)
    safe = sorted(e.robot for e in decision.events if e.fallback == "safe")
    assert safe == sorted(members[i] for i in failed)


def test_past_its_deadline_a_window_whose_sqp_fails_takes_the_safe_action_without_ipopt():
    """Running free, a window's failed SQP is not followed by IPOPT (whose time has no
    bound): its sub-team takes the safe action at once. Without a deadline the ladder
    climbs as always."""
    from resilient_tracking.planning.faults import FaultInjector

    planner = LeaguePlanner(
        subteams=SMALL, fault_hook=FaultInjector(1.0, ["infeasible"], rungs=["sqp"])
    )
    planner.prepare_team(12, 6, SENSOR)
    q, members = big_league(), tuple(range(12))
    assert planner.windows is not None
    solve, rungs = planner.windows.plan, []

    def recorded(structure, robots, window):
        result = solve(structure, robots, window)
        rungs.append([rung for rung, _ in result.attempts])
        return result

    assert planner.subteams is not None
    planner.subteams.plan_window = recorded
    climbed = planner.plan(q.structure(), members, q)
    assert climbed.success and all(attempts[-1] != "sqp" for attempts in rungs)
    rungs.clear()
    planner.deadline = time.perf_counter() + 60.0  # a minute to spare: every window planned
    bounded = planner.plan(q.structure(), members, q)
    assert rungs and all(attempts == ["sqp"] for attempts in rungs)
    assert not bounded.success and len(bounded.safe) == 12
    planner.deadline = None
    rungs.clear()
    assert planner.plan(q.structure(), members, q).success
    assert all(len(attempts) > 1 for attempts in rungs)


def test_a_league_past_its_deadline_is_not_routed_and_smaller_leagues_plan_first():
    """Running free, the policy plans the smaller leagues first (each fits one window and is
    planned whatever the deadline), and a league that will go unplanned gets no route rows;
    without a deadline the leagues go in their order and every league is routed."""
    from helpers import shipped
    from resilient_tracking.sim.episode import start_truth
    from resilient_tracking.team import build_team
    from resilient_tracking.world import World

    scenario = shipped("swarm-40x20")
    targets, _ = start_truth(scenario, 1)
    team = build_team(scenario, "failure_aware", 1, targets)
    policy, planner = team.policy, team.policy.planner
    obs = World(scenario, 1).observe()
    team.perceive(obs)
    league, others = list(range(40)), [[3], [5, 6]]
    weights, sensing = np.ones(5), np.ones(40)

    def routed() -> bool:
        q = policy.tracking_inputs(team.belief, obs, league, 0, weights[:4], sensing)
        return q.route is not None

    leagues = [league, *others]
    assert policy.planning_order(leagues) == [0, 1, 2] and routed()
    planner.deadline = 0.0  # long past
    assert policy.planning_order(leagues) == [1, 2, 0]
    assert planner.subteams is not None
    planner.subteams._starved = False  # the league was planned the step before
    assert not routed() and planner.skips(40) and not planner.skips(12)  # one window
    planner.subteams._starved = True
    assert routed()  # never two steps in a row without a plan
