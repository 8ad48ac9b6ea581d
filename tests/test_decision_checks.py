"""A policy's bad decisions never reach the robots silently: a control that is not finite or
breaks its velocity bounds becomes an ``invalid_decision`` event naming the policy, and that
robot holds its position; the others keep their commands."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from helpers import shipped
from resilient_tracking.events import Event
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


class RaisingPolicy(Policy):
    """A plug-in with a bug: raises at its second step."""

    name = "raising"
    learns_zones = False

    def act(self, belief, obs) -> Decision:
        if obs.step == 1:
            raise RuntimeError("plug-in bug")
        return Decision(controls=np.zeros((obs.n_robots, 2)), modes=["raising"] * obs.n_robots)


class WrongShapePolicy(Policy):
    """A plug-in that returns three numbers per robot."""

    name = "wrong_shape"
    learns_zones = False

    def act(self, belief, obs) -> Decision:
        return Decision(controls=np.zeros((obs.n_robots, 3)), modes=["x"] * obs.n_robots)


def test_a_wrong_shape_holds_every_robot_with_one_warning(caplog):
    from resilient_tracking.scenario import parse_scenario

    result = run_episode(parse_scenario(_scenario()), policy=f"{__name__}:WrongShapePolicy")
    bad = result["events"][result["events"]["event"] == "invalid_decision"]
    assert len(bad) == 3 * 6 and set(bad["cause"]) == {"shape"}
    assert (result["robots"][["ux", "uy"]].to_numpy() == 0.0).all()
    warnings = [r for r in caplog.records if r.levelname == "WARNING"]
    assert len(warnings) == 1 and "policy wrong_shape" in warnings[0].getMessage()


class ChattyPolicy(Policy):
    """Fair controls; its events and plans are given per test (``EVENTS``, ``PLANS``)."""

    name = "chatty"
    learns_zones = False
    EVENTS: object = []
    PLANS: object = []

    def act(self, belief, obs) -> Decision:
        decision = Decision(np.zeros((obs.n_robots, 2)), ["chatty"] * obs.n_robots)
        decision.events, decision.plans = self.EVENTS, self.PLANS  # type: ignore[assignment]
        return decision


def _plan(**changes):
    from resilient_tracking.planning.plan_result import PlanResult

    fields = {"controls": np.zeros((1, 2)), "status": "ok", "success": True}
    return PlanResult(**{**fields, "iterations": 3, "solve_ms": 1.5, **changes})


BAD_FIELDS = [
    ("events", ["hello"], "events[0] is str 'hello', not an Event"),
    ("events", ("not", "a list"), "events[0] is str"),
    ("events", "text", "events must be a list of Event, got str"),
    ("events", [Event(0, 0, "attack", detail=None)], "events[0].detail must be text"),
    ("events", [Event("0", 0, "attack")], "events[0].step must be an integer"),
    ("events", [Event(0, 0, "dance")], "events[0].event 'dance' is not the name of a team's"),
    ("events", [Event(0, 0, "degraded")], "events[0].event 'degraded' is not the name"),
    ("plans", None, "plans must be a list of PlanResult, got NoneType"),
    ("plans", [{"success": True}], "plans[0] is dict"),
    ("plans", [_plan(iterations=2.5)], "plans[0].iterations must be an integer"),
    ("plans", [_plan(solve_ms="fast")], "plans[0].solve_ms must be a number"),
    ("plans", [_plan(success="yes")], "plans[0].success must be a bool"),
]


@pytest.mark.parametrize(("field", "value", "words"), BAD_FIELDS)
def test_events_and_plans_a_run_cannot_record_are_dropped_as_invalid_decisions(
    field, value, words, monkeypatch
):
    from resilient_tracking.scenario import parse_scenario

    monkeypatch.setattr(ChattyPolicy, field.upper(), value)
    result = run_episode(parse_scenario(_scenario()), policy=f"{__name__}:ChattyPolicy")
    bad = result["events"][result["events"]["event"] == "invalid_decision"]
    assert len(bad) == 3 * 6 and set(bad["cause"]) == {field}, bad
    assert bad["detail"].str.contains(words, regex=False).all(), bad["detail"].iloc[0]
    robots = result["robots"]
    assert (robots["mode"] == "chatty").all()  # a fair control: no robot holds
    if field == "plans":
        assert (result["team"]["n_solves"] == 0).all()


def test_well_formed_events_and_plans_are_recorded(monkeypatch):
    from resilient_tracking.scenario import parse_scenario

    monkeypatch.setattr(ChattyPolicy, "EVENTS", (Event(0, np.int64(1), "zone_suspected"),))
    monkeypatch.setattr(ChattyPolicy, "PLANS", [_plan(success=np.bool_(False))])
    result = run_episode(parse_scenario(_scenario()), policy=f"{__name__}:ChattyPolicy")
    events = result["events"]
    assert (events["event"] == "invalid_decision").sum() == 0
    assert (events["event"] == "zone_suspected").sum() == 6
    assert (result["team"]["n_solver_failures"] == 1).all()


@pytest.mark.parametrize("jobs", [1, 2])
def test_compare_says_which_runs_of_a_plugin_failed_one_line_each(tmp_path, capsys, jobs):
    from resilient_tracking.cli import main

    path = tmp_path / "s.yaml"
    path.write_text(yaml.safe_dump(_scenario()))
    out = tmp_path / "cmp"
    policies = f"{__name__}:RaisingPolicy,{__name__}:WrongShapePolicy"
    argv = ["compare", str(path), "--policies", policies, "--seeds", "2", "--out", str(out)]
    code = main([*argv, "--jobs", str(jobs), "-q"])
    err = capsys.readouterr().err
    assert code == 2 and "Traceback" not in err, err
    lines = [line for line in err.splitlines() if line.startswith("error: ")]
    assert len(lines) == 3, err  # one per failed run, then the count
    for seed in (1, 2):
        assert any(
            f"RaisingPolicy/seed-00{seed}: policy {__name__}:RaisingPolicy: RuntimeError: "
            "plug-in bug" in line
            for line in lines
        ), err
    assert "2 of 4 run(s) failed" in lines[-1]
    stored = sorted(p.parent.parent.name for p in out.glob("runs/*/*/seed-*/manifest.json"))
    assert stored == 2 * [f"{__name__}_WrongShapePolicy"]
    assert not (out / "report.md").exists()


def test_the_team_s_velocity_bounds_follow_the_positions_they_are_asked_for():
    from resilient_tracking.build import team_config

    config = team_config(shipped("sensing-temp"))
    everyone = list(range(config.n_robots))
    positions = np.array([[-3.9, 0.0], [0.0, 2.95], [3.99, -2.99]])
    first = config.velocity_bounds(everyone, positions)
    again = config.velocity_bounds(everyone, positions.copy())
    assert all(np.array_equal(a, b) for a, b in zip(first, again, strict=True))
    # each robot alone gets its row of the team's bounds
    for i in everyone:
        alone = config.velocity_bounds([i], positions)
        assert np.array_equal(alone[0], first[0][[i]]) and np.array_equal(alone[1], first[1][[i]])
    positions[0] = [3.95, 0.0]  # moved in place: new bounds, not the kept ones
    moved = config.velocity_bounds(everyone, positions)
    fresh = team_config(shipped("sensing-temp")).velocity_bounds(everyone, positions)
    assert all(np.array_equal(a, b) for a, b in zip(moved, fresh, strict=True))
    assert moved[1][0, 0] < first[1][0, 0]


def test_the_team_s_clip_keeps_controls_within_the_bounds_and_nan_as_nan():
    from resilient_tracking.build import team_config

    config = team_config(shipped("sensing-temp"))
    everyone = list(range(config.n_robots))
    rng = np.random.default_rng(8)
    for _ in range(200):
        positions = rng.uniform(-4.0, 4.0, size=(config.n_robots, 2))
        u = rng.uniform(-3.0, 3.0, size=(config.n_robots, 2))
        lower, upper = config.velocity_bounds(everyone, positions)
        clipped = config.clip(u, positions)
        assert (lower <= clipped).all() and (clipped <= upper).all()
        inside = (lower <= u) & (u <= upper)
        assert np.array_equal(clipped[inside], u[inside])  # a control within them is kept
    u[0, 1] = np.nan
    with_nan = config.clip(u, positions)
    assert np.isnan(with_nan[0, 1]) and np.isfinite(np.delete(with_nan.ravel(), 1)).all()
