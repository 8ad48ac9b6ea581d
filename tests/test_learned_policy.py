"""Learned policies as plug-ins: a function from a robot's view to its velocity runs like any
policy (``rtrack run``, ``rtrack compare``, ``check_policy``) and sees what the environment's
agents see."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
import yaml

from helpers import shipped
from learned_agents import chase
from resilient_tracking.cli import main
from resilient_tracking.policies import CallablePolicy
from resilient_tracking.policy_check import check_policy
from resilient_tracking.scenario import ScenarioError
from resilient_tracking.sim.episode import run_episode

CHASE = "learned_agents:chase"


def with_function(name: str, function: str, steps: int = 60):
    data = shipped(name).with_overrides(steps=steps).model_dump(mode="json")
    data["policy"] = {"name": "callable", "callable": {"function": function}}
    return type(shipped(name)).model_validate(data)


def test_a_wrapped_function_passes_check_policy():
    report = check_policy(CallablePolicy.wrapping(chase, "chaser"), shipped("comm-perm"))
    assert report.ok, str(report)


def test_the_function_named_in_the_scenario_moves_the_robots():
    result = run_episode(with_function("sensing-temp", CHASE), seed=1)
    robots = result["robots"]
    assert (robots["mode"] == "learned").all()
    assert robots["ux"].abs().max() > 0
    assert result.manifest["policy"] == "callable"


def test_a_function_giving_nan_holds_that_robot_with_an_event():
    result = run_episode(with_function("sensing-temp", "learned_agents:broken", 5), seed=0)
    invalid = result["events"][result["events"]["event"] == "invalid_decision"]
    assert len(invalid) == 5 and set(invalid["robot"]) == {0}


def test_no_function_is_an_error_naming_the_field():
    with pytest.raises(ValueError, match="params.function"):
        run_episode(shipped("sensing-temp").with_overrides(steps=2), policy="callable")
    data = shipped("sensing-temp").model_dump(mode="json")
    data["policy"] = {"name": "callable", "callable": {"function": "no_colon"}}
    with pytest.raises((ScenarioError, ValueError), match="package.module:name"):
        type(shipped("sensing-temp")).model_validate(data)


def test_under_rtrack_run_and_compare(tmp_path):
    file = tmp_path / "chase.yaml"
    data = with_function("sensing-perm", CHASE, steps=30).model_dump(mode="json")
    file.write_text(yaml.safe_dump(data))
    assert main(["run", str(file), "--out", str(tmp_path / "run"), "--quiet", "--no-figures"]) == 0
    robots = pd.read_parquet(tmp_path / "run" / "robots.parquet")
    assert (robots["mode"] == "learned").all()
    out = tmp_path / "compare"
    args = ["compare", "sensing-perm", "--policies", "vanilla,callable", "--seeds", "1"]
    args += ["--set", "steps=30", "--set", f"policy.callable.function={CHASE}"]
    assert main([*args, "--out", str(out), "--quiet"]) == 0
    assert "callable" in (out / "report.md").read_text()


def test_the_function_sees_what_the_environments_agents_see():
    pytest.importorskip("pettingzoo")
    from resilient_tracking.env import parallel_env

    run = run_episode(with_function("combined-temp", CHASE, steps=80), seed=3)
    env = parallel_env("combined-temp", steps=80)
    observations, _ = env.reset(seed=3)
    while env.agents:
        observations, *_ = env.step({a: chase(v) for a, v in observations.items()})
    walked = env.session.result()["robots"]
    columns = ["step", "robot", "x", "y", "ux", "uy", "sensing_ok", "comm_ok", "league"]
    pd.testing.assert_frame_equal(walked[columns], run["robots"][columns], check_exact=True)
    assert np.abs(run["robots"]["ux"]).max() > 0
