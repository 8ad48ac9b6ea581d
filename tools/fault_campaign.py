"""Solver-fault campaign (docs/reliability.md): shipped scenarios under injected solver faults.

    python tools/fault_campaign.py                       # 6 scenarios × 2 policies × 3 seeds
    python tools/fault_campaign.py --probability 0.5 --seeds 0 1 --steps 300

Each episode runs with a seeded FaultInjector (all four kinds, every rung). Printed per episode
and in total: faults injected by kind, fallbacks (retries that succeeded, safe escapes, safe
holds), and two checks made from the saved tables alone: no non-finite cell, and no robot that
took the safe action ended the step closer to a zone its team knew. Exit status 1 if a check
failed or an episode raised.
"""

from __future__ import annotations

import argparse
import logging
import sys

import numpy as np
import pandas as pd
from resilient_tracking.sim.records import EpisodeResult

from resilient_tracking import builtin_scenarios
from resilient_tracking.experiments.catalog import SIX
from resilient_tracking.planning.faults import FAULT_KINDS, FaultInjector
from resilient_tracking.scenario import load_scenario
from resilient_tracking.sim.episode import run_episode
from resilient_tracking.sim.soak import non_finite_cells


def closer_to_known_zone(result: EpisodeResult) -> int:
    """Safe-action steps after which the robot was closer to a zone it knew (should be 0)."""
    events, robots, knowledge = result["events"], result["robots"], result["knowledge"]
    safe = events[(events["event"] == "solver_fallback") & (events["fallback"] == "safe")]
    pos = robots.set_index(["step", "robot"])[["x", "y"]]
    bad = 0
    for step, robot in safe[["step", "robot"]].itertuples(index=False):
        if (step + 1, robot) not in pos.index:
            continue  # last step: no position after it
        before = pos.loc[(step, robot)].to_numpy(dtype=float)
        after = pos.loc[(step + 1, robot)].to_numpy(dtype=float)
        rows = knowledge[(knowledge["robot"] == robot) & (knowledge["step"] <= step)]
        for mu in rows[["x", "y"]].drop_duplicates().to_numpy(dtype=float):
            bad += np.linalg.norm(after - mu) < np.linalg.norm(before - mu) - 1e-9
    return bad


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenarios", nargs="+", default=list(SIX))
    parser.add_argument("--policies", nargs="+", default=["failure_aware", "vanilla"])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--probability", type=float, default=0.3)
    parser.add_argument("--steps", type=int, default=300)
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.ERROR)
    failed = 0
    rows = []
    for name in args.scenarios:
        scenario = load_scenario(builtin_scenarios.path(name)).with_overrides(steps=args.steps)
        for policy in args.policies:
            for seed in args.seeds:
                injector = FaultInjector(args.probability, seed=seed)
                try:
                    result = run_episode(scenario, policy=policy, seed=seed, fault_hook=injector)
                except Exception as err:  # a campaign reports, it does not stop
                    print(f"{name} {policy} seed {seed}: RAISED {type(err).__name__}: {err}")
                    failed += 1
                    continue
                events = result["events"]
                fb = events[events["event"] == "solver_fallback"]
                row = {
                    "scenario": name,
                    "policy": policy,
                    "seed": seed,
                    **{k: v for k, v in injector.summary().items()},
                    "retry_ok": int((fb["fallback"] != "safe").sum()),
                    "safe_escape": int((fb["action"] == "escape").sum()),
                    "safe_hold": int((fb["action"] == "hold").sum()),
                    "non_finite": sum(non_finite_cells(result).values()),
                    "closer": closer_to_known_zone(result),
                }
                rows.append(row)
                failed += row["non_finite"] > 0 or row["closer"] > 0
    table = pd.DataFrame(rows)
    with pd.option_context("display.width", 200, "display.max_rows", 200):
        print(table.to_string(index=False))
    numeric = [
        *FAULT_KINDS,
        "attempts",
        "retry_ok",
        "safe_escape",
        "safe_hold",
        "non_finite",
        "closer",
    ]
    total = {k: int(table[k].sum()) for k in numeric}
    print(f"episodes: {len(rows)} completed, {failed} with a failed check or exception")
    print("total: " + ", ".join(f"{k} {total[k]}" for k in numeric))
    print(f"faults injected: {sum(total[k] for k in FAULT_KINDS)}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
