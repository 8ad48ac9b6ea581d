"""Soak run (docs/reliability.md §4): a long episode, memory sampled along it, NaN check.

    python tools/soak.py                                   # soak-20x20, 2000 steps
    python tools/soak.py scenarios/soak-20x20.yaml --steps 100 --checkpoints 50 100

Prints the resident memory (now and peak) and the cache of league problems at each
checkpoint; the leak (memory gained beyond the recorded tables over stretches in which no
problem or solver was built); the events by kind and any table cell that is NaN/inf. Exit
status 1 when a table holds a non-finite number or the leak exceeds --max-leak-mb.
"""

from __future__ import annotations

import argparse
import logging
import sys

from resilient_tracking import builtin_scenarios
from resilient_tracking.scenario import ScenarioError, load_scenario
from resilient_tracking.sim.soak import soak


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenario", nargs="?", default=str(builtin_scenarios.path("soak-20x20")))
    parser.add_argument("--steps", type=int, default=None)
    parser.add_argument("--checkpoints", type=int, nargs="+", default=[500, 2000])
    parser.add_argument("--policy", default=None)
    parser.add_argument("--seed", type=int, default=None)
    parser.add_argument("--sample-every", type=int, default=50)
    parser.add_argument("--max-leak-mb", type=float, default=5.0)
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    try:
        scenario = load_scenario(args.scenario)
        report = soak(
            scenario,
            args.steps,
            tuple(args.checkpoints),
            args.policy,
            args.seed,
            args.sample_every,
        )
    except ScenarioError as err:
        print(f"error: {err}", file=sys.stderr)
        return 1
    print(
        f"{report.scenario} [{report.policy}] seed {report.seed}: {report.steps} steps "
        f"in {report.wall_s:.0f} s"
    )
    print(
        f"{'step':>6} {'RSS MB':>8} {'peak RSS MB':>12} {'problems cached':>16} "
        f"{'cache weight':>13} {'problems + solvers built':>25}"
    )
    for c in report.at_checkpoints():
        print(
            f"{c.step:>6} {c.rss_mb:>8.1f} {c.peak_rss_mb:>12.1f} {c.cached:>16} "
            f"{c.cache_weight:>13.3g} {c.builds:>25}"
        )
    leak = report.leak_mb()
    print(f"cache budget: {report.cache_budget:.3g} instructions")
    print(f"recorded tables: {report.record_bytes_per_step / 1024:.2f} kB per step")
    print(f"RSS growth, first to last checkpoint: {report.growth_mb():+.1f} MB")
    print(
        f"leak (growth beyond the tables while nothing was built, sampled every "
        f"{args.sample_every} steps): "
        f"{leak:.2f} MB"
    )
    print("events: " + ", ".join(f"{k} {v}" for k, v in sorted(report.events.items())))
    print(f"non-finite table cells: {report.non_finite or 'none'}")
    return 0 if report.finite and leak <= args.max_leak_mb else 1


if __name__ == "__main__":
    sys.exit(main())
