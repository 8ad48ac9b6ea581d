"""``rtrack reproduce`` and ``rtrack compare`` never replace a file rtrack did not write in their
``--out`` folder (docs/reliability.md §8): they refuse before running anything, and replace
their own report files on a rerun."""

from __future__ import annotations

import json

import pytest

from resilient_tracking.cli import main
from resilient_tracking.experiments import report_files
from resilient_tracking.experiments.report_files import RECORD, ReportFiles

COMPARE = ["compare", "sensing-temp", "--policies", "vanilla", "--seeds", "1"]
COMPARE += ["--set", "steps=5", "--jobs", "1", "-q"]


def refused(capsys, code: int, path) -> None:
    err = capsys.readouterr().err
    assert code == 1
    assert err.count("\n") == 1 and str(path) in err and "not written by rtrack" in err, err


@pytest.mark.parametrize("name", ["report.md", "summary.csv", "runs.csv"])
def test_compare_refuses_a_users_file_before_running(tmp_path, capsys, name):
    mine = tmp_path / name
    mine.write_text("my own notes\n")
    refused(capsys, main([*COMPARE, "--out", str(tmp_path)]), mine)
    assert mine.read_text() == "my own notes\n"
    assert not (tmp_path / "runs").exists()  # nothing ran


@pytest.mark.parametrize("name", ["report.md", "sensing-temp/summary.csv"])
def test_reproduce_refuses_a_users_file_before_running(tmp_path, capsys, name):
    mine = tmp_path / name
    mine.parent.mkdir(parents=True, exist_ok=True)
    mine.write_text("my own notes\n")
    code = main(["reproduce", "sensing-temp", "--seeds", "1", "--out", str(tmp_path), "-q"])
    refused(capsys, code, mine)
    assert mine.read_text() == "my own notes\n"
    assert not (tmp_path / "runs").exists()


def test_compare_replaces_its_own_report_but_not_one_changed_since(tmp_path, capsys):
    argv = [*COMPARE, "--out", str(tmp_path)]
    assert main(argv) == 0
    report = tmp_path / "report.md"
    first = report.read_text()
    assert main(argv) == 0  # a rerun replaces what rtrack wrote
    assert "0 run(s) done, 1 already stored" in capsys.readouterr().out
    assert report.read_text() == first
    report.write_text(first + "\nmy conclusions\n")
    refused(capsys, main(argv), report)
    assert report.read_text().endswith("my conclusions\n")
    report.unlink()
    figure = tmp_path / "sensing-temp" / "figures" / "bands.png"
    assert figure.exists()
    assert main(argv) == 0  # its own figures are replaced too


def test_a_users_file_in_a_figures_folder_is_refused(tmp_path, capsys):
    mine = tmp_path / "sensing-temp" / "figures" / "bands.png"
    mine.parent.mkdir(parents=True)
    mine.write_bytes(b"my plot")
    refused(capsys, main([*COMPARE, "--out", str(tmp_path)]), mine)
    assert mine.read_bytes() == b"my plot"


WANTED = ReportFiles(("report.md", "x/summary.csv"), ("x/figures",))


def test_files_being_written_when_interrupted_are_rtracks(tmp_path):
    report_files.claim(tmp_path, WANTED)
    (tmp_path / "report.md").write_text("half a report")
    (tmp_path / "x" / "figures").mkdir(parents=True)
    (tmp_path / "x" / "figures" / "a.png").write_bytes(b"png")
    assert report_files.not_ours(tmp_path, WANTED) == []
    report_files.seal(tmp_path, WANTED)
    record = json.loads((tmp_path / RECORD).read_text())
    assert record["files"]["report.md"] and "x/summary.csv" not in record["files"]
    (tmp_path / "x" / "summary.csv").write_text("mine")  # not written by rtrack
    assert report_files.not_ours(tmp_path, WANTED) == [tmp_path / "x" / "summary.csv"]


def test_a_folder_of_an_older_version_is_recognised_by_its_report(tmp_path):
    (tmp_path / "report.md").write_text("# Reproduction report\n\nProduced by ...\n")
    (tmp_path / "x").mkdir()
    (tmp_path / "x" / "summary.csv").write_text("variant,seed\n")
    assert report_files.not_ours(tmp_path, WANTED) == []
    (tmp_path / "report.md").write_text("# My report\n")
    assert report_files.not_ours(tmp_path, WANTED) == [
        tmp_path / "report.md",
        tmp_path / "x" / "summary.csv",
    ]
