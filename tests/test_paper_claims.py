"""The paper's headline claim on the six shipped scenarios over ten seeds, as in docs/model.md §8,
with the paper's method as written: its one-step planner program and its constraint set (the
``paper`` team's settings, as ``rtrack reproduce`` runs the paper's experiments; the route
program's claims with the default team: test_route_program.py).

Ten, not five: in `comm-perm` one seed of five (seed 2) lets vanilla's best cut-off robot
report a low trace with an MSE three times the failure-aware team's, which decides a
five-seed mean (0.0509 against 0.0500); over ten seeds the failure-aware team is lower in 8.
"""

from __future__ import annotations

import pytest

from helpers import SCENARIOS
from resilient_tracking.experiments.in_memory import compare
from resilient_tracking.scenario.teams import get_team

pytestmark = pytest.mark.slow

SIX = ["sensing-temp", "sensing-perm", "comm-temp", "comm-perm", "combined-temp", "combined-perm"]


@pytest.fixture(scope="module")
def results():
    paths = [SCENARIOS / f"{name}.yaml" for name in SIX]
    return compare(
        paths,
        ["vanilla", "failure_aware"],
        seeds=range(1, 11),
        jobs=2,
        overrides=get_team("paper").settings,
    )


@pytest.mark.parametrize("name", SIX)
def test_failure_aware_has_lower_time_averaged_trace_than_vanilla(results, name):
    rows = results[results.scenario == name]
    mean = rows.groupby("policy")["trace"].mean()
    assert mean["failure_aware"] < mean["vanilla"], mean.to_dict()
    assert (rows.solver_failures == 0).all()


@pytest.mark.parametrize("name", ["sensing-temp", "sensing-perm", "combined-temp", "combined-perm"])
def test_vanilla_collapses_where_sensing_zones_lie_on_the_path(results, name):
    """Paper Figs. 4, 5, 10, 11: the vanilla trace explodes, the adaptive one stays bounded."""
    rows = results[results.scenario == name].groupby("policy")
    final = rows["final_trace"].median()
    assert final["vanilla"] > 100 * final["failure_aware"]
    assert rows["mse"].mean()["failure_aware"] < rows["mse"].mean()["vanilla"]


def test_in_comm_perm_the_team_that_reads_the_circle_loses_fewer_radios(results):
    """Paper Fig. 6: teammates infer the jammer from the circling robot and keep clear of it,
    while vanilla robots follow their targets past it and are cut off one after another."""
    rows = results[results.scenario == "comm-perm"].groupby("policy")
    attacked = rows["robots_attacked"].mean()
    assert attacked["failure_aware"] < attacked["vanilla"] - 0.5, attacked.to_dict()
    assert rows["zones_inferred"].mean()["failure_aware"] >= 0.6
