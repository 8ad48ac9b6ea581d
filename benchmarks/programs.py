"""The route program against the paper's one-step program, side by side in one run.

    python -m benchmarks.programs            # sensing-temp (3×3) and 300 steps of soak-20x20
    python -m benchmarks.programs --quick    # 60 steps each

Both programs plan the same episode (same scenario and seed, failure-aware policy), once
untimed to build and compile every league structure it meets, then timed. Reported
per program: planning time per league solve (wall clock of the solver ladder, from
``timing.parquet``: median, p99, max), the episode's time per step outside planning (world,
belief, the route program's routes and goals), solver failures, how many league structures
the timed run had to (re)build because the bounded problem cache no longer held them, the
steps whose planning took over 100 ms, and the ratio route ÷ one-step.
The control period is ``dt`` = 100 ms.
"""

from __future__ import annotations

import argparse
import time
from typing import Any

import numpy as np

from benchmarks.common import SCENARIOS, machine, save, summary_ms, table
from resilient_tracking.planning.nlp_cache import solver_builds, wait_for_compilers
from resilient_tracking.scenario import load_scenario
from resilient_tracking.sim.episode import run_episode

CASES = {"3x3": ("sensing-temp", 300), "20x20": ("soak-20x20", 300)}
PROGRAMS = ("one_step", "route")


def timed(name: str, steps: int, program: str, seed: int = 1) -> dict[str, Any]:
    scenario = load_scenario(SCENARIOS / f"{name}.yaml")
    data = scenario.model_dump(mode="python")
    data["steps"] = steps
    data["planner"]["program"] = program
    scenario = type(scenario).model_validate(data)
    # an untimed first run builds (and compiles) every structure the timed run will meet
    run_episode(scenario, policy="failure_aware", seed=seed)
    wait_for_compilers()
    builds = solver_builds()
    start = time.perf_counter()
    result = run_episode(scenario, policy="failure_aware", seed=seed)
    wall_ms = (time.perf_counter() - start) * 1e3
    team = result["team"]
    plan = result["timing"]["plan_ms"].to_numpy()
    solves = np.maximum(team["n_solves"].to_numpy(), 1)
    return {
        "per_solve": summary_ms(plan / solves),
        "outside_planning_ms_per_step": float((wall_ms - plan.sum()) / steps),
        "solver_failures": int(team["n_solver_failures"].sum()),
        # league structures (re)built inside the timed run: the problem cache is bounded, so
        # a run meeting more large structures than it holds rebuilds them (seconds each)
        "builds_in_timed_run": solver_builds() - builds,
        "slow_steps_over_100ms": int((plan > 100).sum()),
    }


def main(argv: list[str] | None = None) -> dict[str, Any]:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="60 steps per case")
    args = parser.parse_args(argv)
    results: dict[str, Any] = {"machine": machine(), "cases": {}}
    rows = []
    for label, (name, steps) in CASES.items():
        steps = 60 if args.quick else steps
        found = {p: timed(name, steps, p) for p in PROGRAMS}
        results["cases"][label] = found
        one, route = found["one_step"], found["route"]
        rows.append(
            [
                f"{label} ({name}, {steps} steps)",
                one["per_solve"]["median"],
                route["per_solve"]["median"],
                route["per_solve"]["median"] / one["per_solve"]["median"],
                one["per_solve"]["p99"],
                route["per_solve"]["p99"],
                one["outside_planning_ms_per_step"],
                route["outside_planning_ms_per_step"],
                f"{one['solver_failures']} / {route['solver_failures']}",
                f"{one['builds_in_timed_run']} / {route['builds_in_timed_run']}",
                f"{one['slow_steps_over_100ms']} / {route['slow_steps_over_100ms']}",
            ]
        )
    header = [
        "case",
        "one-step median (ms)",
        "route median (ms)",
        "ratio",
        "one-step p99",
        "route p99",
        "one-step outside planning (ms/step)",
        "route outside planning",
        "solver failures one-step / route",
        "solvers created in the timed run",
        "steps planning > 100 ms",
    ]
    print(table(rows, header))
    if not args.quick:
        print(f"saved {save('programs', results)}")
    return results


if __name__ == "__main__":
    main()
