"""Routes around keep-out discs (planning/route.py) and the route program's goals (goals.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from resilient_tracking.planning.goals import assign, keep_out_discs, route_rows
from resilient_tracking.planning.layout import RouteRow
from resilient_tracking.planning.route import SIDES, RouteMap, segment_distances
from resilient_tracking.planning.spec import RouteSpec

BOX = (np.array([-10.0, -10.0]), np.array([10.0, 10.0]))


def around_disc(start: np.ndarray, goal: np.ndarray, radius: float) -> float:
    """Exact shortest path around one disc at the origin: tangent, arc, tangent."""
    a, b = np.linalg.norm(start), np.linalg.norm(goal)
    angle = math.acos(np.dot(start, goal) / (a * b))
    arc = angle - math.acos(radius / a) - math.acos(radius / b)
    if arc <= 0:
        return float(np.linalg.norm(goal - start))
    return math.sqrt(a * a - radius * radius) + math.sqrt(b * b - radius * radius) + radius * arc


def test_no_discs_is_a_straight_line() -> None:
    routes = RouteMap(np.zeros((0, 3)), *BOX)
    start, goal = np.array([[0.0, 0.0]]), np.array([[3.0, 4.0]])
    assert routes.lengths(start, goal)[0, 0] == pytest.approx(5.0)
    waypoint, remaining = routes.routes(start, goal)
    np.testing.assert_array_equal(waypoint[0], goal[0])
    assert remaining[0] == 0.0


@pytest.mark.parametrize("radius", [0.5, 1.0, 2.0])
def test_length_around_a_disc_is_near_the_exact_one(radius: float) -> None:
    routes = RouteMap(np.array([[0.0, 0.0, radius]]), *BOX)
    start, goal = np.array([-4.0, 0.3]), np.array([4.0, -0.2])
    exact = around_disc(start, goal, radius)
    found = routes.lengths(start[None], goal[None])[0, 0]
    # the polygon circumscribes the inflated disc: never shorter, at most a few % longer
    assert exact <= found <= exact / math.cos(math.pi / SIDES) + 0.2


def test_waypoint_is_visible_and_route_is_consistent() -> None:
    routes = RouteMap(np.array([[0.0, 0.0, 1.0]]), *BOX)
    start, goal = np.array([[-3.0, 0.0]]), np.array([[3.0, 0.0]])
    waypoint, remaining = routes.routes(start, goal)
    # the first leg misses the disc, and first leg + rest is the route length
    assert segment_distances(start, waypoint, np.zeros((1, 2)))[0, 0] >= 1.0 - 1e-9
    total = np.linalg.norm(waypoint[0] - start[0]) + remaining[0]
    assert total == pytest.approx(routes.lengths(start, goal)[0, 0])


def test_routes_leave_the_workspace_never() -> None:
    lower, upper = np.array([-3.0, -1.2]), np.array([3.0, 3.0])
    routes = RouteMap(np.array([[0.0, 0.0, 1.0]]), lower, upper)
    assert np.all(routes.corners >= lower) and np.all(routes.corners <= upper)
    waypoint, _ = routes.routes(np.array([[-2.5, 0.0]]), np.array([[2.5, 0.0]]))
    assert waypoint[0, 1] > 0  # the way south is outside the box: it goes north


def test_a_start_inside_a_disc_still_gets_out() -> None:
    routes = RouteMap(np.array([[0.0, 0.0, 1.0], [3.0, 0.0, 1.0]]), *BOX)
    start, goal = np.array([[0.2, 0.1]]), np.array([[6.0, 0.0]])
    length = routes.lengths(start, goal)[0, 0]
    assert np.isfinite(length) and length > 5.8


def test_goals_inside_discs_are_moved_out() -> None:
    routes = RouteMap(np.array([[0.0, 0.0, 1.0]]), *BOX)
    moved = routes.outside(np.array([[0.5, 0.0], [3.0, 3.0]]))
    assert np.linalg.norm(moved[0]) > 1.0 and moved[0, 0] > 0
    np.testing.assert_array_equal(moved[1], [3.0, 3.0])


@settings(max_examples=40, deadline=None)
@given(
    st.lists(
        st.tuples(st.floats(-4, 4), st.floats(-4, 4), st.floats(0.2, 1.5)),
        min_size=1,
        max_size=3,
    ),
    st.tuples(st.floats(-6, 6), st.floats(-6, 6)),
    st.tuples(st.floats(-6, 6), st.floats(-6, 6)),
)
def test_route_lengths_are_at_least_straight_and_legs_are_free(discs, start, goal) -> None:
    routes = RouteMap(np.array(discs), *BOX)
    s, g = np.array([start]), routes.outside(np.array([goal]))
    length = routes.lengths(s, g)[0, 0]
    assert length >= np.linalg.norm(g - s) - 1e-9
    waypoint, remaining = routes.routes(s, g)
    if np.isfinite(length):
        assert np.linalg.norm(waypoint[0] - s[0]) + remaining[0] == pytest.approx(length)


def test_assignment_spreads_robots_over_targets() -> None:
    lengths = np.array([[1.0, 5.0], [1.1, 5.0], [1.2, 5.0]])
    chosen = assign(lengths, spread=0.5)
    assert sorted(chosen.tolist()).count(0) == 2 and 1 in chosen
    assert assign(np.array([[2.0, 1.0, 3.0]]), 0.5).tolist() == [1]


def test_keep_out_discs_bound_the_chance_constraints() -> None:
    # sensing row: mu, sigma, r_safe, beta  -> r_safe + beta √(2 λmax)
    sensing = np.array([[1.0, 2.0, 0.3, 0.0, 0.1, 0.5, 1.5]])
    comm = np.array([[0.0, 0.0, 0.2, 0.0, 0.2, 0.3, 0.7, 0.1]])
    discs = keep_out_discs(sensing, comm, pair=2.0)
    assert discs[0] == pytest.approx([1.0, 2.0, 0.5 + 1.5 * math.sqrt(0.6)])
    assert discs[1] == pytest.approx([0.0, 0.0, 0.1 + 0.7 * math.sqrt(0.4) + 0.3 * 2.0])
    assert keep_out_discs(sensing, comm, pair=1.9)[1] == pytest.approx(discs[1])


def test_route_rows_pull_only_robots_that_sense() -> None:
    routes = RouteMap(np.array([[0.0, 0.0, 1.0]]), *BOX)
    positions = np.array([[-3.0, 0.0], [-3.0, 1.0]])
    rows = route_rows(
        positions,
        can_sense=np.array([1.0, 0.0]),
        targets=np.array([[3.0, 0.0]]),
        velocities=np.zeros((1, 2)),
        routes=routes,
        u_max=np.ones(2),
        w_effort=0.05,
        dt=0.1,
        params=RouteSpec(speed=0.8, reach=0.7),
    )
    assert rows[1, 3] == 0.0
    assert rows[0, 3] == pytest.approx(2 * 0.05 * 0.8 / 0.1)
    # the first robot heads for a corner beside the disc, with route left beyond it
    assert abs(rows[0, 1]) > 0.5 and rows[0, 2] > 0


def test_a_robot_wedged_where_two_discs_overlap_is_routed_around_them() -> None:
    """Routed from inside both discs, neither would block it and its waypoint would be the
    goal straight through their overlap, where the chance constraints hold it for good."""
    discs = np.array([[0.0, 0.8, 1.0], [0.0, -0.8, 1.0]])  # overlapping across y = 0
    routes = RouteMap(discs, *BOX)
    robot = np.array([[-0.3, 0.0]])  # in the notch, inside both
    assert routes._inside(robot).all()
    rows = route_rows(
        robot,
        can_sense=np.ones(1),
        targets=np.array([[3.0, 0.0]]),
        velocities=np.zeros((1, 2)),
        routes=routes,
        u_max=np.ones(1),
        w_effort=0.05,
        dt=0.1,
        params=RouteSpec(speed=0.8, reach=0.7, lookahead=0.0),
    )
    waypoint = rows[0, RouteRow.WAYPOINT]
    assert not np.allclose(waypoint, [3.0, 0.0])  # not straight through the overlap
    assert np.min(np.linalg.norm(routes.corners - waypoint, axis=1)) < 1e-12  # a corner
    route = np.linalg.norm(waypoint - robot[0]) + rows[0, RouteRow.OFFSET] + 0.7  # + reach
    assert route > np.linalg.norm(robot[0] - [3.0, 0.0]) + 1.0  # around the discs, not through


@pytest.mark.parametrize("seed", range(4))
def test_blocked_segments_are_those_the_exhaustive_test_finds(seed: int) -> None:
    """The disc test skips pairs whose bounding boxes cannot meet: its answer must be the one
    of testing every segment against every disc, including segments grazing a disc."""
    rng = np.random.default_rng(seed)
    discs = np.column_stack([rng.uniform(-8, 8, (6, 2)), rng.uniform(0.3, 2.5, 6)])
    routes = RouteMap(discs, *BOX)
    starts = rng.uniform(-10, 10, (400, 2))
    ends = rng.uniform(-10, 10, (400, 2))
    # segments tangent to a disc (distance exactly the radius) and just inside it
    row = 0
    for x, y, r in discs:
        for inset in (0.0, 2e-6, -2e-6):
            starts[row], ends[row] = (x - 5, y + r - inset), (x + 5, y + r - inset)
            row += 1
    ignore = rng.uniform(size=(400, 6)) < 0.2
    exhaustive = ~np.any(
        (segment_distances(starts, ends, discs[:, :2]) < discs[None, :, 2] - 1e-6) & ~ignore,
        axis=1,
    )
    free = routes._free(starts, ends, ignore)
    assert 0 < free.sum() < len(free)
    np.testing.assert_array_equal(free, exhaustive)
