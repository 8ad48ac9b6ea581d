"""A hazard model and a target motion from outside the package, each one class in one file
(this one), selected by dotted path: validated by their own Spec, run in an episode."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from pydantic import Field

from helpers import shipped
from resilient_tracking import HazardModel, HazardSpec, MotionSpec, TargetMotion
from resilient_tracking.scenario import ScenarioError, parse_scenario
from resilient_tracking.sim.episode import run_episode


class AlwaysSpec(HazardSpec):
    """Attack with probability ``p`` at every step, anywhere."""

    p: float = Field(ge=0, le=1, description="Attack probability per step.")


class AlwaysHazard(HazardModel):
    """Attack with the same probability everywhere (a test hazard)."""

    Spec = AlwaysSpec

    def __init__(self, p: float):
        self.p = p

    @classmethod
    def from_zone(cls, spec: Any, zone: Any) -> AlwaysHazard:
        return cls(spec.p)

    def probability(self, positions: np.ndarray, step: int, dt: float) -> np.ndarray:
        return np.full(len(np.atleast_2d(positions)), self.p)


class StillSpec(MotionSpec):
    """The target does not move."""


class StillMotion(TargetMotion):
    """A target that stays at its start (a test motion)."""

    Spec = StillSpec

    def step(self, dt: float, rng: np.random.Generator) -> None:
        pass


def _data(p: Any = 1.0) -> dict:
    data = shipped("sensing-temp").model_dump(mode="json")
    data["steps"] = 5
    data["zones"][0]["hazard"] = {"model": f"{__name__}:AlwaysHazard", "p": p}
    for target in data["targets"]:
        target["motion"] = {"type": f"{__name__}:StillMotion"}
    return data


def test_plugins_by_dotted_path_run_in_an_episode():
    scenario = parse_scenario(_data())
    result = run_episode(scenario, policy="vanilla")
    events = result["events"]
    assert (events["event"] == "attack").sum() > 0  # p = 1: the zone attacks at once
    targets = result["targets"]
    first = targets[targets.step == 0][["x", "y"]].to_numpy()
    last = targets[targets.step == 4][["x", "y"]].to_numpy()
    np.testing.assert_array_equal(first, last)


def test_plugin_spec_errors_name_the_field():
    with pytest.raises(ScenarioError) as err:
        parse_scenario(_data(p=2.0))
    assert any(p.startswith("zones.0.hazard.p: ") for p in err.value.problems), err.value
    data = _data()
    data["zones"][0]["hazard"] = {"model": "nowhere.module:Thing"}
    with pytest.raises(ScenarioError, match="zones.0.hazard: hazard model 'nowhere.module:Thing'"):
        parse_scenario(data)
