"""The TorchRL example: two iterations of its one command train, export and run a team, and
the exported model decides what the trained network decides."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

pytest.importorskip("torchrl")
pytest.importorskip("onnxruntime")

import torch  # noqa: E402

from helpers import run_checked, shipped  # noqa: E402
from resilient_tracking.belief.agent_view import FIELDS, ViewShape  # noqa: E402
from resilient_tracking.build import team_config  # noqa: E402
from resilient_tracking.policies import POLICIES  # noqa: E402
from resilient_tracking.policy_check import check_policy  # noqa: E402

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "learned_team"


def example_module(name: str):
    """The example's module ``name``, imported under a name of its own."""
    spec = importlib.util.spec_from_file_location(f"learned_team_{name}", EXAMPLE / f"{name}.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def trained(tmp_path_factory) -> Path:
    """The example's one command on a small budget: one demonstration, two PPO iterations."""
    out = tmp_path_factory.mktemp("learned")
    run_checked(
        [sys.executable, str(EXAMPLE / "train.py"), "--out", str(out), "--iterations", "2",
         "--episodes", "1", "--steps", "20", "--generated", "1", "--demo-episodes", "1",
         "--eval-seeds", "1", "--eval-scenarios", "sensing-temp"],
        cwd=out,
    )  # fmt: skip
    return out


@pytest.mark.slow
def test_two_iterations_give_finite_losses_and_returns_and_a_checkpoint_that_loads(trained):
    curve = pd.read_csv(trained / "curve.csv")
    assert curve["iteration"].tolist() == [1, 2]
    terms = ["return", "loss_objective", "loss_critic"]
    assert np.isfinite(curve[terms].to_numpy()).all()
    actor = example_module("model").Actor()
    actor.load_state_dict(torch.load(trained / "checkpoint.pt", weights_only=True)["actor"])
    assert (trained / "curve.png").stat().st_size > 0
    report = (trained / "compare" / "report.md").read_text()
    assert "onnx:" in report and "vanilla" in report


@pytest.mark.slow
def test_the_exported_team_decides_as_the_network_and_passes_check_policy(trained):
    model = example_module("model")
    actor = model.Actor()
    actor.load_state_dict(torch.load(trained / "checkpoint.pt", weights_only=True)["actor"])
    name = f"onnx:{trained / 'team.onnx'}"
    for m, n in [(3, 3), (6, 4)]:  # any team size: robots and targets are dynamic axes
        scenario = shipped("sensing-temp")
        cls = POLICIES.get(name)
        policy = cls(team_config(scenario), cls.Params())
        rng = np.random.default_rng(m)
        views = {
            f: rng.normal(size=(m, *shape)).astype(np.float32)
            for f, shape in ViewShape(m, n).shapes().items()
        }
        views["own"][:, 2] = 1.0  # a speed bound
        with torch.no_grad():
            expected = model.Deployed(actor)(*(torch.from_numpy(views[f]) for f in FIELDS))
        np.testing.assert_allclose(policy.velocities(views), expected.numpy(), atol=1e-5)
    report = check_policy(name, shipped("comm-temp").with_overrides(steps=20))
    assert report.ok, str(report)


def test_a_robot_that_retires_is_masked_out_of_the_rollout_and_the_loss():
    """TorchRL's wrapper with its agent mask: a robot that can neither sense nor talk for good
    leaves (PettingZoo), the mask marks it, and its later steps are not trained on."""
    from resilient_tracking.world.world import Failure

    train = example_module("train")
    learner = train.Learner()
    env = train.wrapped(shipped("combined-perm"), steps=8)
    start = env.reset()
    failures = env._env.session.running.world.failures
    failures["sensing"][0] = failures["comm"][0] = Failure("permanent", 0, 0)
    with torch.no_grad():
        rollout = env.rollout(8, learner.act, auto_reset=False, tensordict=start)
    mask = rollout.get(("robots", "mask"))
    assert mask[0].tolist() == [True, True, True]  # it acts once, then retires
    assert not mask[1:, 0].any() and mask[1:, 1:].all()
    assert rollout.get(("next", "robots", "terminated"))[0, :, 0].tolist() == [True, False, False]
    samples = learner.samples(rollout, gamma=0.98, lmbda=0.95)
    assert len(samples) == 1 + 2 * len(rollout)
    assert torch.isfinite(samples["advantage"]).all()
