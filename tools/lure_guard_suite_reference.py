"""Reference measurement: what the lure guard costs where targets are not all lures
(docs/adversarial.md, *The lure guard*).

Runs the team ``route`` (the paper's method with the EKF), the same with the adaptive
estimator, and that with the lure guard, on the stored adversarial suite, whose targets evade,
lure or keep to their lanes, and prints each team's mean trace and MSE and the share of
scenarios in which it has the lower trace, and the lower MSE, than ``route``: the numbers that
decided whether the guard joins the adaptive estimator (the suite's target is 85 %).

    python tools/lure_guard_suite_reference.py            # the 30 scenarios, seed 1 each
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

import numpy as np
from joblib import Parallel, delayed

from resilient_tracking.experiments.catalog import ADVERSARIAL_SUITE_SIZE
from resilient_tracking.experiments.generator import stored_adversarial_suite
from resilient_tracking.scenario.overrides import overridden
from resilient_tracking.sim.episode import run_episode

_ADAPTIVE = {"team": "route", "estimator.type": "adaptive"}
TEAMS: dict[str, dict[str, Any]] = {
    "route": {"team": "route"},
    "adaptive": _ADAPTIVE,
    "adaptive+lure": _ADAPTIVE | {"guards.lure.enabled": True},
}


def run(index: int, team: str, seed: int) -> tuple[float, float]:
    """The mean trace and MSE of one episode of suite scenario ``index``."""
    scenario = overridden(stored_adversarial_suite()[index], TEAMS[team])
    tables = run_episode(scenario, "failure_aware", seed)
    return float(tables["team"].trace.mean()), float(tables["team"].mse.mean())


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--scenarios", type=int, default=ADVERSARIAL_SUITE_SIZE)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args(argv)
    results = {
        team: np.array(
            Parallel(n_jobs=args.jobs)(
                delayed(run)(i, team, args.seed) for i in range(args.scenarios)
            )
        )
        for team in TEAMS
    }
    default = results["route"]
    n = args.scenarios
    print("| team | mean trace | mean MSE | lower trace than the default team | lower MSE |")
    print("|---|---|---|---|---|")
    for team, r in results.items():
        wins = "–" if team == "route" else f"{(r[:, 0] < default[:, 0]).sum()}/{n}"
        mse_wins = "–" if team == "route" else f"{(r[:, 1] < default[:, 1]).sum()}/{n}"
        print(f"| {team} | {r[:, 0].mean():.4f} | {r[:, 1].mean():.4f} | {wins} | {mse_wins} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
