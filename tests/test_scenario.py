"""Scenario validation: bad input gives a ScenarioError whose problems name the field and value."""

from __future__ import annotations

import copy
import math
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from resilient_tracking.scenario import (
    CommZone,
    DiskHazard,
    Scenario,
    ScenarioError,
    SensingZone,
    apply_overrides,
    load_scenario,
    overridden,
    parse_scenario,
)

# A problem line: ``field.path: message (got value)``.
PROBLEM_LINE = re.compile(r"^[\w.<>]+: .+ \(got .+\)$")


def valid_base() -> dict[str, Any]:
    """A fresh, valid, minimal scenario mapping (two robots, so ``robots.1`` exists)."""
    return {
        "name": "minimal",
        "seed": 3,
        "dt": 0.1,
        "steps": 20,
        "workspace": {"xmin": -5.0, "xmax": 5.0, "ymin": -5.0, "ymax": 5.0},
        "robots": [{"start": [0.0, 0.0]}, {"start": [1.0, -1.0], "u_max": 0.5}],
        "targets": [
            {
                "start": [2.0, 2.0],
                "motion": {"type": "constant_velocity", "velocity": [0.1, 0.0]},
            }
        ],
        "zones": [
            {
                "kind": "sensing",
                "mu": [0.1, 0.0],
                "sigma": [[0.3, 0.0], [0.0, 0.3]],
                "radius": 0.5,
            }
        ],
    }


def problems_of(data: Any) -> list[str]:
    """The problems ``parse_scenario`` reports; fails the test if it accepts ``data``."""
    with pytest.raises(ScenarioError) as info:
        parse_scenario(data, source="test.yaml")
    problems = info.value.problems
    assert problems, "a ScenarioError must list at least one problem"
    assert all(isinstance(p, str) for p in problems)
    return problems


def only_problem(data: Any) -> str:
    problems = problems_of(data)
    assert len(problems) == 1, problems
    return problems[0]


def write(tmp_path: Path, text: str, name: str = "scenario.yaml") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


# ------------------------------------------------------------------------------ valid input


def test_valid_base_parses() -> None:
    scenario = parse_scenario(valid_base())
    assert isinstance(scenario, Scenario)
    assert scenario.dt == pytest.approx(0.1)
    assert scenario.steps == 20
    assert scenario.robots[1].start == (1.0, -1.0)
    assert scenario.robots[1].u_max == pytest.approx(0.5)
    assert scenario.robots[0].u_max == pytest.approx(1.0)  # default
    zone = scenario.zones[0]
    assert isinstance(zone, SensingZone)
    assert zone.persistence == "temporary"
    assert zone.m_recover == pytest.approx(2.0)


def test_valid_base_is_fresh_each_time() -> None:
    first = valid_base()
    first["robots"][0]["start"] = [99.0, 99.0]
    assert valid_base()["robots"][0]["start"] == [0.0, 0.0]


def test_parsing_does_not_mutate_input() -> None:
    data = valid_base()
    before = copy.deepcopy(data)
    parse_scenario(data)
    assert data == before


@pytest.mark.parametrize(
    "motion",
    [
        {"type": "constant_velocity", "velocity": [0.0, 0.1]},
        {"type": "waypoints", "points": [[3.0, 3.0], [-3.0, 3.0]], "speed": 0.2, "loop": True},
        {"type": "circle", "center": [0.0, 2.0], "angular_speed": -0.1},
        {"type": "ncv", "velocity": [0.05, 0.0], "accel_std": 0.0},
    ],
    ids=lambda m: m["type"],
)
def test_every_motion_type_parses(motion: dict[str, Any]) -> None:
    data = valid_base()
    data["targets"][0]["motion"] = motion
    assert parse_scenario(data).targets[0].motion.type == motion["type"]


def test_comm_zone_with_disk_hazard_and_all_sections_parse() -> None:
    data = valid_base()
    data["zones"].append(
        {
            "name": "jammer",
            "kind": "comm",
            "mu": [-2.0, 1.0],
            "sigma": [[0.5, 0.1], [0.1, 0.4]],
            "delta2": 0.6,
            "persistence": "permanent",
            "hazard": {"model": "disk", "f_act": 2.0, "p_hit": 0.25},
            "m_recover": 3.0,
        }
    )
    data["sensor"] = {"range": {"peak": 10.0, "shape": 0.1}, "bearing": {}, "max_range": 8.0}
    data["estimator"] = {"accel_std": 0.3}
    data["comm_range"] = 6.0
    data["policy"] = {"name": "vanilla", "vanilla": {"w_track": 5.0, "w_effort": 0.1}}
    scenario = parse_scenario(data)
    zone = scenario.zones[1]
    assert isinstance(zone, CommZone)
    assert isinstance(zone.hazard, DiskHazard)
    assert zone.hazard.p_hit == pytest.approx(0.25)
    assert scenario.sensor.range.peak == pytest.approx(10.0)
    assert scenario.sensor.bearing.peak == pytest.approx(15.0)  # default
    assert scenario.comm_range == pytest.approx(6.0)


def test_load_scenario_reads_a_valid_file(tmp_path: Path) -> None:
    path = write(tmp_path, yaml.safe_dump(valid_base()))
    assert load_scenario(path) == parse_scenario(valid_base())


# ------------------------------------------------------------------------------ covariance


def test_sigma_not_positive_definite_names_field_and_value() -> None:
    data = valid_base()
    data["zones"][0]["sigma"] = [[1, 2], [2, 1]]
    problem = only_problem(data)
    assert problem.startswith("zones.0.sigma"), problem
    assert "positive definite" in problem
    assert "[[1, 2], [2, 1]]" in problem


def test_sigma_zero_matrix_is_not_positive_definite() -> None:
    data = valid_base()
    data["zones"][0]["sigma"] = [[0.0, 0.0], [0.0, 0.0]]
    assert only_problem(data).startswith("zones.0.sigma")


def test_sigma_not_symmetric_names_field_and_value() -> None:
    data = valid_base()
    data["zones"][0]["sigma"] = [[1.0, 0.5], [0.2, 1.0]]
    problem = only_problem(data)
    assert problem.startswith("zones.0.sigma"), problem
    assert "symmetric" in problem
    assert "0.2" in problem and "0.5" in problem


def test_sigma_of_second_zone_names_its_index() -> None:
    data = valid_base()
    data["zones"].append(
        {"kind": "comm", "mu": [1.0, 1.0], "sigma": [[1, 2], [2, 1]], "delta2": 0.5}
    )
    assert only_problem(data).startswith("zones.1.sigma")


# ------------------------------------------------------------------------------ scalar ranges


@pytest.mark.parametrize("dt", [0, 0.0, -0.1, -1e9])
def test_dt_not_positive(dt: float) -> None:
    data = valid_base()
    data["dt"] = dt
    problem = only_problem(data)
    assert problem.startswith("dt:"), problem
    assert f"(got {dt!r})" in problem


@pytest.mark.parametrize(
    ("path", "value"),
    [
        (("steps",), 0),
        (("seed",), -1),
        (("comm_range",), 0.0),
        (("robots", 0, "u_max"), -1.0),
        (("zones", 0, "radius"), 0.0),
        (("zones", 0, "m_recover"), 0.0),
        (("sensor", "max_range"), -3.0),
        (("estimator", "accel_std"), 0.0),
    ],
    ids=lambda v: ".".join(map(str, v)) if isinstance(v, tuple) else repr(v),
)
def test_out_of_range_values_name_their_path(path: tuple[Any, ...], value: Any) -> None:
    data = valid_base()
    node: Any = data
    for key in path[:-1]:
        node = node.setdefault(key, {}) if isinstance(key, str) else node[key]
    node[path[-1]] = value
    dotted = ".".join(map(str, path))
    problem = only_problem(data)
    assert problem.startswith(dotted + ":"), problem
    assert repr(value) in problem


@pytest.mark.parametrize("p_hit", [-0.1, 1.5])
def test_disk_p_hit_outside_unit_interval(p_hit: float) -> None:
    data = valid_base()
    data["zones"][0]["hazard"] = {"model": "disk", "p_hit": p_hit}
    problem = only_problem(data)
    assert problem.startswith("zones.0.hazard.p_hit:"), problem
    assert repr(p_hit) in problem


# ------------------------------------------------------------------------------ geometry


def test_robot_outside_workspace() -> None:
    data = valid_base()
    data["robots"][1]["start"] = [9.0, 0.0]
    problem = only_problem(data)
    assert problem.startswith("robots.1.start"), problem
    assert "outside" in problem
    assert "9.0" in problem


def test_robot_on_workspace_boundary_is_inside() -> None:
    data = valid_base()
    data["robots"][1]["start"] = [5.0, -5.0]
    parse_scenario(data)


def test_target_outside_workspace() -> None:
    data = valid_base()
    data["targets"][0]["start"] = [0.0, -7.5]
    problem = only_problem(data)
    assert problem.startswith("targets.0.start"), problem
    assert "-7.5" in problem


def test_empty_workspace() -> None:
    data = valid_base()
    data["workspace"] = {"xmin": 1.0, "xmax": 1.0, "ymin": -5.0, "ymax": 5.0}
    data["robots"] = [{"start": [1.0, 0.0]}]
    data["targets"][0]["start"] = [1.0, 1.0]
    problem = only_problem(data)
    assert problem.startswith("workspace.xmax"), problem


def test_circle_center_at_start() -> None:
    data = valid_base()
    data["targets"][0]["motion"] = {"type": "circle", "center": [2.0, 2.0], "angular_speed": 0.1}
    assert only_problem(data).startswith("targets.0.motion.center")


# ------------------------------------------------------------------------------ kinds, shapes


def test_unknown_zone_kind() -> None:
    data = valid_base()
    data["zones"][0]["kind"] = "radiation"
    problem = only_problem(data)
    assert problem.startswith("zones.0"), problem
    assert "radiation" in problem


def test_unknown_motion_type_and_hazard_model() -> None:
    data = valid_base()
    data["targets"][0]["motion"] = {"type": "teleport"}
    data["zones"][0]["hazard"] = {"model": "laser"}
    problems = problems_of(data)
    assert any(p.startswith("targets.0.motion") and "teleport" in p for p in problems), problems
    assert any(p.startswith("zones.0.hazard") and "laser" in p for p in problems), problems


def test_unknown_policy_name() -> None:
    data = valid_base()
    data["policy"] = {"name": "magic"}
    problem = only_problem(data)
    assert problem.startswith("policy.name"), problem
    assert "magic" in problem


def test_every_policy_section_is_checked_by_that_policys_params() -> None:
    data = valid_base()
    data["policy"] = {"name": "vanilla", "failure_aware": {"eps1": 0.7}, "sog": {"rho2": 0.2}}
    problem = only_problem(data)
    assert problem.startswith("policy.failure_aware.eps1: "), problem
    data["policy"]["failure_aware"] = {"eps1": 0.05}
    policy = parse_scenario(data).policy
    assert policy.params_for("failure_aware").eps1 == 0.05
    assert policy.params_for("sog").rho2 == 0.2
    assert policy.params_for("vanilla") == policy.params_for("vanilla").__class__()  # defaults


def test_params_are_the_named_policys_section_and_given_once() -> None:
    data = valid_base()
    data["policy"] = {"name": "failure_aware", "params": {"eps1": 0.05}}
    assert parse_scenario(data).policy.params_for("failure_aware").eps1 == 0.05
    data["policy"]["params"] = {"eps1": 0.9}
    assert only_problem(data).startswith("policy.params.eps1: ")
    data["policy"] = {"name": "failure_aware", "params": {"eps1": 0.05}, "failure_aware": {}}
    assert "given twice" in only_problem(data)


def test_a_section_must_name_a_policy() -> None:
    data = valid_base()
    data["policy"] = {"name": "vanilla", "magic": {"x": 1}}
    problem = only_problem(data)
    assert problem.startswith("policy.magic: not a policy"), problem


def test_start_with_three_numbers() -> None:
    data = valid_base()
    data["robots"][0]["start"] = [0.0, 0.0, 1.0]
    problem = only_problem(data)
    assert problem.startswith("robots.0.start"), problem
    assert "[0.0, 0.0, 1.0]" in problem


def test_start_with_one_number() -> None:
    data = valid_base()
    data["targets"][0]["start"] = [1.0]
    assert problems_of(data)[0].startswith("targets.0.start")


def test_sigma_three_by_three() -> None:
    data = valid_base()
    data["zones"][0]["sigma"] = [[1, 0, 0], [0, 1, 0], [0, 0, 1]]
    problems = problems_of(data)
    assert all(p.startswith("zones.0.sigma") for p in problems), problems


def test_sigma_flat_list() -> None:
    data = valid_base()
    data["zones"][0]["sigma"] = [0.3, 0.3]
    problems = problems_of(data)
    assert all(p.startswith("zones.0.sigma") for p in problems), problems


def test_string_where_number_expected() -> None:
    data = valid_base()
    data["robots"][0]["start"] = ["left", 0.0]
    problem = only_problem(data)
    assert problem.startswith("robots.0.start.0"), problem
    assert "left" in problem


# ------------------------------------------------------------------------------ NaN and infinity


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf], ids=["nan", "inf", "-inf"])
def test_non_finite_dt(bad: float) -> None:
    data = valid_base()
    data["dt"] = bad
    problem = only_problem(data)
    assert problem.startswith("dt:"), problem
    assert repr(bad) in problem


@pytest.mark.parametrize("bad", [math.nan, math.inf], ids=["nan", "inf"])
def test_non_finite_robot_start(bad: float) -> None:
    data = valid_base()
    data["robots"][1]["start"] = [0.0, bad]
    problem = only_problem(data)
    assert problem.startswith("robots.1.start"), problem
    assert repr(bad) in problem


@pytest.mark.parametrize("bad", [math.nan, math.inf], ids=["nan", "inf"])
def test_non_finite_sigma_entry(bad: float) -> None:
    data = valid_base()
    data["zones"][0]["sigma"] = [[bad, 0.0], [0.0, 0.3]]
    problems = problems_of(data)
    assert all(p.startswith("zones.0.sigma") for p in problems), problems
    assert any(repr(bad) in p for p in problems), problems


def test_non_finite_workspace_bound() -> None:
    data = valid_base()
    data["workspace"]["xmax"] = math.inf
    problem = only_problem(data)
    assert problem.startswith("workspace.xmax"), problem


@pytest.mark.parametrize(
    ("text", "field"),
    [
        (".nan", "dt"),
        (".inf", "dt"),
        ("-.inf", "dt"),
        (".NaN", "dt"),
    ],
)
def test_non_finite_in_yaml_text(tmp_path: Path, text: str, field: str) -> None:
    body = yaml.safe_dump(valid_base()).replace("dt: 0.1", f"dt: {text}")
    assert f"dt: {text}" in body
    path = write(tmp_path, body)
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    assert len(info.value.problems) == 1, info.value.problems
    assert info.value.problems[0].startswith(f"{field}:")
    assert "nan" in info.value.problems[0] or "inf" in info.value.problems[0]


def test_nan_in_yaml_sigma_and_start(tmp_path: Path) -> None:
    text = """
robots:
  - start: [0.0, .nan]
targets:
  - start: [1.0, 1.0]
    motion: {type: constant_velocity, velocity: [0.0, 0.0]}
zones:
  - kind: sensing
    mu: [0.0, 0.0]
    sigma: [[.inf, 0.0], [0.0, 1.0]]
    radius: 0.5
"""
    with pytest.raises(ScenarioError) as info:
        load_scenario(write(tmp_path, text))
    problems = info.value.problems
    assert any(p.startswith("robots.0.start") and "nan" in p for p in problems), problems
    assert any(p.startswith("zones.0.sigma") and "inf" in p for p in problems), problems


# ------------------------------------------------------------------------------ unknown keys


def test_unknown_top_level_key() -> None:
    data = valid_base()
    data["dtt"] = 0.1
    problem = only_problem(data)
    assert problem.startswith("dtt:"), problem
    assert "0.1" in problem


@pytest.mark.parametrize(
    ("where", "expected"),
    [
        (lambda d: d["robots"][1], "robots.1.speed"),
        (lambda d: d["workspace"], "workspace.speed"),
        (lambda d: d["zones"][0], "zones.0.speed"),
        (lambda d: d["targets"][0]["motion"], "targets.0.motion.speed"),
    ],
    ids=["robot", "workspace", "zone", "motion"],
)
def test_unknown_nested_key(where: Any, expected: str) -> None:
    data = valid_base()
    where(data)["speed"] = 7
    problem = only_problem(data)
    assert problem.startswith(expected + ":"), problem
    assert "(got 7)" in problem


def test_field_of_the_other_zone_kind_is_unknown() -> None:
    data = valid_base()
    data["zones"][0]["delta2"] = 0.5  # a comm-zone field on a sensing zone
    assert only_problem(data).startswith("zones.0.delta2")


# ------------------------------------------------------------------------------ not a mapping


@pytest.mark.parametrize("data", [[1, 2, 3], "scenario", 42, None, 1.5])
def test_parse_non_mapping(data: Any) -> None:
    problem = only_problem(data)
    assert problem.startswith("<root>"), problem
    assert "mapping" in problem


@pytest.mark.parametrize("text", ["- a\n- b\n", "just a string\n", "42\n", ""])
def test_yaml_that_is_not_a_mapping(tmp_path: Path, text: str) -> None:
    with pytest.raises(ScenarioError) as info:
        load_scenario(write(tmp_path, text))
    assert info.value.problems[0].startswith("<root>")


# ------------------------------------------------------------------------------ required fields


def test_empty_robot_list() -> None:
    data = valid_base()
    data["robots"] = []
    problem = only_problem(data)
    assert problem.startswith("robots:"), problem
    assert "(got [])" in problem


@pytest.mark.parametrize("field", ["robots", "targets"])
def test_missing_required_top_level(field: str) -> None:
    data = valid_base()
    del data[field]
    assert only_problem(data).startswith(f"{field}:")


@pytest.mark.parametrize(
    ("field", "path"),
    [("radius", "zones.0.radius"), ("mu", "zones.0.mu"), ("sigma", "zones.0.sigma")],
)
def test_missing_zone_field(field: str, path: str) -> None:
    data = valid_base()
    del data["zones"][0][field]
    problem = only_problem(data)
    assert problem.startswith(path + ":"), problem
    assert "required" in problem.lower()


def test_missing_robot_start() -> None:
    data = valid_base()
    del data["robots"][1]["start"]
    assert only_problem(data).startswith("robots.1.start:")


# ------------------------------------------------------------------------------ many problems


def test_several_problems_are_all_reported() -> None:
    data = valid_base()
    data["dt"] = 0
    data["zones"][0]["sigma"] = [[1, 2], [2, 1]]
    data["robots"][0]["start"] = [0.0, math.nan]
    data["bogus"] = True
    problems = problems_of(data)
    assert len(problems) >= 2
    for prefix in ("dt:", "zones.0.sigma", "robots.0.start", "bogus:"):
        assert any(p.startswith(prefix) for p in problems), (prefix, problems)
    for problem in problems:
        assert PROBLEM_LINE.match(problem), problem


def test_several_geometry_problems_are_all_reported() -> None:
    data = valid_base()
    data["robots"][0]["start"] = [6.0, 0.0]
    data["robots"][1]["start"] = [0.0, -6.0]
    data["targets"][0]["start"] = [10.0, 10.0]
    problems = problems_of(data)
    assert len(problems) == 3, problems
    assert [p.split(":")[0] for p in problems] == [
        "robots.0.start",
        "robots.1.start",
        "targets.0.start",
    ]


def test_error_message_lists_source_and_every_problem() -> None:
    data = valid_base()
    data["dt"] = -1
    data["steps"] = 0
    with pytest.raises(ScenarioError) as info:
        parse_scenario(data, source="my.yaml")
    err = info.value
    assert err.source == "my.yaml"
    assert isinstance(err, ValueError)
    text = str(err)
    assert text.startswith("my.yaml: 2 problem(s)")
    for problem in err.problems:
        assert problem in text


# ------------------------------------------------------------------------------ files


def test_missing_file(tmp_path: Path) -> None:
    path = tmp_path / "nope.yaml"
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    assert info.value.source == str(path)
    assert info.value.problems[0].startswith("<file>")


def test_directory_instead_of_file(tmp_path: Path) -> None:
    with pytest.raises(ScenarioError):
        load_scenario(tmp_path)


@pytest.mark.parametrize(
    "text",
    [
        "robots: [\n",
        "a: b: c\n",
        "key: 'unterminated\n",
        "\tdt: 0.1\n",
        "!!python/object/apply:os.system ['true']\n",
    ],
)
def test_invalid_yaml_syntax(tmp_path: Path, text: str) -> None:
    path = write(tmp_path, text)
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    assert info.value.source == str(path)
    assert info.value.problems[0].startswith("<yaml>")


def test_file_that_is_not_utf8(tmp_path: Path) -> None:
    path = tmp_path / "binary.yaml"
    path.write_bytes(b"\xff\xfe\x00dt: 0.1\n")
    with pytest.raises(ScenarioError):
        load_scenario(path)


def test_problems_from_a_file_carry_its_path(tmp_path: Path) -> None:
    data = valid_base()
    data["dt"] = -0.5
    path = write(tmp_path, yaml.safe_dump(data))
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    assert info.value.source == str(path)
    assert info.value.problems == ["dt: Input should be greater than or equal to 0.001 (got -0.5)"]


# ------------------------------------------------------------------------------ overrides


def test_dotted_overrides_set_nested_fields_and_list_items() -> None:
    scenario = parse_scenario(valid_base())
    changed = overridden(scenario, {"zones.0.radius": 0.75, "robots.1.u_max": 0.25, "steps": 9})
    assert (changed.zones[0].radius, changed.robots[1].u_max, changed.steps) == (0.75, 0.25, 9)
    assert scenario.zones[0].radius == 0.5  # the original is untouched
    assert overridden(scenario, {}) is scenario


def test_dotted_overrides_create_missing_sections() -> None:
    data = valid_base()
    scenario = apply_overrides(data, {"policy.failure_aware.eps1": 0.05}, "test.yaml")
    assert scenario.policy.params_for("failure_aware").eps1 == 0.05


def test_top_level_overrides_are_dotted_paths_of_one_step() -> None:
    scenario = parse_scenario(valid_base())
    assert scenario.with_overrides(seed=7, zones=[]) == overridden(
        scenario, {"seed": 7, "zones": []}
    )


@pytest.mark.parametrize(
    ("path", "value"),
    [("zones.3.radius", 1.0), ("robots.first.u_max", 1.0), ("dt.value", 0.1)],
)
def test_an_override_that_cannot_be_set_names_its_path(path: str, value: Any) -> None:
    with pytest.raises(ScenarioError) as info:
        apply_overrides(valid_base(), {path: value}, "test.yaml")
    assert info.value.source == "test.yaml"
    assert info.value.problems == [f"{path}: no such field to set (got {value!r})"]


def test_an_override_the_schema_refuses_names_its_path() -> None:
    scenario = parse_scenario(valid_base())
    with pytest.raises(ScenarioError) as info:
        overridden(scenario, {"zones.0.radius": -1.0}, "with a bad radius")
    assert info.value.source == "with a bad radius"
    assert [p.split(":")[0] for p in info.value.problems] == ["zones.0.radius"]


# ------------------------------------------------------------------------------ property


def _set_dt(data: dict[str, Any], value: float) -> None:
    data["dt"] = value


def _set_sigma(i: int, j: int, symmetric: bool) -> Any:
    def inject(data: dict[str, Any], value: float) -> None:
        sigma = data["zones"][0]["sigma"]
        sigma[i][j] = value
        if symmetric:
            sigma[j][i] = value

    inject.__name__ = f"sigma[{i}][{j}]{'+sym' if symmetric else ''}"
    return inject


def _set_start(robot: int, axis: int) -> Any:
    def inject(data: dict[str, Any], value: float) -> None:
        data["robots"][robot]["start"][axis] = value

    inject.__name__ = f"robots[{robot}].start[{axis}]"
    return inject


INJECTORS = [
    _set_dt,
    *(_set_sigma(i, j, sym) for i in (0, 1) for j in (0, 1) for sym in (False, True)),
    *(_set_start(r, a) for r in (0, 1) for a in (0, 1)),
]


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    injections=st.lists(
        st.tuples(st.sampled_from(INJECTORS), st.floats()),
        min_size=1,
        max_size=3,
    )
)
def test_random_floats_give_scenario_or_scenario_error(
    injections: list[tuple[Any, float]],
) -> None:
    data = valid_base()
    for inject, value in injections:
        inject(data, value)
    try:
        scenario = parse_scenario(data)
    except ScenarioError as err:
        assert err.problems
        assert all(isinstance(p, str) and ": " in p for p in err.problems)
        return
    # Accepted: everything is finite and usable downstream.
    assert math.isfinite(scenario.dt) and scenario.dt > 0
    sigma = np.asarray(scenario.zones[0].sigma, dtype=float)
    assert np.all(np.isfinite(sigma))
    assert np.allclose(sigma, sigma.T, rtol=0, atol=1e-12)  # the documented tolerance
    assert np.linalg.eigvalsh(sigma).min() > 0
    for robot in scenario.robots:
        assert all(math.isfinite(c) for c in robot.start)
        assert scenario.workspace.contains(robot.start)
