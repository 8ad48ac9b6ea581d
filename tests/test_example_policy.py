"""The example third-party policy (examples/greedy_tracker), copied outside the repository and
installed into the fresh virtualenv of the wheel test, runs by entry point and by dotted path;
check_policy passes on it and reports, without a traceback, when its controls go non-finite."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from pathlib import Path

import pytest

from helpers import run_checked

pytestmark = [pytest.mark.wheel, pytest.mark.slow]

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "greedy_tracker"

SCENARIO = """\
name: greedy-by-path
steps: 15
robots:
  - {start: [0.0, 0.0]}
  - {start: [1.0, 0.0]}
targets:
  - {start: [2.0, 2.0], motion: {type: constant_velocity, velocity: [0.1, 0.0]}}
policy:
  name: greedy_tracker.policy:GreedyPolicy
  params: {gain: 0.8, standoff: 0.3}
"""

NAN_CHECK = """\
import numpy as np
from greedy_tracker import GreedyPolicy
from resilient_tracking import check_policy, load_scenario

class Broken(GreedyPolicy):
    def act(self, belief, obs):
        decision = super().act(belief, obs)
        decision.controls[:] = np.nan
        return decision

scenario = load_scenario("greedy.yaml")
print(check_policy("greedy", scenario))
print(check_policy(Broken, scenario))
"""


@pytest.fixture(scope="module")
def with_example(installed: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The wheel's virtualenv with the example package installed from a copy of it."""
    outside = tmp_path_factory.mktemp("thirdparty") / "greedy_tracker"
    shutil.copytree(EXAMPLE, outside, ignore=shutil.ignore_patterns("*.egg-info", "build"))
    run_checked(
        [
            str(installed / "python"),
            "-m",
            "pip",
            "install",
            "-q",
            "--no-deps",
            "--no-index",
            "--no-build-isolation",
            str(outside),
        ],
        cwd=outside.parent,
    )
    return installed


def _env() -> dict[str, str]:
    return {**os.environ, "MPLBACKEND": "Agg", "PYTHONPATH": ""}


def test_runs_by_entry_point_name(with_example: Path, tmp_path: Path) -> None:
    rtrack = str(with_example / "rtrack")
    args = ["run", "sensing-temp", "--policy", "greedy", "--steps", "15", "--no-figures", "-q"]
    run_checked([rtrack, *args, "--out", "R"], cwd=tmp_path, env=_env())
    manifest = json.loads((tmp_path / "R" / "manifest.json").read_text())
    assert manifest["policy"] == "greedy"


def test_runs_by_dotted_path_with_its_parameters(with_example: Path, tmp_path: Path) -> None:
    (tmp_path / "greedy.yaml").write_text(SCENARIO)
    rtrack = str(with_example / "rtrack")
    run_checked(
        [rtrack, "run", "greedy.yaml", "--no-figures", "-q", "--out", "P"], tmp_path, _env()
    )
    manifest = json.loads((tmp_path / "P" / "manifest.json").read_text())
    assert manifest["policy"] == "greedy_tracker.policy:GreedyPolicy"
    assert manifest["steps"] == 15
    # the default run folder names the policy portably (no colon from the dotted path)
    run_checked([rtrack, "run", "greedy.yaml", "--no-figures", "-q"], tmp_path, _env())
    (default,) = (tmp_path / "runs").iterdir()
    assert "greedy_tracker.policy_GreedyPolicy" in default.name and ":" not in default.name
    (tmp_path / "bad.yaml").write_text(SCENARIO.replace("gain: 0.8", "gain: -1"))
    done = subprocess.run(
        [rtrack, "validate", "bad.yaml"], cwd=tmp_path, env=_env(), capture_output=True, text=True
    )
    assert done.returncode == 1
    assert "policy.params.gain: Input should be greater than 0" in done.stdout + done.stderr


def test_check_policy_passes_and_reports_non_finite_controls(with_example, tmp_path) -> None:
    (tmp_path / "greedy.yaml").write_text(SCENARIO)
    (tmp_path / "check.py").write_text(NAN_CHECK)
    out = run_checked([str(with_example / "python"), "check.py"], tmp_path, _env()).stdout
    passed, broken = out.split("check_policy(")[1:]
    assert passed.startswith("greedy): ok"), out
    assert "are not finite" in broken, out
    assert "Traceback" not in out
