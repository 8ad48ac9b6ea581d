"""Bounded caches of league problems: a long mission meeting new structures keeps flat memory."""

from __future__ import annotations

import pytest

from helpers import inputs, structure_of
from resilient_tracking.planning.cache import LruCache
from resilient_tracking.planning.planner import LeaguePlanner


def test_least_recently_used_entries_beyond_the_budget_are_evicted():
    evicted: list[tuple[str, int]] = []
    cache: LruCache[str, int] = LruCache(
        10, weigh=float, on_evict=lambda k, v: evicted.append((k, v))
    )
    built = []

    def build(value: int):
        return lambda: built.append(value) or value

    assert cache.get("a", build(4)) == 4
    assert cache.get("b", build(5)) == 5
    assert cache.get("a", build(99)) == 4  # a hit: not rebuilt, and now the most recent
    assert cache.get("c", build(3)) == 3  # 4 + 5 + 3 > 10: the least recent ("b") goes
    assert evicted == [("b", 5)]
    assert list(cache) == ["a", "c"] and cache.total == 7
    assert built == [4, 5, 3]
    assert cache.get("b", build(5)) == 5  # rebuilt on return; "a" is now the oldest
    assert [k for k, _ in evicted] == ["b", "a"]
    assert (cache.builds, cache.evictions) == (4, 2)


def test_an_entry_heavier_than_the_budget_is_kept_alone():
    cache: LruCache[str, int] = LruCache(10, weigh=float)
    cache.get("small", lambda: 2)
    cache.get("huge", lambda: 50)
    assert list(cache) == ["huge"]


def test_the_budget_must_be_positive():
    with pytest.raises(ValueError, match="budget"):
        LruCache(0)


class SmallPlanner(LeaguePlanner):
    PROBLEM_BUDGET = 1.0  # one problem at a time

    def weigh(self, problem):
        return 1.0


def test_a_planner_forgets_evicted_structures_and_their_warm_starts():
    planner = SmallPlanner()
    one, two = inputs(sensing_zones=1), inputs(sensing_zones=2)
    first = planner.plan(structure_of(one), (0, 1, 2), one)
    assert (structure_of(one), (0, 1, 2)) in planner._warm
    planner.plan(structure_of(two), (0, 1, 2), two)
    assert list(planner._problems) == [structure_of(two)]
    assert [key[0] for key in planner._warm] == [structure_of(two)]
    again = planner.plan(structure_of(one), (0, 1, 2), one)  # rebuilt, solved cold as at first
    assert again.success
    assert again.controls.tolist() == first.controls.tolist()


def test_a_planner_keeps_a_bounded_number_of_warm_starts():
    planner = LeaguePlanner()
    planner.WARM_STARTS = 3
    q = inputs(n=1, big_n=1, sensing_zones=0, comm_zones=0)
    for robot in range(5):
        planner.plan(structure_of(q), (robot,), q)
    assert [members for _, members in planner._warm] == [(2,), (3,), (4,)]


def test_the_league_planner_weighs_problems_by_the_symbolic_code_they_built():
    planner = LeaguePlanner()
    small, large = inputs(n=1, big_n=1, sensing_zones=0, comm_zones=0), inputs()
    assert planner.weigh(planner.problem(structure_of(small))) == 0  # nothing built yet
    planner.plan(structure_of(small), (0,), small)
    planner.plan(structure_of(large), (0, 1, 2), large)
    w_small = planner.weigh(planner.problem(structure_of(small)))
    w_large = planner.weigh(planner.problem(structure_of(large)))
    assert 0 < w_small < w_large
    assert planner._problems.total == w_small + w_large
