"""Bounded YAML input (docs/reliability.md §7): size, aliases, duplicate keys, YAML 1.2 floats."""

from __future__ import annotations

import resource
import time
from pathlib import Path

import pytest

from resilient_tracking import builtin_scenarios
from resilient_tracking.scenario import ScenarioError, load_scenario
from resilient_tracking.yaml_io import (
    MAX_ALIAS_NODES,
    MAX_FILE_BYTES,
    YamlInputError,
    parse_yaml,
)

SHIPPED = builtin_scenarios.path("sensing-temp").read_text()


def alias_bomb(levels: int = 9, width: int = 9) -> str:
    lines = ["a0: &a0 [" + ", ".join(["x"] * width) + "]"]
    for i in range(1, levels + 1):
        lines.append(f"a{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * width) + "]")
    return "\n".join(lines) + "\n"


def problems_of(tmp_path: Path, text: str) -> list[str]:
    path = tmp_path / "s.yaml"
    path.write_text(text)
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    assert info.value.source == str(path)
    return info.value.problems


def test_an_alias_bomb_is_refused_quickly_and_the_message_is_short(tmp_path):
    start = time.process_time()
    problems = problems_of(tmp_path, alias_bomb())
    assert time.process_time() - start < 5
    assert problems[0].startswith("<yaml>: aliases expand the document")
    assert len(problems[0]) < 300


def test_a_few_aliases_are_fine():
    text = "a: &p [1.0, 2.0]\nb: *p\nc: [*p, *p]\n"
    assert parse_yaml(text) == {"a": [1.0, 2.0], "b": [1.0, 2.0], "c": [[1.0, 2.0]] * 2}


def test_aliases_just_within_the_budget_are_fine_and_just_beyond_are_refused():
    def doc(count: int) -> str:
        return "a: &p [1]\nb: [" + ", ".join(["*p"] * count) + "]\n"

    assert len(parse_yaml(doc(MAX_ALIAS_NODES // 2))["b"]) == MAX_ALIAS_NODES // 2
    with pytest.raises(YamlInputError, match="aliases expand"):
        parse_yaml(doc(MAX_ALIAS_NODES // 2 + 1))


def test_a_self_referring_alias_is_refused():
    with pytest.raises(YamlInputError, match="contains it"):
        parse_yaml("a: &a [*a]\n")


def test_a_file_over_the_size_limit_is_refused_before_parsing(tmp_path):
    path = tmp_path / "big.yaml"
    with path.open("w") as handle:
        handle.write("robots:\n")
        handle.write("  - {start: [0.0, 0.0]}\n" * (MAX_FILE_BYTES // 20))
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    assert info.value.problems == [
        f"<file>: larger than {MAX_FILE_BYTES} bytes, the limit for a scenario file"
    ]
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before < 50_000  # kB


def test_duplicate_keys_name_both_lines(tmp_path):
    problems = problems_of(tmp_path, SHIPPED + "steps: 7\n")
    first = 1 + SHIPPED.splitlines().index("steps: 300")
    last = 1 + len(SHIPPED.splitlines())
    assert problems == [
        f"<yaml>: duplicate key 'steps' at line {last} (first given at line {first}); "
        "give each key once"
    ]


def test_duplicate_keys_in_a_nested_mapping_are_refused():
    with pytest.raises(YamlInputError, match="duplicate key 'x'"):
        parse_yaml("a:\n  x: 1\n  y: 2\n  x: 3\n")


def test_merge_keys_may_be_overridden():
    assert parse_yaml("base: &b {x: 1, y: 2}\nc:\n  <<: *b\n  x: 3\n")["c"] == {"x": 3, "y": 2}


@pytest.mark.parametrize(
    ("text", "value"),
    [
        ("1.0e12", 1.0e12),
        ("1e12", 1e12),
        ("-2.5E-3", -2.5e-3),
        ("1.0e+12", 1.0e12),
        ("0.5", 0.5),
        (".5", 0.5),
        ("3", 3),
        ("-7", -7),
        (".inf", float("inf")),
    ],
)
def test_numbers_are_read_as_yaml_1_2_writes_them(text, value):
    read = parse_yaml(f"v: {text}\n")["v"]
    assert read == value and type(read) is type(value)


@pytest.mark.parametrize("text", ["1.0e", "e12", "1.0.0", "0x1p3", "abc"])
def test_non_numbers_stay_text(text):
    assert parse_yaml(f"v: {text}\n")["v"] == text


def test_a_sigma_written_with_1_0e12_is_a_number(tmp_path):
    text = SHIPPED.replace("[[0.3, 0.0], [0.0, 0.3]]", "[[1.0e12, 0], [0, 1.0e12]]")
    assert text != SHIPPED
    path = tmp_path / "s.yaml"
    path.write_text(text)
    assert load_scenario(path).zones[0].sigma == ((1e12, 0.0), (0.0, 1e12))


def test_a_tiny_sigma_is_refused_with_the_reason(tmp_path):
    text = SHIPPED.replace("[[0.3, 0.0], [0.0, 0.3]]", "[[1e-300, 0], [0, 1e-300]]")
    problems = problems_of(tmp_path, text)
    assert problems[0].startswith("zones.0.sigma: is too small")


@pytest.mark.slow
def test_a_large_invalid_value_is_rendered_briefly(tmp_path):
    rows = ", ".join(["[0.0, 0.0]"] * 5000)
    problems = problems_of(tmp_path, SHIPPED.replace("name: sensing-temp", f"name: [{rows}]"))
    assert any(p.startswith("name:") for p in problems)
    assert max(len(p) for p in problems) < 300
