"""Every command-line option is checked before work starts, and file errors name the file
(docs/reliability.md §10)."""

from __future__ import annotations

import pytest

from resilient_tracking.cli import main


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["animate", "RUN", "--fps", "0"], "--fps: must be between 1 and 120 (got 0)"),
        (["animate", "RUN", "--frames", "0"], "--frames: must be between 2 and 2000 (got 0)"),
        (["animate", "RUN", "--frames", "-3"], "--frames: must be between 2 and 2000 (got -3)"),
        (["reproduce", "--seeds", "0"], "--seeds: must be between 1 and 1000"),
        (["reproduce", "--seeds", "100000000"], "--seeds: must be between 1 and 1000"),
        (["reproduce", "--jobs", "100000"], "--jobs: must be between 1 and"),
        (["compare", "sensing-temp", "--jobs", "0"], "--jobs: must be between 1 and"),
        (["compare", "sensing-temp", "--seeds", "5000"], "--seeds: must be between 1 and 1000"),
    ],
)
def test_out_of_range_options_are_refused_by_name(argv, message, capsys, tmp_path):
    argv = [str(tmp_path) if a == "RUN" else a for a in argv]
    assert main([*argv, "--out", str(tmp_path / "out")]) == 1
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("command", ["reproduce", "compare"])
def test_an_output_path_that_is_a_file_is_refused(command, tmp_path, capsys):
    target = tmp_path / "file"
    target.write_text("mine")
    argv = [command, "sensing-temp", "--out", str(target)]
    assert main(argv if command == "compare" else [*argv, "--quick"]) == 1
    assert f"--out: {target} exists and is not a folder" in capsys.readouterr().err
    assert target.read_text() == "mine"


def test_animate_names_a_broken_manifest(tmp_path, capsys):
    run = tmp_path / "run"
    run.mkdir()
    (run / "manifest.json").write_text('{"seed": 4\x01}')
    assert main(["animate", str(run), "-q"]) == 1
    assert f"error: {run / 'manifest.json'}: not valid JSON" in capsys.readouterr().err


def test_animate_on_a_missing_run_folder_prints_its_error_and_no_progress_bar(tmp_path, capsys):
    missing = tmp_path / "no-such-run"
    assert main(["animate", str(missing)]) == 1
    err = capsys.readouterr().err
    assert err.strip() == f"error: run folder {missing} does not exist"
