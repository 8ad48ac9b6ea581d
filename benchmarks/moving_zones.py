"""Planning time with moving zones known, side by side with the same zones standing still.

    python -m benchmarks.moving_zones            # about a minute
    python -m benchmarks.moving_zones --quick    # a smoke run

The ``beyond`` team (zone motion tracked, planning against each zone predicted to
the planned step) runs closed-loop episodes with every zone known from the start (``known``),
so each step plans against every zone:

* 3×3: ``moving-sensing`` and ``moving-comm-perm`` as shipped, and the same with the zone's
  ``motion`` removed;
* 20×20: ``soak-20x20`` with each zone circling 0.8 m around its prior mean (0.1 rad/s), and as
  shipped (zones standing still).

Each case first runs once untimed, so that the problems (and the reduced variants a run
meets) are built before the clock starts. Printed per case: median, p99 and largest of the
runs' ``timing`` table (``plan_ms``: the wall time of the team's planning per step), moving
and static, and the ratios.
"""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np

from benchmarks.common import machine, save, table
from resilient_tracking import builtin_scenarios
from resilient_tracking.scenario import Scenario, load_scenario
from resilient_tracking.scenario.overrides import every_zone_known, overridden
from resilient_tracking.sim.episode import run_episode


def cases(quick: bool) -> list[tuple[str, Scenario, Scenario]]:
    """(label, moving, static) pairs, the extended team with every zone known."""
    out = []
    for name in ("moving-sensing", "moving-comm-perm"):
        moving = every_zone_known(load_scenario(builtin_scenarios.path(name)).with_team("beyond"))
        static = overridden(moving, {f"zones.{i}.motion": None for i in range(len(moving.zones))})
        out.append((f"3×3 {name}", moving, static))
    soak = load_scenario(builtin_scenarios.path("soak-20x20")).with_overrides(
        steps=60 if quick else 300
    )
    static = every_zone_known(soak.with_team("beyond"))
    circling = {
        f"zones.{i}.motion": {
            "type": "circle",
            "center": [zone.mu[0] + 0.8, zone.mu[1]],
            "angular_speed": 0.1,
        }
        for i, zone in enumerate(static.zones)
    }
    out.append(("20×20 soak-20x20", overridden(static, circling), static))
    return out


def plan_ms(scenario: Scenario, seeds: list[int]) -> np.ndarray:
    """Every step's planning wall time (ms) over ``seeds``."""
    return np.concatenate(
        [run_episode(scenario, seed=s).tables["timing"]["plan_ms"].to_numpy() for s in seeds]
    )


def main(argv: list[str] | None = None) -> dict[str, Any]:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args(argv)
    rows, results = [], {}
    for label, moving, static in cases(args.quick):
        seeds = [1] if args.quick or label.startswith("20") else [1, 2, 3]
        for scenario in (moving, static):  # untimed: every problem variant built once
            run_episode(scenario, seed=seeds[0])
        times = {"moving": plan_ms(moving, seeds), "static": plan_ms(static, seeds)}
        stats = {
            k: (float(np.median(v)), float(np.percentile(v, 99)), float(v.max()))
            for k, v in times.items()
        }
        (med_m, p99_m, max_m), (med_s, p99_s, max_s) = stats["moving"], stats["static"]
        rows.append([label, med_m, med_s, med_m / med_s, p99_m, p99_s, p99_m / p99_s, max_m, max_s])
        results[label] = {"moving_ms": stats["moving"], "static_ms": stats["static"]}
    header = ["case", "median moving", "median static", "ratio", "p99 moving", "p99 static"]
    print(table(rows, [*header, "ratio", "max moving", "max static"]))
    path = save(
        "moving_zones_quick" if args.quick else "moving_zones",
        {"machine": machine(), "plan_ms": results},
    )
    print(f"\nsaved {path}")
    return results


if __name__ == "__main__":
    main()
