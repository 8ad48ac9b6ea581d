"""The route program (the default planner) on the six paper scenarios over ten seeds: the team
evades, comes back and keeps tracking (docs/calibration.md, "Evade, then come back").

"Last third" is the mean trace over the final third of an episode; "no-zone" is the same
scenario, policy and seed with ``zones: []``. A straggler is a robot that can still sense at
the end but is more than 1.5 m from every target. The targets (docs/calibration.md §6) that
are not met yet are strict xfails, so that meeting one is noticed.
"""

from __future__ import annotations

import pandas as pd
import pytest

from conftest import SCENARIOS
from resilient_tracking.experiments.in_memory import compare
from resilient_tracking.scenario import load_scenario
from resilient_tracking.scenario.overrides import overridden

pytestmark = pytest.mark.slow

SIX = ["sensing-temp", "sensing-perm", "comm-temp", "comm-perm", "combined-temp", "combined-perm"]
SEEDS = range(1, 11)


#: Scenarios whose files differ from their twin's only in their zones: without zones they are
#: one mission, so one zone-free run serves both.
TWINS = {"sensing-perm": "sensing-temp", "combined-perm": "combined-temp"}


def _zone_free(name: str) -> dict:
    scenario = overridden(load_scenario(SCENARIOS / f"{name}.yaml"), {"zones": []})
    return scenario.model_dump(mode="json", exclude={"name", "description"})


@pytest.fixture(scope="module")
def results() -> pd.DataFrame:
    paths = [SCENARIOS / f"{name}.yaml" for name in SIX]
    both = compare(paths, ["vanilla", "failure_aware"], seeds=SEEDS, jobs=2)
    alone = [SCENARIOS / f"{name}.yaml" for name in SIX if name not in TWINS]
    free = compare(alone, ["failure_aware"], seeds=SEEDS, jobs=2, overrides={"zones": []})
    for twin, same in TWINS.items():
        assert _zone_free(twin) == _zone_free(same)
        free = pd.concat([free, free[free.scenario == same].assign(scenario=twin)])
    return pd.concat([both.assign(zones=True), free.assign(zones=False)], ignore_index=True)


def ratio(results: pd.DataFrame, name: str) -> float:
    """Mean over seeds of the last-third trace ÷ the same seed's no-zone last-third trace."""
    rows = results[(results.scenario == name) & (results.policy == "failure_aware")]
    with_zones = rows[rows.zones].set_index("seed")["last_third_trace"]
    without = rows[~rows.zones].set_index("seed")["last_third_trace"]
    return float((with_zones / without).mean())


@pytest.mark.parametrize("name", SIX)
def test_failure_aware_beats_vanilla_in_trace_and_mse(results, name):
    rows = results[(results.scenario == name) & results.zones]
    mean = rows.groupby("policy")[["trace", "mse"]].mean()
    assert mean.loc["failure_aware", "trace"] < mean.loc["vanilla", "trace"], mean.to_dict()
    assert mean.loc["failure_aware", "mse"] < mean.loc["vanilla", "mse"], mean.to_dict()
    assert (rows.solver_failures == 0).all()


@pytest.mark.parametrize(
    ("name", "bound"),
    [
        ("comm-temp", 2.0),
        ("comm-perm", 4.0),
        ("sensing-temp", 2.0),
        ("sensing-perm", 4.0),
        pytest.param(
            "combined-temp",
            2.0,
            marks=pytest.mark.xfail(
                strict=True,
                reason="the comm zone lies on the targets' last leg (x = 1.6): the last third's "
                "trace is about 3 times the zone-free run's",
            ),
        ),
        pytest.param(
            "combined-perm",
            4.0,
            marks=pytest.mark.xfail(
                strict=True,
                reason="most seeds keep one sensing robot of three: the last third's trace is "
                "7 to 17 times the zone-free run's, far more in a seed that loses all three",
            ),
        ),
    ],
)
def test_the_team_comes_back_after_it_learns_a_zone(results, name, bound):
    assert ratio(results, name) <= bound


@pytest.mark.parametrize(
    "name",
    [
        "sensing-temp",
        "sensing-perm",
        "comm-temp",
        pytest.param(
            "comm-perm",
            marks=pytest.mark.xfail(
                strict=True,
                reason="the robot whose radio is destroyed circles its attacker to the end "
                "(Alg. 4), away from the targets, with its sensor working",
            ),
        ),
    ],
)
def test_no_robot_that_can_sense_is_left_behind(results, name):
    rows = results[(results.scenario == name) & (results.policy == "failure_aware")]
    assert rows.stragglers.sum() <= 0.1 * rows.sensing_end.sum(), rows[["seed", "stragglers"]]
