"""A policy's bad decisions never reach the robots silently: a control that is not finite or
breaks its velocity bounds becomes an ``invalid_decision`` event naming the policy, and that
robot holds its position; the others keep their commands."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import yaml

from helpers import shipped
from resilient_tracking.policies import Decision, Policy
from resilient_tracking.sim.episode import run_episode

HERE = Path(__file__).resolve().parent


class WildPolicy(Policy):
    """Robot 0 gets NaN, robot 1 five times its speed limit, every other robot a fair command."""

    name = "wild"
    learns_zones = False

    def act(self, belief, obs) -> Decision:
        controls = np.full((obs.n_robots, 2), 0.3)
        controls[0] = np.nan
        controls[1] = 5.0 * self.config.u_max[1]
        return Decision(controls=controls, modes=["wild"] * obs.n_robots)


def _scenario():
    data = shipped("sensing-temp").model_dump(mode="json")
    data["steps"] = 6
    data["zones"] = []
    return data


def test_invalid_controls_become_events_and_hold_position():
    from resilient_tracking.scenario import parse_scenario

    result = run_episode(parse_scenario(_scenario()), policy=f"{__name__}:WildPolicy")
    events = result["events"]
    bad = events[events["event"] == "invalid_decision"]
    assert sorted(set(bad["robot"])) == [0, 1]
    assert len(bad) == 2 * 6  # both robots, every step
    assert bad["detail"].str.contains("policy wild").all()
    assert bad[bad.robot == 0]["detail"].str.contains("not finite").all()
    assert bad[bad.robot == 1]["detail"].str.contains("outside its velocity bounds").all()
    robots = result["robots"]
    held = robots[robots.robot.isin([0, 1])]
    assert (held[["ux", "uy"]].to_numpy() == 0.0).all()
    assert (held["mode"] == "hold").all()
    fair = robots[robots.robot == 2]
    np.testing.assert_allclose(fair[["ux", "uy"]].to_numpy(), 0.3)
    assert (fair["mode"] == "wild").all()
    assert np.isfinite(result["team"]["trace"]).all()


def test_rtrack_run_says_which_policy_produced_them(tmp_path):
    data = _scenario()
    data["policy"] = {"name": "test_decision_checks:WildPolicy"}
    path = tmp_path / "wild.yaml"
    path.write_text(yaml.safe_dump(data))
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(HERE), *sys.path]), "MPLBACKEND": "Agg"}
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "resilient_tracking.cli",
            "run",
            str(path),
            "--out",
            str(tmp_path / "out"),
            "-q",
            "--no-figures",
        ],
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    assert "12 invalid decision(s) of the policy: policy wild" in done.stderr, done.stderr
