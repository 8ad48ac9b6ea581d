"""Hostile scenario files (docs/reliability.md): property tests over malformed and hostile input.

Each property takes a shipped scenario, breaks it in a generated way (wrong types and shapes,
NaN/inf, bad variances, bad covariances, empty or huge teams, unknown keys, zones on robots,
targets outside the workspace…) or generates a whole file that is not a scenario, and checks:

* ``parse_scenario``/``load_scenario`` either accept it or raise :class:`ScenarioError` whose
  every problem starts with a field path; never any other exception;
* ``rtrack validate`` exits 0 with "ok" or 1 with ``error:`` naming the field;
* ``rtrack run`` exits 0 with a complete run folder, or non-zero with no run folder at all.

The number of examples is the hypothesis profile's: ``ci`` (default) or ``thorough``
(``HYPOTHESIS_PROFILE=thorough``), see docs/reliability.md.
"""

from __future__ import annotations

import copy
import json
import math
import re
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest
import yaml
from hypothesis import HealthCheck, assume, currently_in_test_context, event, given, settings
from hypothesis import strategies as st

from helpers import SCENARIOS
from resilient_tracking.cli import main
from resilient_tracking.scenario import (
    MAX_ROBOTS,
    MAX_ROBOTS_X_TARGETS,
    MotionSpec,
    Scenario,
    ScenarioError,
    load_scenario,
    parse_scenario,
)
from resilient_tracking.sim.episode import NonFiniteError, run_episode
from resilient_tracking.world.target_motion import TargetMotion

BASES = ("sensing-temp", "combined-temp", "comm-perm")
TOP_LEVEL = set(Scenario.model_fields) | {"<root>", "<yaml>", "<file>"}
#: "field.path: message" — the path is dotted keys and list indices.
PROBLEM = re.compile(r"^(?P<path>[\w<>]+(?:\.[\w<>]+)*): \S")


def base(name: str) -> dict[str, Any]:
    return yaml.safe_load((SCENARIOS / f"{name}.yaml").read_text())


BASE_DATA = {name: base(name) for name in BASES}


def paths(node: Any, prefix: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    """Every key path in a parsed YAML document (mappings and lists), leaves and inner nodes."""
    out = [prefix] if prefix else []
    if isinstance(node, dict):
        for k, v in node.items():
            out += paths(v, (*prefix, k))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            out += paths(v, (*prefix, i))
    return out


def numeric_leaves(node: Any) -> list[tuple[Any, ...]]:
    """Paths of leaves holding a number (not a bool)."""
    return [
        p
        for p in paths(node)
        if isinstance(get(node, p), int | float) and not isinstance(get(node, p), bool)
    ]


def get(node: Any, path: tuple[Any, ...]) -> Any:
    for part in path:
        node = node[part]
    return node


def put(node: Any, path: tuple[Any, ...], value: Any) -> None:
    get(node, path[:-1])[path[-1]] = value


def dotted(path: tuple[Any, ...]) -> str:
    return ".".join(str(p) for p in path)


# ---------------------------------------------------------------------------- strategies

NUMBERS = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(min_value=-(10**30), max_value=10**30),
    st.sampled_from([0, -1, 0.0, -0.0, 1e-320, 1e300, -1e300, 2**63, -(2**63)]),
)
HOSTILE = st.one_of(
    NUMBERS,
    st.sampled_from(
        [None, True, False, "yes", "no", "0.1", "nan", "", "sensing", [], {}, [1], [1, 2, 3]]
    ),
    st.sampled_from([[[1, 2], [3]], [[1, 2], [2, 1]], [[0, 0], [0, 0]], {"x": 1}, [None, None]]),
    st.text(max_size=20),
    st.lists(NUMBERS, max_size=4),
    st.lists(st.lists(NUMBERS, max_size=3), max_size=3),
)


@st.composite
def replaced_value(draw: st.DrawFn) -> tuple[dict[str, Any], tuple[Any, ...]]:
    """A shipped scenario with one node (leaf or subtree) replaced by a hostile value."""
    data = copy.deepcopy(BASE_DATA[draw(st.sampled_from(BASES))])
    path = draw(st.sampled_from(paths(data)))
    put(data, path, draw(HOSTILE))
    return data, path


@st.composite
def structural_break(draw: st.DrawFn) -> dict[str, Any]:
    """A shipped scenario with a key removed, an unknown key added, or an adversarial layout."""
    data = copy.deepcopy(BASE_DATA[draw(st.sampled_from(BASES))])
    kind = draw(
        st.sampled_from(
            [
                "delete",
                "unknown_key",
                "empty_team",
                "huge_team",
                "zone_on_robot",
                "target_outside",
                "bad_sigma",
                "tiny_workspace",
            ]
        )
    )
    if kind == "delete":
        path = draw(st.sampled_from([p for p in paths(data) if isinstance(p[-1], str)]))
        del get(data, path[:-1])[path[-1]]
    elif kind == "unknown_key":
        mappings = [p for p in paths(data) if isinstance(get(data, p), dict)]
        where = get(data, draw(st.sampled_from(mappings))) if mappings else data
        where[draw(st.text(min_size=1, max_size=12))] = draw(HOSTILE)
    elif kind == "empty_team":
        data[draw(st.sampled_from(["robots", "targets", "zones"]))] = []
    elif kind == "huge_team":
        key = draw(st.sampled_from(["robots", "targets", "zones"]))
        count = draw(st.sampled_from([MAX_ROBOTS + 1, MAX_ROBOTS_X_TARGETS + 1, 10**5]))
        data[key] = [copy.deepcopy(data[key][0]) for _ in range(1)] * count if data[key] else []
    elif kind == "zone_on_robot":
        if data.get("zones"):
            zone = data["zones"][0]
            robot = draw(st.integers(0, len(data["robots"]) - 1))
            zone["mu"] = list(data["robots"][robot]["start"])
            s = draw(st.sampled_from([1e-12, 1e-6, 0.01, 1.0, 100.0]))
            zone["sigma"] = [[s, 0.0], [0.0, s]]
    elif kind == "target_outside":
        ws = data["workspace"]
        data["targets"][0]["start"] = [ws["xmax"] + draw(st.floats(0.001, 1e6)), 0.0]
    elif kind == "bad_sigma":
        if data.get("zones"):
            a, b, c, d = (draw(st.floats(-10, 10)) for _ in range(4))
            data["zones"][0]["sigma"] = [[a, b], [c, d]]
    elif kind == "tiny_workspace":
        x = draw(st.floats(-10, 10))
        data["workspace"] = {"xmin": x, "xmax": x, "ymin": -1.0, "ymax": 1.0}
    return data


DOCUMENTS = st.one_of(
    st.text(max_size=200),
    st.sampled_from(
        [
            "",
            "   \n",
            "- 1\n- 2\n",
            "42",
            "just a string",
            "null",
            "[",
            "{robots: [",
            "robots: {start: [0, 0]}\n\ttargets: 1",
            "a: &a [*a]",
            "key: value\nkey: other\n",
            "!!python/object/apply:os.system ['echo hacked']",
            "\x00\x01\x02",
            "[" * 1500 + "]" * 1500,
            "a: &a [1, 2]\nb: &b [*a, *a, *a, *a]\nrobots: [*b, *b, *b, *b, *b, *b, *b, *b]\n",
        ]
    ),
    st.recursive(
        st.none() | st.booleans() | NUMBERS | st.text(max_size=10),
        lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner),
        max_leaves=20,
    ).map(lambda doc: yaml.safe_dump(doc)),
)


# ---------------------------------------------------------------------------- checks


def check_parse(data: Any) -> Scenario | ScenarioError:
    """Parse; the only allowed failure is a ScenarioError whose problems all name a field."""
    try:
        return parse_scenario(data, "<hostile>")
    except ScenarioError as err:
        assert err.problems
        for problem in err.problems:
            match = PROBLEM.match(problem)
            assert match, f"problem does not start with a field path: {problem!r}"
            assert match["path"].split(".")[0] in TOP_LEVEL, problem
        return err


def check_cli(text: str | bytes, valid: bool | None = None) -> None:
    """``rtrack validate`` and ``rtrack run`` on a file with this content."""
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "hostile.yaml"
        if isinstance(text, bytes):
            path.write_bytes(text)
        else:
            path.write_text(text, encoding="utf-8")
        out = Path(tmp) / "run"
        code, _, err = run_cli(["validate", str(path)])
        assert code in (0, 1)
        assert "Traceback" not in err
        if currently_in_test_context():
            event("valid file" if code == 0 else "invalid file")
        if code == 1:
            assert re.search(r"error: .*\n\s+- [\w<>]+(\.[\w<>]+)*: ", err), err
        if valid is not None:
            assert (code == 0) == valid
        code_run, _, err_run = run_cli(
            ["run", str(path), "--out", str(out), "--steps", "2", "--no-figures", "-q"]
        )
        assert "Traceback" not in err_run
        if code == 1:
            assert code_run == 1 and "error:" in err_run
            assert not out.exists()
        else:
            assert code_run == 0, err_run  # a valid file must run
            assert (out / "manifest.json").exists() and (out / "team.parquet").exists()
        leftovers = [p.name for p in Path(tmp).iterdir() if p.name not in ("hostile.yaml", "run")]
        assert leftovers == []  # no staging folder left behind


_CAPTURE: pytest.CaptureFixture[str] | None = None


def run_cli(argv: list[str]) -> tuple[int, str, str]:
    assert _CAPTURE is not None
    _CAPTURE.readouterr()
    code = main(argv)
    out, err = _CAPTURE.readouterr()
    return code, out, err


@pytest.fixture(autouse=True)
def _capture(capsys: pytest.CaptureFixture[str]):
    global _CAPTURE
    _CAPTURE = capsys
    yield
    _CAPTURE = None


# ---------------------------------------------------------------------------- properties


@pytest.mark.slow
@settings(suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(replaced_value())
def test_any_replaced_node_is_accepted_or_named(case):
    data, path = case
    outcome = check_parse(data)
    event("accepted" if isinstance(outcome, Scenario) else "refused")
    if isinstance(outcome, ScenarioError):
        named = {PROBLEM.match(p)["path"] for p in outcome.problems}  # type: ignore[index]
        target = dotted(path)
        # the replaced node, something inside it, or (for cross-field rules) its section
        assert any(
            n == target
            or n.startswith(target + ".")
            or target.startswith(n + ".")
            or n.split(".")[0] == target.split(".")[0]
            or n.split(".")[0] in ("robots", "targets", "workspace", "steps")
            for n in named
        ), (target, outcome.problems)


@settings(suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    st.sampled_from(BASES).flatmap(
        lambda name: st.tuples(st.just(name), st.sampled_from(numeric_leaves(BASE_DATA[name])))
    ),
    st.sampled_from(
        [True, False, "0.1", "yes", None, math.nan, math.inf, -math.inf, [1.0], {"v": 1.0}]
    ),
)
def test_a_non_number_in_a_number_field_is_named_exactly(case, value):
    name, path = case
    data = copy.deepcopy(BASE_DATA[name])
    put(data, path, value)
    outcome = check_parse(data)
    assert isinstance(outcome, ScenarioError), (dotted(path), value)
    named = [PROBLEM.match(p)["path"] for p in outcome.problems]  # type: ignore[index]
    assert dotted(path) in named, (dotted(path), outcome.problems)


@pytest.mark.slow
@settings(suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(structural_break())
def test_structural_breaks_are_accepted_or_named(data):
    outcome = check_parse(data)
    event("accepted" if isinstance(outcome, Scenario) else "refused")


@pytest.mark.slow
@settings(suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(DOCUMENTS)
def test_any_document_is_accepted_or_named(text):
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "doc.yaml"
        path.write_text(text, encoding="utf-8", errors="surrogatepass")
        try:
            load_scenario(path)
        except ScenarioError as err:
            assert all(PROBLEM.match(p) for p in err.problems), err.problems


@pytest.mark.slow
@settings(
    suppress_health_check=[HealthCheck.function_scoped_fixture],
    max_examples=max(10, settings().max_examples // 3),
)
@given(
    st.one_of(
        replaced_value().map(lambda case: yaml.safe_dump(case[0])),
        structural_break().map(yaml.safe_dump),
        DOCUMENTS,
    )
)
def test_cli_validate_and_run_never_crash_and_never_leave_a_partial_folder(text):
    check_cli(text)


EXTREMES = st.sampled_from(
    [0, 1e-9, 1e-6, 1e-3, 0.5, 1, 10, 1e3, 1e5, 1e6, -1e-6, -1, -1e3, -1e6, 1e9, 1e12]
)


@st.composite
def extreme_but_valid(draw: st.DrawFn) -> dict[str, Any]:
    """A shipped scenario with one to three numbers pushed to extremes, or a zone put on top
    of a robot; only inputs the validator accepts (the rest is the other properties' job)."""
    data = copy.deepcopy(BASE_DATA[draw(st.sampled_from(BASES))])
    data["steps"] = 4
    if draw(st.booleans()) and data.get("zones"):
        robot = draw(st.integers(0, len(data["robots"]) - 1))
        zone = data["zones"][draw(st.integers(0, len(data["zones"]) - 1))]
        zone["mu"] = list(data["robots"][robot]["start"])
        s = draw(st.sampled_from([1e-9, 1e-4, 0.01, 1.0, 1e4]))
        zone["sigma"] = [[s, 0.0], [0.0, s]]
    leaves = [p for p in numeric_leaves(data) if p != ("steps",)]
    for path in draw(st.lists(st.sampled_from(leaves), min_size=1, max_size=3, unique=True)):
        put(data, path, draw(EXTREMES))
    try:
        parse_scenario(data)
    except ScenarioError:
        assume(False)
    return data


@pytest.mark.slow
@settings(
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.filter_too_much],
    max_examples=max(10, settings().max_examples // 2),
)
@given(extreme_but_valid())
@pytest.mark.filterwarnings("error::RuntimeWarning")  # an overflow is a numerical bug here
def test_extreme_but_valid_scenarios_run_without_nan(data):
    """Whatever the validator accepts runs, and every number in every table is finite."""
    result = run_episode(parse_scenario(data))
    for name, table in result.tables.items():
        numbers = table.select_dtypes("number").to_numpy(dtype=float)
        assert np.all(np.isfinite(numbers)), (name, table[~np.isfinite(numbers).all(axis=1)])


@pytest.mark.slow
@settings(
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.filter_too_much],
    max_examples=max(5, settings().max_examples // 6),
)
@given(extreme_but_valid().map(yaml.safe_dump))
def test_cli_runs_extreme_but_valid_files(text):
    check_cli(text, valid=True)


# ---------------------------------------------------------------------------- fixed cases


@pytest.mark.slow
@pytest.mark.parametrize(
    ("text", "field"),
    [
        ("", "<root>: must be a mapping"),
        ("- 1\n- 2\n", "<root>: must be a mapping"),
        ("{robots: [", "<yaml>: not valid YAML"),
        ("[" * 1500 + "]" * 1500, "<yaml>"),
        (b"\xff\xfe\x00robots", "<file>: not UTF-8"),
    ],
)
def test_whole_file_problems_are_named(text, field):
    check_cli(text, valid=False)
    assert field in run_cli_on(text)


def run_cli_on(text: str | bytes) -> str:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "x.yaml"
        path.write_bytes(text if isinstance(text, bytes) else text.encode())
        code, _, err = run_cli(["validate", str(path)])
        assert code == 1
        return err


def test_a_missing_file_is_named_and_run_writes_nothing(tmp_path):
    missing = tmp_path / "nope.yaml"
    code, _, err = run_cli(["validate", str(missing)])
    assert code == 1 and "<file>: cannot read" in err and "nope.yaml" in err
    code, _, err = run_cli(["run", str(missing), "--out", str(tmp_path / "out")])
    assert code == 1 and not (tmp_path / "out").exists()


@pytest.mark.parametrize(
    ("path", "value"),
    [
        (("dt",), True),
        (("dt",), "0.1"),
        (("robots", 0, "u_max"), "yes"),
        (("targets", 0, "motion", "speed"), "0.18"),
        (("zones", 0, "sigma", 0, 0), False),
        (("seed",), 1.5),
        (("steps",), "300"),
        (("policy", "failure_aware", "cooldown_steps"), True),
    ],
)
def test_numbers_are_strict(path, value):
    data = copy.deepcopy(BASE_DATA["combined-temp"])
    data["policy"] = {"failure_aware": {"cooldown_steps": 10}}
    put(data, path, value)
    with pytest.raises(ScenarioError) as err:
        parse_scenario(data)
    assert any(p.startswith(dotted(path) + ":") for p in err.value.problems), err.value.problems


def test_a_bool_field_is_strict():
    data = copy.deepcopy(BASE_DATA["combined-temp"])
    data["targets"][0]["motion"]["loop"] = "yes"
    with pytest.raises(ScenarioError, match=r"targets\.0\.motion\.loop: "):
        parse_scenario(data)


@pytest.mark.parametrize(
    ("key", "count", "message"),
    [
        ("robots", 65, "robots: List should have at most 64 items"),
        ("targets", 10**5, "targets: List should have at most 64 items"),
        ("zones", 33, "zones: List should have at most 32 items"),
    ],
)
def test_huge_counts_are_refused_with_the_bound(key, count, message):
    data = copy.deepcopy(BASE_DATA["combined-temp"])
    data[key] = [data[key][0]] * count
    with pytest.raises(ScenarioError) as err:
        parse_scenario(data)
    assert any(p.startswith(message) for p in err.value.problems), err.value.problems


def test_many_robots_times_many_targets_is_refused():
    data = copy.deepcopy(BASE_DATA["combined-temp"])
    data["robots"] = [data["robots"][0]] * 64
    data["targets"] = [data["targets"][0]] * 40
    with pytest.raises(ScenarioError, match=r"robots: 64 robots × 40 targets exceeds"):
        parse_scenario(data)


def test_too_many_recorded_rows_is_refused():
    data = copy.deepcopy(BASE_DATA["combined-temp"])
    data["robots"] = [data["robots"][0]] * 60
    data["steps"] = 100_000
    with pytest.raises(ScenarioError, match=r"steps: 100000 steps × 63 robots and targets"):
        parse_scenario(data)


def test_run_steps_override_beyond_the_bound_is_an_error(tmp_path):
    out = tmp_path / "out"
    code, _, err = run_cli(
        ["run", str(SCENARIOS / "sensing-temp.yaml"), "--steps", "10000000", "--out", str(out)]
    )
    assert code == 1 and "steps" in err and "Traceback" not in err
    assert not out.exists()


def test_run_refuses_to_overwrite_a_folder_that_is_not_a_run(tmp_path):
    out = tmp_path / "precious"
    out.mkdir()
    (out / "thesis.tex").write_text("do not delete")
    code, _, err = run_cli(["run", str(SCENARIOS / "sensing-temp.yaml"), "--out", str(out)])
    assert code == 1 and "not a run folder" in err
    assert (out / "thesis.tex").read_text() == "do not delete"


def test_a_failing_run_writes_no_folder(tmp_path, monkeypatch):
    import resilient_tracking.sim.episode as episode

    def broken(*args, **kwargs):
        raise FloatingPointError("simulated failure in the episode")

    monkeypatch.setattr(episode, "run_episode", broken)
    out = tmp_path / "out"
    code, _, err = run_cli(["run", str(SCENARIOS / "sensing-temp.yaml"), "--out", str(out), "-q"])
    assert code == 2 and "simulated failure" in err and "Traceback" not in err
    assert not out.exists() and list(tmp_path.iterdir()) == []


def test_failing_figures_leave_no_partial_folder(tmp_path, monkeypatch):
    import resilient_tracking.viz as viz

    def broken(folder):
        (Path(folder) / "figures").mkdir()
        raise RuntimeError("simulated plotting failure")

    monkeypatch.setattr(viz, "make_run_figures", broken)
    out = tmp_path / "out"
    argv = ["run", str(SCENARIOS / "sensing-temp.yaml"), "--out", str(out), "--steps", "3", "-q"]
    code, _, err = run_cli(argv)
    assert code == 2 and "simulated plotting failure" in err
    assert list(tmp_path.iterdir()) == []


def test_rerun_replaces_a_run_folder_whole(tmp_path):
    out = tmp_path / "out"
    argv = ["run", str(SCENARIOS / "sensing-temp.yaml"), "--out", str(out), "--no-figures", "-q"]
    assert run_cli([*argv, "--steps", "3"])[0] == 0
    (out / "figures").mkdir()
    (out / "figures" / "trajectories.png").write_bytes(b"ours, from a run with figures")
    manifest = json.loads((out / "manifest.json").read_text())
    manifest["files"]["figures/trajectories.png"] = "0" * 64
    (out / "manifest.json").write_text(json.dumps(manifest))
    assert run_cli([*argv, "--steps", "4"])[0] == 0
    assert not (out / "figures").exists()  # ours: replaced with the folder
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_rerun_never_deletes_what_the_user_added(tmp_path):
    out = tmp_path / "out"
    argv = ["run", str(SCENARIOS / "sensing-temp.yaml"), "--out", str(out), "--no-figures", "-q"]
    assert run_cli([*argv, "--steps", "3"])[0] == 0
    (out / "notes.txt").write_text("mine")
    (out / "mywork").mkdir()
    (out / "mywork" / "a.csv").write_text("1,2")
    code, _, err = run_cli([*argv, "--steps", "4"])
    assert code == 1 and "notes.txt" in err and "mywork/" in err and "--overwrite" in err
    assert len(pd.read_parquet(out / "team.parquet")) == 3
    assert run_cli([*argv, "--steps", "4", "--overwrite"])[0] == 0
    assert len(pd.read_parquet(out / "team.parquet")) == 4
    assert (out / "notes.txt").read_text() == "mine"
    assert (out / "mywork" / "a.csv").read_text() == "1,2"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_shipped_scenarios_still_validate():
    for path in sorted(SCENARIOS.glob("*.yaml")):
        assert isinstance(load_scenario(path), Scenario)


# ---------------------------------------------------------------------------- non-finite numbers


class RunawaySpec(MotionSpec):
    """A plug-in motion whose position becomes NaN at its third step."""

    type: str


class RunawayMotion(TargetMotion):
    Spec = RunawaySpec
    steps = 0

    def step(self, dt: float, rng: np.random.Generator) -> None:
        self.steps += 1
        if self.steps == 3:
            self.position = self.position * np.nan


def _runaway() -> dict[str, Any]:
    data = copy.deepcopy(BASE_DATA["sensing-temp"])
    data["steps"] = 6
    data["targets"][1]["motion"] = {"type": f"{__name__}:RunawayMotion"}
    return data


def test_a_run_meeting_a_number_that_is_not_finite_stops_naming_it_and_the_step():
    with pytest.raises(NonFiniteError, match=r"^step 3: a target's true state is not finite$"):
        run_episode(parse_scenario(_runaway()))


def test_rtrack_run_meeting_a_number_that_is_not_finite_stores_nothing(tmp_path):
    path = tmp_path / "runaway.yaml"
    path.write_text(yaml.safe_dump(_runaway()))
    out = tmp_path / "out"
    code, _, err = run_cli(["run", str(path), "--out", str(out), "--no-figures", "-q"])
    assert code == 2 and "Traceback" not in err
    assert "NonFiniteError: step 3: a target's true state is not finite" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["runaway.yaml"]
