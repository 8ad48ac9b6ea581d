"""The distillation example: its training loop, its network and its policy run end to end on
a small budget."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pettingzoo")

from helpers import shipped  # noqa: E402
from resilient_tracking.policy_check import check_policy  # noqa: E402
from resilient_tracking.sim.episode import run_episode  # noqa: E402

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "distilled_policy"


@pytest.fixture
def example(monkeypatch, tmp_path):
    monkeypatch.syspath_prepend(str(EXAMPLE))
    monkeypatch.setenv("DISTILLED_WEIGHTS", str(tmp_path / "weights.npz"))
    import distilled
    import train

    return distilled, train, tmp_path / "weights.npz"


def test_the_network_fits_what_it_is_shown(example):
    distilled, _, _ = example
    rng = np.random.default_rng(0)
    x = rng.normal(size=(400, 5))
    y = np.tanh(x[:, :2] - 0.5 * x[:, 2:4])
    network = distilled.Network.fit(x, y, hidden=16, epochs=200)
    assert np.mean((network(x) - y) ** 2) < 0.1 * np.mean(y**2)


def test_cloned_from_the_planner_it_runs_as_a_policy(example):
    distilled, train, weights = example
    xs, ys = train.episode("sensing-temp", 1000, 40, None, np.random.default_rng(0))
    assert len(xs) == 40 * 3 and all(np.isfinite(x).all() for x in xs)
    distilled.Network.fit(np.array(xs), np.clip(np.array(ys), -1, 1), epochs=20).save(weights)
    scenario = shipped("comm-temp").with_overrides(steps=40)
    report = check_policy("distilled:DistilledPolicy", scenario)
    assert report.ok, str(report)
    robots = run_episode(scenario, policy="distilled:DistilledPolicy", seed=0)["robots"]
    assert (robots["mode"] == "distilled").all() and robots["ux"].abs().max() > 0
