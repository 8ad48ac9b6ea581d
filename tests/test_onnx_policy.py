"""The onnx policy: a trained team saved as ONNX runs wherever a policy runs, and a model that
does not fit the team is refused before the first tick, naming the file and what differs.

The models are built with onnx's helpers (``onnx_models.py``): a pursuer that steers each robot
towards the mean of its league's target estimates, the same rule written in NumPy for
comparison.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

pytest.importorskip("onnx")
pytest.importorskip("onnxruntime")

from helpers import shipped  # noqa: E402
from onnx_models import pursue, pursuer_model  # noqa: E402
from resilient_tracking.belief.agent_view import ViewShape  # noqa: E402
from resilient_tracking.build import team_config  # noqa: E402
from resilient_tracking.cli import main  # noqa: E402
from resilient_tracking.policies import POLICIES, CallablePolicy  # noqa: E402
from resilient_tracking.policies.onnx_policy import OnnxPolicy  # noqa: E402
from resilient_tracking.policy_check import check_policy  # noqa: E402
from resilient_tracking.registry import UnknownName  # noqa: E402
from resilient_tracking.sim.episode import run_episode  # noqa: E402


@pytest.fixture
def model(tmp_path: Path) -> Path:
    return pursuer_model(tmp_path / "pursuer.onnx")


def _policy(name: str, scenario_name: str = "sensing-temp") -> OnnxPolicy:
    scenario = shipped(scenario_name)
    cls = POLICIES.get(name)
    policy = cls(team_config(scenario), cls.Params())
    policy.check_targets(len(scenario.targets))
    assert isinstance(policy, OnnxPolicy)
    return policy


def _views(m: int, n: int, seed: int = 0) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    return {
        name: rng.normal(size=(m, *shape)).astype(np.float32)
        for name, shape in ViewShape(m, n).shapes().items()
    }


@pytest.mark.parametrize("batch", ["robots", 1])
def test_the_model_decides_what_the_same_rule_in_numpy_decides(tmp_path, batch):
    """All robots in one call, or one at a time when the model's leading axis is fixed at 1."""
    policy = _policy(f"onnx:{pursuer_model(tmp_path / 'm.onnx', batch=batch)}")
    assert policy.one_at_a_time == (batch == 1)
    views = _views(3, 3)
    numpy = CallablePolicy.wrapping(pursue)(policy.config, CallablePolicy.Params())
    np.testing.assert_allclose(policy.velocities(views), numpy.velocities(views), rtol=1e-6)


def test_rtrack_run_and_compare_run_a_team_saved_as_onnx(tmp_path, model):
    out = tmp_path / "run"
    assert main(["run", "sensing-temp", "--policy", f"onnx:{model}", "--out", str(out), "-q"]) == 0
    robots = pd.read_parquet(out / "robots.parquet")
    assert set(robots["mode"]) == {"learned"}
    argv = ["compare", "sensing-temp", "--policies", f"onnx:{model}", "--seeds", "1"]
    assert main([*argv, "--out", str(tmp_path / "cmp"), "-q"]) == 0
    assert (tmp_path / "cmp" / "report.md").exists()
    figures = tmp_path / "cmp" / "sensing-temp" / "figures"
    snapshots = [p.name for p in figures.iterdir() if p.name.startswith("snapshots-")]
    assert snapshots == [f"snapshots-onnx_{str(model).replace('/', '_')}.png"]  # one file


def test_rtrack_reproduce_runs_the_failure_aware_arms_with_the_model(tmp_path, model):
    out = tmp_path / "reproduced"
    argv = ["reproduce", "sensing-temp", "--seeds", "1", "--policy", f"onnx:{model}", "-q"]
    assert main([*argv, "--out", str(out)]) == 0
    modes = {
        arm.name: set(pd.read_parquet(run / "robots.parquet")["mode"])
        for arm in (out / "runs" / "sensing-temp").iterdir()
        for run in arm.glob("seed-*")
    }
    learned = [arm for arm, seen in modes.items() if seen == {"learned"}]
    assert len(learned) == 1 and len(modes) == 2  # the failure-aware arm, not vanilla
    assert f"--policy onnx:{model}" in (out / "report.md").read_text()
    refused = ["reproduce", "sensing-temp", "--policy", "onnx:", "--out", str(tmp_path / "x")]
    assert main(refused) == 1 and not (tmp_path / "x").exists()


def test_a_changed_model_file_makes_stored_runs_stale(tmp_path, model):
    from resilient_tracking.experiments.catalog import catalog, tasks, with_policy

    def fingerprints():
        runs = with_policy(tasks(catalog()["sensing-temp"], 1), f"onnx:{model}")
        return {t.variant.policy.partition(":")[0]: t.fingerprint for t in runs}

    before = fingerprints()
    assert fingerprints() == before and set(before) == {"onnx", "vanilla"}
    pursuer_model(model, input_name="targets", divide_by_zero=True)  # same path, new weights
    after = fingerprints()
    assert after["onnx"] != before["onnx"] and after["vanilla"] == before["vanilla"]


def test_the_pursuer_follows_its_targets_in_an_episode(model):
    """Closed loop: the robots end nearer the targets than they start (the controls reach the
    robots), and the team tracks (finite, small error) with no invalid decision."""
    scenario = shipped("sensing-temp").with_overrides(zones=[], policy={"name": f"onnx:{model}"})
    result = run_episode(scenario, seed=3)
    robots, targets = result.tables["robots"], result.tables["targets"]
    gap = []
    for step in (0, int(robots.step.max())):
        here = robots[robots.step == step][["x", "y"]].to_numpy().mean(axis=0)
        there = targets[targets.step == step][["x", "y"]].to_numpy().mean(axis=0)
        gap.append(float(np.hypot(*(here - there))))
    assert gap[1] < gap[0]
    events = result.tables["events"]
    assert not (events.event == "invalid_decision").any()


def test_check_policy_passes_on_an_onnx_team(model):
    report = check_policy(f"onnx:{model}", shipped("sensing-temp"))
    assert report.ok, report.text()


def test_the_model_can_be_named_in_the_scenario_params(model):
    scenario = shipped("sensing-temp").with_overrides(
        policy={"name": "onnx", "params": {"model": str(model)}}
    )
    robots = run_episode(scenario.with_overrides(steps=5), seed=1).tables["robots"]
    assert set(robots["mode"]) == {"learned"}


# --------------------------------------------------------------------------- refusals


def _refused(name: str, scenario_name: str = "sensing-temp") -> str:
    with pytest.raises((ValueError, UnknownName)) as err:
        _policy(name, scenario_name)
    return str(err.value)


def test_a_missing_file_is_refused_naming_it(tmp_path):
    message = _refused(f"onnx:{tmp_path / 'nowhere.onnx'}")
    assert "nowhere.onnx" in message and "no such file" in message


def test_a_file_that_is_not_a_model_is_refused_naming_it(tmp_path):
    junk = tmp_path / "junk.onnx"
    junk.write_bytes(b"not a model")
    message = _refused(f"onnx:{junk}")
    assert "junk.onnx" in message and "not a model onnxruntime can run" in message


def test_an_input_that_is_no_field_of_a_view_is_refused(tmp_path):
    path = pursuer_model(tmp_path / "obs.onnx", input_name="observation")
    message = _refused(f"onnx:{path}")
    assert "obs.onnx" in message and "'observation' is not a field" in message


def test_a_model_made_for_another_number_of_targets_is_refused(tmp_path):
    path = pursuer_model(tmp_path / "five.onnx", n_targets=5)
    message = _refused(f"onnx:{path}")
    assert "five.onnx" in message and "'targets'" in message
    assert "(robots, 5, 4)" in message and "(3, 3, 4)" in message


def test_a_model_whose_velocities_are_not_finite_is_refused(tmp_path):
    path = pursuer_model(tmp_path / "nan.onnx", divide_by_zero=True)
    message = _refused(f"onnx:{path}")
    assert "nan.onnx" in message and "not finite" in message


def test_rtrack_run_refuses_a_mismatched_model_in_one_line_and_writes_nothing(tmp_path, capsys):
    path = pursuer_model(tmp_path / "five.onnx", n_targets=5)
    out = tmp_path / "run"
    assert main(["run", "sensing-temp", "--policy", f"onnx:{path}", "--out", str(out)]) != 0
    err = capsys.readouterr().err
    assert "five.onnx" in err and "'targets'" in err and "Traceback" not in err
    assert not out.exists()


def test_the_name_needs_a_path_after_the_colon():
    assert "give its model after the colon" in _refused("onnx:")
    assert "give the model file" in _refused("onnx")


def test_the_shipped_learned_team_is_found_by_name_and_passes_check_policy():
    from resilient_tracking.policies.onnx_policy import SHIPPED, model_path

    assert model_path("learned-team") == SHIPPED / "learned-team.onnx"
    report = check_policy("onnx:learned-team", shipped("comm-temp").with_overrides(steps=20))
    assert report.ok, str(report)
    with pytest.raises(ValueError, match="no such file .models shipped: learned-team"):
        _policy("onnx:learned-tea")
