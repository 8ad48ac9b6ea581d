"""check_policy passes every built-in policy and names each kind of violation, no traceback."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from helpers import with_policy_needs
from resilient_tracking import builtin_scenarios
from resilient_tracking.build import team_config
from resilient_tracking.policies import POLICIES, Decision, Policy
from resilient_tracking.policy_check import PolicyCheckError, check_policy


@pytest.fixture(scope="module")
def scenario():
    return builtin_scenarios.load("combined-temp")


@pytest.mark.parametrize("name", POLICIES.builtin_names())
def test_every_builtin_policy_passes(name, scenario):
    data = with_policy_needs(scenario.model_dump(mode="json"), name)
    report = check_policy(name, type(scenario).model_validate(data))
    assert report.ok, str(report)
    assert len(report.ticks) >= 10
    assert "every robot blind" in report.ticks


def test_the_builtin_policies_register_themselves():
    assert set(POLICIES.builtin_names()) == {"failure_aware", "vanilla", "sog", "callable", "onnx"}


def test_the_learned_policy_without_its_function_is_reported_not_raised(scenario):
    report = check_policy("callable", scenario)
    assert not report.ok
    assert "params.function" in str(report)


class Still(Policy):
    """Holds every robot; the subclasses below each break one promise."""

    name = "still"

    def act(self, belief, obs):
        m = obs.n_robots
        return Decision(controls=self.controls(obs), modes=["still"] * m)

    def controls(self, obs):
        return np.zeros((obs.n_robots, 2))


class NonFinite(Still):
    def controls(self, obs):
        u = np.zeros((obs.n_robots, 2))
        u[0] = np.nan
        return u


class TooFast(Still):
    def controls(self, obs):
        return np.full((obs.n_robots, 2), 1e3)


class WrongShape(Still):
    def controls(self, obs):
        return np.zeros((obs.n_robots + 1, 2))


class Raises(Still):
    def controls(self, obs):
        if not obs.sensing_ok.any():
            raise RuntimeError("nobody sees anything")
        return np.zeros((obs.n_robots, 2))


class Random(Still):
    def controls(self, obs):
        return np.random.default_rng().uniform(-1e-3, 1e-3, (obs.n_robots, 2))


class HoldsTruth(Still):
    def __init__(self, config, params=None):
        super().__init__(config, params)
        from resilient_tracking.world.zones import TrueZone  # reaching for truth

        self.zone_type = TrueZone


def test_a_well_behaved_policy_passes(scenario):
    assert check_policy(Still, scenario).ok


@pytest.mark.parametrize(
    ("cls", "words"),
    [
        (NonFinite, "controls of robots [0] are not finite"),
        (TooFast, "outside its velocity bounds"),
        (WrongShape, "controls have shape"),
        (Raises, "act raised RuntimeError: nobody sees anything"),
        (Random, "nondeterministic"),
        (HoldsTruth, "imports resilient_tracking.world.zones"),
    ],
)
def test_each_violation_is_named(cls, words, scenario):
    report = check_policy(cls, scenario)
    assert not report.ok
    text = str(report)
    assert words in text, text
    assert "Traceback" not in text
    with pytest.raises(PolicyCheckError, match="violation"):
        report.raise_for_violations()


def test_an_instance_is_checked_on_copies(scenario):

    policy = NonFinite(team_config(scenario))
    report = check_policy(policy, scenario)
    assert "not finite" in str(report)


def test_blind_tick_is_where_raises_is_reported(scenario):
    report = check_policy(Raises, scenario)
    assert {v.tick for v in report.violations} == {"every robot blind"}


class Exits(Still):
    def controls(self, obs):
        sys.exit(0)


class GeneratorExits(Still):
    def controls(self, obs):
        raise GeneratorExit("gone")


class Odd(BaseException):
    """Neither an Exception nor an interrupt."""


class RaisesOdd(Still):
    def controls(self, obs):
        raise Odd("odd")


class ExitsWhenBuilt(Still):
    def __init__(self, config, params=None):
        sys.exit(4)


class NeedsExit(Still):
    def belief_needs(self):
        sys.exit(5)


class Interrupted(Still):
    def controls(self, obs):
        raise KeyboardInterrupt


class StringEvents(Still):
    def act(self, belief, obs):
        decision = super().act(belief, obs)
        decision.events = ["attack"]
        return decision


class BadPlans(Still):
    def act(self, belief, obs):
        decision = super().act(belief, obs)
        decision.plans = [{"solve_ms": 1.0}]
        return decision


@pytest.mark.parametrize(
    ("cls", "tick", "words"),
    [
        (Exits, "all well, no zone knowledge", "act called sys.exit(0) in test_policy_check.Exits"),
        (GeneratorExits, "all well, no zone knowledge", "act raised GeneratorExit: gone in"),
        (RaisesOdd, "all well, no zone knowledge", "act raised Odd: odd in test_policy_check"),
        (ExitsWhenBuilt, "build", "building the policy called sys.exit(4) in"),
        (NeedsExit, "setup", "setting up its team called sys.exit(5) in"),
        (StringEvents, "all well, no zone knowledge", "events[0] is str 'attack', not an Event"),
        (BadPlans, "all well, no zone knowledge", "plans[0] is dict"),
    ],
)
def test_exits_and_fields_a_run_cannot_use_are_reported_not_raised(cls, tick, words, scenario):
    report = check_policy(cls, scenario)
    assert not report.ok
    assert report.violations[0].tick == tick
    assert words in str(report), str(report)


def test_a_policy_module_that_exits_at_import_is_reported(scenario, tmp_path, monkeypatch):
    (tmp_path / "exits_at_import_for_check.py").write_text("import sys\nsys.exit(0)\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    report = check_policy("exits_at_import_for_check:P", scenario)
    assert not report.ok and report.violations[0].tick == "build"
    assert "called sys.exit(0) at import" in str(report), str(report)


def test_an_interrupt_in_act_is_raised_not_reported(scenario):
    with pytest.raises(KeyboardInterrupt):
        check_policy(Interrupted, scenario)
