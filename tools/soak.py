"""Soak run (docs/reliability.md): a long episode, memory at checkpoints, NaN check.

    python tools/soak.py                                   # soak-20x20, 2000 steps, 500/2000
    python tools/soak.py scenarios/soak-20x20.yaml --steps 100 --checkpoints 50 100

Prints peak RSS and the traced Python heap (recorded rows vs. everything else) at each
checkpoint, the events by kind and any table cell that is NaN/inf. Exit status 1 when a table
holds a non-finite number or the non-record heap grew by more than --max-growth-mb.
"""

from __future__ import annotations

import argparse
import logging
import sys
from pathlib import Path

from resilient_tracking.scenario import ScenarioError, load_scenario
from resilient_tracking.sim.soak import soak

ROOT = Path(__file__).resolve().parents[1]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenario", nargs="?", default=str(ROOT / "scenarios/soak-20x20.yaml"))
    parser.add_argument("--steps", type=int, default=None)
    parser.add_argument("--checkpoints", type=int, nargs="+", default=[500, 2000])
    parser.add_argument("--policy", default=None)
    parser.add_argument("--seed", type=int, default=None)
    parser.add_argument("--max-growth-mb", type=float, default=5.0)
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    try:
        scenario = load_scenario(args.scenario)
        report = soak(scenario, args.steps, tuple(args.checkpoints), args.policy, args.seed)
    except ScenarioError as err:
        print(f"error: {err}", file=sys.stderr)
        return 1
    print(
        f"{report.scenario} [{report.policy}] seed {report.seed}: {report.steps} steps "
        f"in {report.wall_s:.0f} s"
    )
    print(
        f"{'step':>6} {'RSS MB':>8} {'peak RSS MB':>12} {'heap MB':>9} {'records MB':>11} "
        f"{'other MB':>9}"
    )
    for c in report.checkpoints:
        print(
            f"{c.step:>6} {c.rss_mb:>8.1f} {c.peak_rss_mb:>12.1f} {c.traced_mb:>9.1f} "
            f"{c.records_mb:>11.1f} {c.other_mb:>9.1f}"
        )
    growth = report.other_growth_mb()
    print(f"non-record heap growth, first to last checkpoint: {growth:+.2f} MB")
    print("events: " + ", ".join(f"{k} {v}" for k, v in sorted(report.events.items())))
    print(f"non-finite table cells: {report.non_finite or 'none'}")
    return 0 if report.finite and growth <= args.max_growth_mb else 1


if __name__ == "__main__":
    sys.exit(main())
