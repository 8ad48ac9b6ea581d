"""Every value the validator accepts runs to the end with finite numbers, for every policy
(docs/reliability.md §7): scenarios with numbers set exactly at the edges of the bounds."""

from __future__ import annotations

import copy
import math
from typing import Any

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from conftest import SCENARIOS
from resilient_tracking.policies import POLICIES
from resilient_tracking.scenario import (
    MAX_COORDINATE,
    MAX_DT,
    MAX_VARIANCE,
    MIN_COVARIANCE_RATIO,
    MIN_VARIANCE,
    ScenarioError,
    parse_scenario,
)
from resilient_tracking.scenario_reference import sections
from resilient_tracking.sim.episode import run_episode

BASES = {
    name: yaml.safe_load((SCENARIOS / f"{name}.yaml").read_text())
    for name in ("sensing-temp", "comm-temp", "combined-temp")
}


def edge_values() -> list[float]:
    """Every bound written in the scenario models (``ge``/``le`` as is, ``gt``/``lt`` one ulp
    inside) and the module's limits, positive and negative."""
    values = {0.0, 1.0, MIN_VARIANCE, MAX_VARIANCE, MAX_COORDINATE, -MAX_COORDINATE, MAX_DT}
    inward = {"ge": None, "le": None, "gt": math.inf, "lt": -math.inf}
    rules = [r for s in sections() for f in s.model.model_fields.values() for r in f.metadata]
    for rule in rules:
        for name, direction in inward.items():
            bound = getattr(rule, name, None)
            if isinstance(bound, int | float) and math.isfinite(bound):
                edge = bound if direction is None else math.nextafter(bound, direction)
                values.add(float(edge))
    return sorted(values)


EDGES = edge_values()

#: Σ at its bounds: smallest eigenvalue, largest entries, flattest allowed shape, correlated.
SIGMAS = [
    [[MIN_VARIANCE, 0.0], [0.0, MIN_VARIANCE]],
    [[MAX_VARIANCE, 0.0], [0.0, MAX_VARIANCE]],
    [[MAX_VARIANCE, 0.0], [0.0, MAX_VARIANCE * MIN_COVARIANCE_RATIO * 1.001]],
    [[1.0, 0.0], [0.0, MIN_COVARIANCE_RATIO * 1.001]],
    [[1.0, 0.999], [0.999, 1.0]],
]


def numeric_leaves(node: Any, path: tuple = ()) -> list[tuple]:
    if isinstance(node, dict):
        return [p for k, v in node.items() for p in numeric_leaves(v, (*path, k))]
    if isinstance(node, list):
        return [p for i, v in enumerate(node) for p in numeric_leaves(v, (*path, i))]
    if isinstance(node, int | float) and not isinstance(node, bool):
        return [path]
    return []


def get(data: Any, path: tuple) -> Any:
    for key in path:
        data = data[key]
    return data


def put(data: Any, path: tuple, value: Any) -> None:
    get(data, path[:-1])[path[-1]] = value


@st.composite
def scenario_at_the_edges(draw: st.DrawFn) -> dict[str, Any]:
    data = copy.deepcopy(BASES[draw(st.sampled_from(sorted(BASES)))])
    data["steps"] = 3
    leaves = [p for p in numeric_leaves(data) if p[0] not in ("steps", "seed")]
    for path in draw(st.lists(st.sampled_from(leaves), min_size=1, max_size=3, unique=True)):
        value = draw(st.sampled_from(EDGES))
        if isinstance(get(data, path), int):
            value = int(value) if abs(value) < 2**53 else value
        put(data, path, value)
    if draw(st.booleans()):
        zone = data["zones"][draw(st.integers(0, len(data["zones"]) - 1))]
        zone["sigma"] = draw(st.sampled_from(SIGMAS))
        if draw(st.booleans()):  # on top of a robot
            zone["mu"] = list(data["robots"][draw(st.integers(0, 2))]["start"])
    try:
        parse_scenario(data)
    except ScenarioError:
        assume(False)
    return data


@settings(
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.filter_too_much],
    max_examples=max(8, settings().max_examples // 6),
)
@given(scenario_at_the_edges(), st.sampled_from(POLICIES.builtin_names()))
@pytest.mark.filterwarnings("error::RuntimeWarning")  # an overflow or 0/0 is a numerical bug
def test_every_policy_runs_scenarios_at_the_edges_of_the_bounds_with_finite_numbers(data, policy):
    result = run_episode(parse_scenario(data), policy=policy)
    assert len(result["team"]) == 3
    for name, table in result.tables.items():
        numbers = table.select_dtypes("number").to_numpy(dtype=float)
        assert np.all(np.isfinite(numbers)), (name, policy)


@pytest.mark.parametrize("policy", POLICIES.builtin_names())
@pytest.mark.parametrize("sigma", SIGMAS[:2], ids=["smallest", "largest"])
@pytest.mark.filterwarnings("error::RuntimeWarning")
def test_a_zone_on_a_robot_with_the_extreme_covariances_runs_finite(policy, sigma):
    data = copy.deepcopy(BASES["sensing-temp"])
    data["steps"] = 3
    data["zones"][0]["sigma"] = sigma
    data["zones"][0]["mu"] = list(data["robots"][0]["start"])
    result = run_episode(parse_scenario(data), policy=policy)
    for table in result.tables.values():
        assert np.all(np.isfinite(table.select_dtypes("number").to_numpy(dtype=float)))


def test_the_edges_cover_the_written_bounds():
    assert MIN_VARIANCE in EDGES and MAX_DT in EDGES and 1.0 in EDGES
    assert len(EDGES) > 8
