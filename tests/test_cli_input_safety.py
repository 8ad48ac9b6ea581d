"""Text from the person's files and arguments reaches the terminal escaped, and run folders
whose manifest fields have the wrong type, negative generator seeds and names that are not UTF-8
are refused with one line before anything is created (docs/reliability.md §10)."""

from __future__ import annotations

import json
import logging
import os
import shutil
import sys
from pathlib import Path

import pytest
import yaml

from helpers import SCENARIOS
from resilient_tracking.cli import main
from resilient_tracking.cli.common import ShownFormatter, shown

#: What a terminal acts on instead of showing: a window title, a colour, a right-to-left override.
HOSTILE = "evil\x1b]0;pwned\x07\x1b[31mRED\u202e"
ACTIVE = ("\x1b", "\x07", "\u202e")  # the progress bar itself writes "\\r"


def one_error_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    return lines[0]


def test_shown_escapes_what_a_terminal_would_act_on():
    assert shown("sensing-temp ü → 1") == "sensing-temp ü → 1"
    assert shown(HOSTILE) == "evil\\x1b]0;pwned\\x07\\x1b[31mRED\\u202e"
    assert shown("a\rb\tc") == "a\\rb\tc"
    assert shown(os.fsdecode(b"out\xff\xfe")) == "out\\xff\\xfe"  # bytes that are not UTF-8
    assert shown("two\nlines") == "two\\nlines"
    assert shown("two\nlines", lines=True) == "two\nlines"


def test_log_lines_are_escaped_like_printed_text():
    record = logging.LogRecord("x", logging.WARNING, "", 0, "zone %s", (HOSTILE,), None)
    line = ShownFormatter("%(levelname)s %(message)s").format(record)
    assert line == "WARNING zone evil\\x1b]0;pwned\\x07\\x1b[31mRED\\u202e"


def test_a_scenario_name_with_escape_codes_reaches_the_terminal_escaped(tmp_path, capsys):
    data = yaml.safe_load((SCENARIOS / "sensing-temp.yaml").read_text())
    data["name"] = HOSTILE
    path = tmp_path / f"{HOSTILE}.yaml"
    path.write_text(yaml.safe_dump(data))
    assert main(["validate", str(path)]) == 0
    out = tmp_path / "out"
    assert main(["run", str(path), "--steps", "2", "--no-figures", "--out", str(out)]) == 0
    data["dt"] = "x"
    path.write_text(yaml.safe_dump(data))
    assert main(["validate", str(path)]) == 1
    printed = capsys.readouterr()
    text = printed.out + printed.err
    assert not [c for c in ACTIVE if c in text], text
    assert "evil\\x1b]0;pwned\\x07\\x1b[31mRED\\u202e [failure_aware]" in printed.err  # the bar
    assert "evil\\x1b]0;pwned\\x07\\x1b[31mRED\\u202e.yaml: ok" in printed.out


@pytest.fixture(scope="module")
def run_folder(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("run") / "run"
    assert (
        main(["run", "sensing-temp", "--steps", "3", "--no-figures", "-q", "--out", str(folder)])
        == 0
    )
    return folder


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        ("seed", "x", "seed: expected a non-negative integer, got 'x'"),
        ("seed", 1.5, "seed: expected a non-negative integer, got 1.5"),
        ("seed", True, "seed: expected a non-negative integer, got True"),
        ("seed", -1, "seed: expected a non-negative integer, got -1"),
        ("dt", "0.1", "scenario.dt: expected a positive number of seconds, got '0.1'"),
        ("dt", 0, "scenario.dt: expected a positive number of seconds, got 0"),
        ("dt", [0.1], "scenario.dt: expected a positive number of seconds, got [0.1]"),
    ],
)
def test_animate_names_a_manifest_field_of_the_wrong_type(
    field, value, message, run_folder, tmp_path, capsys
):
    run = tmp_path / "run"
    shutil.copytree(run_folder, run)
    manifest = json.loads((run / "manifest.json").read_text())
    (manifest["scenario"] if field == "dt" else manifest)[field] = value
    (run / "manifest.json").write_text(json.dumps(manifest))
    assert main(["animate", str(run), "--frames", "2", "-q"]) == 1
    err = capsys.readouterr().err
    assert one_error_line(err) == f"error: {run / 'manifest.json'}: {message}"
    assert not (run / "figures").exists()


def test_animate_reports_a_drawing_error_itself_before_writing(
    run_folder, tmp_path, monkeypatch, capsys
):
    """The movie writer hides an error of the first frame behind an IndexError of its own: the
    first frame is drawn before any file is opened."""
    from resilient_tracking.viz import animate

    def broken(*args, **kwargs):
        raise ValueError("cannot draw this run")

    monkeypatch.setattr(animate, "plot_trajectory_map", broken)
    run = tmp_path / "run"
    shutil.copytree(run_folder, run)
    assert main(["animate", str(run), "--frames", "2", "-q"]) == 1
    assert one_error_line(capsys.readouterr().err) == "error: cannot draw this run"
    assert not (run / "figures").exists()


def test_generate_refuses_a_negative_seed_before_creating_anything(tmp_path, capsys):
    out = tmp_path / "generated"
    assert main(["generate", "--seed", "-1", "-n", "2", "--out", str(out), "-q"]) == 1
    assert one_error_line(capsys.readouterr().err) == "error: --seed: must be non-negative"
    assert not out.exists()


NOT_UTF8 = os.fsdecode(b"name\xff\xfe")


@pytest.mark.parametrize(
    "argv",
    [
        ["run", "sensing-temp", "--steps", "2", "--out", "BAD"],
        ["reproduce", "sensing-temp", "--quick", "--out", "BAD"],
        ["compare", "sensing-temp", "--seeds", "1", "--out", "BAD"],
        ["compare", "BAD.yaml", "--seeds", "1", "--out", "OK"],
        ["animate", "BAD"],
    ],
)
def test_a_name_that_is_not_utf8_is_refused_before_any_work(argv, tmp_path, capsys):
    if "BAD.yaml" in argv:
        shutil.copy(SCENARIOS / "sensing-temp.yaml", tmp_path / f"{NOT_UTF8}.yaml")
    before = sorted(os.listdir(tmp_path))
    given = [
        str(tmp_path / a.replace("BAD", NOT_UTF8)) if a in ("BAD", "BAD.yaml", "OK") else a
        for a in argv
    ]
    assert main([*given, "-q"]) == 1
    line = one_error_line(capsys.readouterr().err)
    assert "name\\xff\\xfe" in line and "not UTF-8 text" in line
    assert sorted(os.listdir(tmp_path)) == before


def test_generate_writes_into_a_folder_whose_name_is_not_utf8(tmp_path, capsys):
    out = tmp_path / NOT_UTF8
    assert main(["generate", "-n", "1", "--out", str(out), "-q"]) == 0
    assert (out / "g00.yaml").exists()
    assert "name\\xff\\xfe/g00.yaml" in capsys.readouterr().out


@pytest.mark.parametrize(
    "argv",
    [
        ["run", "sensing-temp", "--steps", "2", "--out", ""],
        ["reproduce", "sensing-temp", "--quick", "--out", ""],
        ["compare", "sensing-temp", "--seeds", "1", "--out", ""],
        ["generate", "-n", "1", "--out", ""],
        ["animate", ""],
        ["animate", "RUN", "--out", ""],
    ],
)
def test_an_empty_name_is_refused_before_any_work(argv, run_folder, tmp_path, capsys, monkeypatch):
    """An empty name (an unset shell variable) would mean the current folder."""
    monkeypatch.chdir(tmp_path)
    argv = [str(run_folder) if a == "RUN" else a for a in argv]
    assert main([*argv, "-q"]) == 1
    assert one_error_line(capsys.readouterr().err).endswith(": empty; give a name")
    assert os.listdir(tmp_path) == []


def test_animate_refuses_a_folder_as_its_output_file(run_folder, tmp_path, capsys):
    assert main(["animate", str(run_folder), "--out", str(tmp_path), "-q"]) == 1
    assert one_error_line(capsys.readouterr().err).endswith("is a folder; give a GIF file name")
    assert os.listdir(tmp_path) == []


@pytest.mark.parametrize("command", ["compare", "reproduce"])
def test_dask_without_the_cluster_extra_is_one_line_naming_it(
    command, tmp_path, capsys, monkeypatch
):
    monkeypatch.setitem(sys.modules, "dask.distributed", None)  # as if not installed
    out = tmp_path / "out"
    argv = [command, "sensing-temp", "--dask", "local", "--out", str(out), "-q"]
    argv += ["--seeds", "1", "--policies", "vanilla"] if command == "compare" else ["--quick"]
    assert main(argv) == 1
    line = one_error_line(capsys.readouterr().err)
    assert line == "error: --dask needs dask.distributed: pip install 'resilient-tracking[cluster]'"
    assert not out.exists()


@pytest.mark.parametrize("seed", [2**63, 10**30, -1])
def test_run_refuses_a_seed_beyond_the_scenario_s_cap(seed, tmp_path, capsys):
    out = tmp_path / "out"
    argv = ["run", "sensing-temp", "--steps", "2", "--seed", str(seed), "--out", str(out)]
    assert main([*argv, "--no-figures", "-q"]) == 1
    line = one_error_line(capsys.readouterr().err)
    assert line.startswith(f"error: --seed: must be between 0 and {2**63 - 1}"), line
    assert not out.exists()


def test_run_accepts_the_largest_seed(tmp_path):
    out = tmp_path / "out"
    argv = ["run", "sensing-temp", "--steps", "2", "--seed", str(2**63 - 1), "--out", str(out)]
    assert main([*argv, "--no-figures", "-q"]) == 0
    assert json.loads((out / "manifest.json").read_text())["seed"] == 2**63 - 1


def test_run_refuses_an_out_that_is_a_link_to_a_run_folder_and_keeps_both(
    run_folder, tmp_path, capsys
):
    target = tmp_path / "target"
    shutil.copytree(run_folder, target)
    before = sorted(p.name for p in target.iterdir())
    link = tmp_path / "link"
    link.symlink_to(target, target_is_directory=True)
    argv = ["run", "sensing-temp", "--steps", "2", "--no-figures", "-q", "--out", str(link)]
    for extra in ([], ["--overwrite"]):
        assert main([*argv, *extra]) == 1
        line = one_error_line(capsys.readouterr().err)
        assert f"error: --out: {link}: is a symbolic link" in line, line
        assert link.is_symlink() and link.resolve() == target.resolve()
        assert sorted(p.name for p in target.iterdir()) == before
