"""A guard from outside the package, one class in one file (this one): configured by dotted
path or by the name it registers, validated by its own Params, run in an episode."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from pydantic import Field

from resilient_tracking.belief.estimate import TargetEstimate
from resilient_tracking.events import Event
from resilient_tracking.observation import TeamObservation
from resilient_tracking.planning.layout import sensing_row, sensing_table
from resilient_tracking.policies.guards import GUARDS, Guard, GuardParams, register_guard
from resilient_tracking.scenario import ScenarioError, parse_scenario
from resilient_tracking.sim.episode import run_episode


class TargetStandoffParams(GuardParams):
    """Keep ``distance`` from every target."""

    distance: float = Field(1.2, gt=0, le=10, description="Stand-off from each target (m).")


@register_guard("target_standoff")
class TargetStandoffGuard(Guard):
    """An eq. 7c disc of radius ``distance`` around each target's predicted position."""

    name = "target_standoff"
    Params = TargetStandoffParams
    params: TargetStandoffParams

    def league_rows(
        self,
        step: int,
        robots: list[int],
        estimate: TargetEstimate,
        predicted: TargetEstimate,
        zone_rows: np.ndarray,
        obs: TeamObservation,
        beta1: float,
    ) -> tuple[np.ndarray, list[Event]]:
        rows = [
            sensing_row(mean[:2], cov[:2, :2], r_safe=self.params.distance, beta=beta1)
            for mean, cov in zip(predicted.mean, predicted.cov, strict=True)
        ]
        return sensing_table(rows), []


def _scenario(guards: dict[str, Any]):
    """Two robots start next to a slow target, which they would close in on."""
    return parse_scenario(
        {
            "name": "standoff",
            "seed": 3,
            "steps": 80,
            "workspace": {"xmin": -4, "xmax": 4, "ymin": -3, "ymax": 3},
            "robots": [{"start": [-1.5, 0.6]}, {"start": [-1.5, -0.6]}],
            "targets": [
                {
                    "start": [-1.0, 0.0],
                    "motion": {"type": "waypoints", "points": [[0.5, 0.0]], "speed": 0.2},
                }
            ],
            "guards": guards,
        }
    )


def _closest(result: Any, after: int) -> float:
    robots, target = result["robots"], result["targets"].set_index("step")
    late = robots[robots.step >= after]
    gaps = np.hypot(
        late.x.to_numpy() - target.loc[late.step, "x"].to_numpy(),
        late.y.to_numpy() - target.loc[late.step, "y"].to_numpy(),
    )
    return float(gaps.min())


@pytest.mark.parametrize("name", [f"{__name__}:TargetStandoffGuard", "target_standoff"])
def test_a_guard_from_outside_the_package_adds_its_rows(name):
    guarded = run_episode(_scenario({name: {"enabled": True}}), seed=1)
    plain = run_episode(_scenario({}), seed=1)
    assert _closest(guarded, after=40) > 0.8 * TargetStandoffParams().distance
    assert _closest(plain, after=40) < 0.5 * TargetStandoffParams().distance


def test_a_registered_guard_is_listed_and_off_until_enabled():
    assert "target_standoff" in GUARDS.names()
    scenario = _scenario({})
    assert "target_standoff" not in scenario.guards.enabled()
    assert "comm_hazard" in scenario.guards.enabled()  # a built-in on by default


def test_a_guards_settings_are_checked_by_its_params_naming_the_field():
    with pytest.raises(ScenarioError) as err:
        _scenario({"target_standoff": {"enabled": True, "distance": -1.0}})
    assert any(p.startswith("guards.target_standoff.distance:") for p in err.value.problems)
    with pytest.raises(ScenarioError) as err:
        _scenario({"no_such_guard": {"enabled": True}})
    assert any(p.startswith("guards.no_such_guard:") for p in err.value.problems)
    with pytest.raises(ScenarioError) as err:
        _scenario({"lure": {"enabled": "yes"}})
    assert any(p.startswith("guards.lure.enabled:") for p in err.value.problems)
