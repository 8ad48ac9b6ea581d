"""Reference measurement for the paper's claims that do not hold here (docs/paper-map.md,
*Known gaps*): the same experiment's arms, each run as committed and again with every zone on
the team's map from the start (a hazard map: a reference no team that must find its zones can
reach).

A claim the zone-knowing arms still fail is not failing because the team learns its zones too
slowly: the scenario's geometry, or the method's own settings, decide it.

    python tools/claim_gap_reference.py bench-complex bench-complex-route --seeds 1-5
    python tools/claim_gap_reference.py comm-temp --seeds 1-10
    python tools/claim_gap_reference.py comm-temp-route --seeds 1-10 --team default

``--team`` runs the failure-aware arms with another named team (`rtrack teams`); only on the
route program's copies, since the one-step experiments set the ``paper`` team's settings in
full.

Prints, per experiment, arm and map, the mean over seeds of the MSE and trace, the share of
seeds that end with a sensing robot, and the sensors and radios lost per run to zones the robot
knew and did not know (experiments/known_zones.py).
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

import pandas as pd
from joblib import Parallel, delayed

from resilient_tracking.cli.common import MAX_SEEDS
from resilient_tracking.experiments.arms import Task
from resilient_tracking.experiments.catalog import catalog, tasks
from resilient_tracking.experiments.comparison import parse_seeds
from resilient_tracking.experiments.summary import summarise_run
from resilient_tracking.runs.reading import run_data
from resilient_tracking.scenario.overrides import every_zone_known
from resilient_tracking.scenario.teams import TEAMS
from resilient_tracking.sim.episode import run_episode

MAPS = ("found", "known")
COLUMNS = ("mse", "trace", "sensing_end", "losses_known", "losses_unknown")


def run(task: Task, known: bool, team: str | None) -> dict[str, Any]:
    """One arm's episode, its zones found as the paper's team finds them or known from the
    start, the failure-aware arms run by ``team`` if given; its summary row reduced to the
    printed columns."""
    scenario = task.scenario
    if team and task.variant.policy == "failure_aware":
        scenario = scenario.with_team(team)
    scenario = every_zone_known(scenario) if known else scenario
    row = summarise_run(run_data(run_episode(scenario, task.variant.policy, task.seed), ""))
    return {
        "mse": row["mse"],
        "trace": row["trace"],
        "sensing_end": float(row["sensing_end"] >= 1),
        "losses_known": row["losses_known_permanent"] + row["losses_known_temporary"],
        "losses_unknown": row["losses_unknown_permanent"] + row["losses_unknown_temporary"],
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("experiments", nargs="+", help="experiment names (a wrong one lists them)")
    parser.add_argument("--seeds", default="1-10", help="a range, e.g. 1-10")
    parser.add_argument("--team", choices=TEAMS, help="a named team for the failure-aware arms")
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args(argv)
    known = catalog()
    unknown = [name for name in args.experiments if name not in known]
    if unknown:
        parser.error(f"no experiment {', '.join(unknown)}; choose from {', '.join(known)}")
    if args.team and any(known[name].program == "one_step" for name in args.experiments):
        parser.error("--team: the one-step experiments run the paper team's settings in full")
    seeds = parse_seeds(args.seeds, MAX_SEEDS)
    cases = [
        (task, zone_map)
        for name in args.experiments
        for seed in seeds
        for task in tasks(known[name], 1, first_seed=seed)
        for zone_map in MAPS
    ]
    rows = Parallel(n_jobs=args.jobs)(delayed(run)(t, m == "known", args.team) for t, m in cases)
    frame = pd.DataFrame(
        [
            {"experiment": t.experiment, "arm": t.variant.label, "map": m, "seed": t.seed, **row}
            for (t, m), row in zip(cases, rows, strict=True)
        ]
    )
    means = frame.groupby(["experiment", "arm", "map"], sort=False)[list(COLUMNS)].mean()
    with pd.option_context("display.width", 200):
        print(means.to_string(float_format=lambda v: f"{v:.4g}"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
