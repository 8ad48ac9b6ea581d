"""The rtrack command: validate reports fields, run refuses bad files and writes a run folder."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys

import pandas as pd
import pytest
import yaml

from helpers import SCENARIOS
from resilient_tracking.cli import main


def bad_copy(tmp_path, mutate):
    data = yaml.safe_load((SCENARIOS / "sensing-temp.yaml").read_text())
    mutate(data)
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def test_validate_accepts_every_shipped_scenario(capsys):
    paths = sorted(str(p) for p in SCENARIOS.glob("*.yaml"))
    # the paper's six, three benchmarks, the soak, the 40-robot swarm, bearing-only, two evasive,
    # two lure and two degrade ones, comm-spread, two with a moving zone, one with a zone of
    # two kinds and one with randomly moving (ncv) targets
    assert len(paths) == 23
    assert main(["validate", *paths]) == 0
    assert capsys.readouterr().out.count(": ok") == len(paths)


def test_validate_names_a_sigma_that_is_not_positive_definite(tmp_path, capsys):
    path = bad_copy(tmp_path, lambda d: d["zones"][0].update(sigma=[[1.0, 2.0], [2.0, 1.0]]))
    assert main(["validate", str(path)]) == 1
    err = capsys.readouterr().err
    assert "zones.0.sigma: must be positive definite" in err
    assert "[[1.0, 2.0], [2.0, 1.0]]" in err


def test_validate_reports_every_problem(tmp_path, capsys):
    def mutate(d):
        d["dt"] = -0.1
        d["robots"][1]["start"] = [10.0, 0.0]
        d["zones"][0]["kind"] = "radiation"

    assert main(["validate", str(bad_copy(tmp_path, mutate))]) == 1
    err = capsys.readouterr().err
    assert "dt:" in err and "zones.0" in err
    # the robot outside the workspace is a cross-field problem found once types are right
    fixed = bad_copy(tmp_path, lambda d: d["robots"][1].update(start=[10.0, 0.0]))
    assert main(["validate", str(fixed)]) == 1
    assert "robots.1.start: outside the workspace" in capsys.readouterr().err


def test_run_refuses_a_bad_file_and_writes_nothing(tmp_path, capsys):
    path = bad_copy(tmp_path, lambda d: d.update(dt=0))
    out = tmp_path / "out"
    assert main(["run", str(path), "--out", str(out), "-q"]) == 1
    assert "dt:" in capsys.readouterr().err
    assert not out.exists()


@pytest.mark.slow
def test_run_writes_tables_manifest_and_figures(tmp_path, capsys):
    out = tmp_path / "run"
    scenario = tmp_path / "s.yaml"
    shutil.copy(SCENARIOS / "comm-perm.yaml", scenario)
    assert (
        main(["run", str(scenario), "--seed", "2", "--steps", "30", "--out", str(out), "-q"]) == 0
    )
    for name in ("team", "robots", "targets", "events", "zones", "knowledge", "timing"):
        assert (out / f"{name}.parquet").exists()
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["seed"] == 2 and manifest["policy"] == "failure_aware"
    assert manifest["scenario"]["steps"] == 30
    assert len(pd.read_parquet(out / "team.parquet")) == 30
    assert len(list((out / "figures").glob("*.png"))) >= 2
    assert "wrote" in capsys.readouterr().out


@pytest.mark.slow
def test_library_warnings_are_shown_only_with_verbose():
    """A library's warning (joblib's "a worker stopped"…) is for developers: `-v` shows it."""
    code = (
        "import sys, warnings; from resilient_tracking.cli import main, single_run; "
        "single_run.cmd_validate = "
        "lambda args: (warnings.warn('library noise', UserWarning), 0)[1]; "
        "sys.exit(main(sys.argv[1:]))"
    )
    quiet = subprocess.run(
        [sys.executable, "-c", code, "validate", "x.yaml"], capture_output=True, text=True
    )
    loud = subprocess.run(
        [sys.executable, "-c", code, "-v", "validate", "x.yaml"], capture_output=True, text=True
    )
    assert quiet.returncode == loud.returncode == 0, quiet.stderr + loud.stderr
    assert "library noise" not in quiet.stderr + quiet.stdout
    assert "library noise" in loud.stderr


@pytest.mark.parametrize("share", ["1.5", "-0.1", "nan"])
def test_node_plan_budget_outside_its_range_is_an_error_naming_it(share, capsys):
    pytest.importorskip("cyclonedds")
    assert main(["node", str(SCENARIOS / "sensing-temp.yaml"), "--plan-budget", share]) != 0
    assert "--plan-budget: must be between 0 and 1" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("given", "expected"),
    [([], 0.35), (["--plan-budget", "0.5"], 0.5), (["--plan-budget", "0"], None)],
)
def test_node_plan_budget_reaches_the_node_settings(given, expected):
    pytest.importorskip("cyclonedds")
    from resilient_tracking.cli.parser import build_parser
    from resilient_tracking.cli.ros2_nodes import node_setup
    from resilient_tracking.ros2.topics import NodeSettings

    args = build_parser().parse_args(["node", str(SCENARIOS / "sensing-temp.yaml"), *given])
    setup = node_setup(args)
    assert setup is not None
    settings = setup[2]
    assert isinstance(settings, NodeSettings) and settings.plan_budget == expected
