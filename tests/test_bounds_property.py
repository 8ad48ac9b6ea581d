"""Every value the validator accepts runs to the end with finite numbers, for every policy
(docs/reliability.md §7): scenarios with numbers set exactly at the edges of the bounds."""

from __future__ import annotations

import copy
import math
from typing import Any, get_args, get_origin

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from conftest import SCENARIOS
from helpers import with_policy_needs
from resilient_tracking.policies import POLICIES
from resilient_tracking.scenario import (
    MAX_COORDINATE,
    MAX_DT,
    MAX_VARIANCE,
    MIN_COVARIANCE_RATIO,
    MIN_VARIANCE,
    PolicySpec,
    ScenarioError,
    parse_scenario,
)
from resilient_tracking.scenario_reference import _bounds as bounds_of
from resilient_tracking.scenario_reference import _strip as strip
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
    result = run_episode(parse_scenario(with_policy_needs(data, policy)), policy=policy)
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
    result = run_episode(parse_scenario(with_policy_needs(data, policy)), policy=policy)
    for table in result.tables.values():
        assert np.all(np.isfinite(table.select_dtypes("number").to_numpy(dtype=float)))


def test_the_edges_cover_the_written_bounds():
    assert MIN_VARIANCE in EDGES and MAX_DT in EDGES and 1.0 in EDGES
    assert len(EDGES) > 8


# ---------------------------------------------------------------------------- each bound


def _every_field_base() -> dict[str, Any]:
    """combined-temp with every kind of number the schema has: each target motion, both hazard
    models, a maximum range, a comm range, the IMM estimator's parameters and every built-in
    policy's parameters written out."""
    written = yaml.safe_load((SCENARIOS / "combined-temp.yaml").read_text())
    # the team route's EKF section, which the IMM's parameters extend
    data = parse_scenario(written | {"team": "route"}).model_dump(mode="json")
    data["targets"][1]["motion"] = {"type": "circle", "center": [-2.0, 0.0], "angular_speed": 0.1}
    data["targets"][2]["motion"] = {"type": "ncv", "velocity": [0.1, 0.0], "accel_std": 0.01}
    data["targets"].append(
        {"start": [-2.0, 1.0], "motion": {"type": "constant_velocity", "velocity": [0.1, 0.0]}}
    )
    straight = {"type": "constant_velocity", "velocity": [0.1, 0.0]}
    data["targets"].append(
        {
            "start": [-2.0, -1.0],
            "motion": {"type": "evasive", "base": straight, "radius": 1.0, "speed": 0.3}
            | {"max_accel": 1.0, "wall_margin": 0.5},
        }
    )
    data["targets"].append(
        {
            "start": [-2.5, 0.0],
            "motion": {"type": "lure", "base": straight, "zone": data["zones"][0]["name"]}
            | {"speed": 0.3, "linger": 2.0, "after": 0.1, "period": 3.0, "near": 2.0}
            | {"standoff": 0.1, "max_accel": 1.0},
        }
    )
    data["zones"][-1]["hazard"] = {"model": "disk", "f_act": 1.0, "p_hit": 0.5}
    data["sensor"]["max_range"] = 5.0
    data["comm_range"] = 6.0
    data["estimator"] |= {"type": "imm", "manoeuvre_accel_std": 1.0, "switch_probability": 0.05}
    data["policy"] = {"name": "failure_aware"} | {
        name: POLICIES.get(name).Params().model_dump(mode="json")
        for name in POLICIES.builtin_names()
    }
    return with_policy_needs(with_policy_needs(data, "callable"), "onnx")


EVERY_FIELD = _every_field_base()


def number_rules(annotation: Any) -> list[Any]:
    """The constraints on each number of a point, of a list of points, or of a number."""
    inner = strip(annotation)
    if get_origin(inner) in (list, tuple):
        return number_rules(get_args(inner)[0])
    return bounds_of(annotation)


def _field_bounds(path: tuple) -> tuple[float | None, float | None]:
    """The smallest and largest value the schema accepts at ``path`` (one ulp inside a strict
    bound), from the field's own constraints; ``None`` where it has none."""
    obj: Any = parse_scenario(copy.deepcopy(EVERY_FIELD))
    keys = list(path)
    while True:
        key = keys.pop(0)
        if isinstance(obj, PolicySpec) and key not in PolicySpec.model_fields:
            obj = obj.params_for(key)
            continue
        if isinstance(obj, list):
            obj = obj[key]
            continue
        field = type(obj).model_fields[key]
        value = getattr(obj, key)
        if not keys:
            rules = field.metadata + bounds_of(field.annotation)
            break
        if isinstance(value, tuple) or (isinstance(value, list) and isinstance(value[0], tuple)):
            rules = number_rules(field.annotation)  # a point or points: each number's bounds
            break
        obj = value
    low = high = None
    for rule in rules:
        for name, inward, is_low in (
            ("ge", None, True),
            ("gt", math.inf, True),
            ("le", None, False),
            ("lt", -math.inf, False),
        ):
            bound = getattr(rule, name, None)
            if bound is None:
                continue
            edge = bound if inward is None else math.nextafter(bound, inward)
            if is_low:
                low = edge
            else:
                high = edge
    return low, high


def _policy_for(path: tuple) -> str:
    return (
        path[1] if path[0] == "policy" and path[1] in POLICIES.builtin_names() else "failure_aware"
    )


#: Every number of the scenario but the episode's length and seed, and Σ (see SIGMAS above).
NUMBER_PATHS = [
    p for p in numeric_leaves(EVERY_FIELD) if p[0] not in ("steps", "seed") and "sigma" not in p
]


def _run_at(path: tuple, value: float) -> None:
    data = copy.deepcopy(EVERY_FIELD)
    data["steps"] = 3
    if isinstance(get(data, path), int) and float(value).is_integer():
        value = int(value)
    put(data, path, value)
    try:
        scenario = parse_scenario(data)
    except ScenarioError as err:  # only a cross-field rule may refuse a value within the bounds
        assert not any(p.startswith(".".join(map(str, path)) + ": Input") for p in err.problems)
        return
    result = run_episode(scenario, policy=_policy_for(path))
    for name, table in result.tables.items():
        numbers = table.select_dtypes("number").to_numpy(dtype=float)
        assert np.all(np.isfinite(numbers)), (name, path, value)


#: The fields whose values beyond today's bounds once gave infinity, an overflow or failed solves.
ONCE_UNBOUNDED = [
    ("targets", 0, "motion", "speed"),
    ("targets", 1, "motion", "angular_speed"),
    ("targets", 2, "motion", "accel_std"),
    ("estimator", "accel_std"),
    ("estimator", "initial_position_std"),
    ("robots", 0, "u_max"),
    ("sensor", "range", "peak"),
    ("policy", "failure_aware", "risky", "track"),
    ("policy", "vanilla", "w_effort"),
]


@pytest.mark.parametrize("path", ONCE_UNBOUNDED, ids=lambda p: ".".join(map(str, p)))
@pytest.mark.filterwarnings("error::RuntimeWarning")
def test_a_value_at_either_bound_of_a_once_unbounded_field_runs_finite(path):
    low, high = _field_bounds(path)
    assert high is not None, path  # bounded above
    for value in (low, high):
        if value is not None:
            _run_at(path, value)


@pytest.mark.parametrize("path", ONCE_UNBOUNDED, ids=lambda p: ".".join(map(str, p)))
def test_a_value_beyond_the_bound_is_refused_naming_the_field(path):
    data = copy.deepcopy(EVERY_FIELD)
    put(data, path, 1e200)
    with pytest.raises(ScenarioError) as err:
        parse_scenario(data)
    assert any(p.startswith(".".join(map(str, path)) + ": ") for p in err.value.problems)


def test_every_number_of_the_schema_is_bounded_above():
    unbounded = [p for p in NUMBER_PATHS if _field_bounds(p)[1] is None]
    assert unbounded == []


@pytest.mark.slow
@pytest.mark.parametrize("path", NUMBER_PATHS, ids=lambda p: ".".join(map(str, p)))
@pytest.mark.filterwarnings("error::RuntimeWarning")
def test_a_value_at_either_bound_of_every_field_runs_finite(path):
    for value in _field_bounds(path):
        if value is not None:
            _run_at(path, value)
