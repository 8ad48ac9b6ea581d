"""Swarm scale, side by side: leagues planned jointly (the paper's program) against sub-teams.

    python -m benchmarks.swarm            # 20×20, 40×20 and 64×32, cold and warm
    python -m benchmarks.swarm --quick    # 40×20 only, 30 steps
    python -m benchmarks.swarm --cases 40x20 --modes subteams   # a part of the table

Each run is a fresh process (so its memory and cache are its own) running the failure-aware
team on the case's scenario: first on an empty compiled-code cache (cold: what a new machine
pays, structures built and compiled before the first step), then again on the cache it filled
(warm). ``joint`` sets ``planner.subteams.above: 64`` (every league one problem, the code
before sub-teams); ``subteams`` is the default planner (at 20×20, ``subteams16`` splits the
20-robot league too, to compare its quality with the joint solve). Reported per run: the wall
time of the whole run, the time to build before the first step, the per-step planning time
(median, p99, steps over the 100 ms control period), solver failures, the time-mean trace, and
peak memory.
The joint 64×32 problem takes minutes per new structure, so it runs only ``JOINT_64_STEPS``.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from typing import Any

import numpy as np
import yaml

from benchmarks.common import SCENARIOS, machine, save, summary_ms, table

#: planner settings of each mode: every league jointly, the default, and 20-robot leagues split
MODES: dict[str, dict[str, Any]] = {
    "joint": {"planner.subteams.above": 64},
    "subteams": {},
    "subteams16": {"planner.subteams.above": 16},
}
#: the cases, by robots × targets
CASES = ("20x20", "40x20", "64x32")
#: how many steps the joint 64×32 team runs (a new 64-robot structure costs minutes)
JOINT_64_STEPS = 5


def scenario_data(case: str) -> dict[str, Any]:
    """The scenario mapping of a case: the shipped soak-20x20 and swarm-40x20, and 64×32 made
    from swarm-40x20 by adding 24 robots and 12 targets on circles."""
    if case == "20x20":
        data = yaml.safe_load((SCENARIOS / "soak-20x20.yaml").read_text())
        data["steps"] = 150
        return data
    data = yaml.safe_load((SCENARIOS / "swarm-40x20.yaml").read_text())
    if case == "40x20":
        return data
    data["name"] = "swarm-64x32"
    for k in range(24):
        data["robots"].append({"start": [-5.5 if k % 2 == 0 else 5.5, round(-7.6 + 0.66 * k, 2)]})
    for k in range(12):
        angle = 2 * np.pi * k / 12
        center = [round(6.5 * float(np.cos(angle)), 2), round(6.5 * float(np.sin(angle)), 2)]
        start = [round(center[0] + 1.0, 2), center[1]]
        speed = 0.12 if k % 2 == 0 else -0.12
        motion = {"type": "circle", "center": center, "angular_speed": speed}
        data["targets"].append({"start": start, "motion": motion})
    return data


def run_case(case: str, mode: str, steps: int | None) -> dict[str, Any]:
    """One run in this process (the child's job)."""
    from resilient_tracking.scenario.overrides import apply_overrides
    from resilient_tracking.sim.episode import EpisodeStepper

    data = scenario_data(case)
    if steps is not None:
        data["steps"] = steps
    changes = MODES[mode]
    scenario = apply_overrides(data, changes, f"{case} [{mode}]")
    started = time.perf_counter()
    stepper = EpisodeStepper(scenario, "failure_aware", scenario.seed)
    build_s = time.perf_counter() - started
    plan_ms: list[float] = []
    failures = 0
    for _ in range(scenario.steps):
        stepper.sense()
        out = stepper.act()
        plan_ms.append(out.decision.plan_ms)
        failures += sum(not p.success for p in out.decision.plans)
    team = stepper.result(time.perf_counter() - started).tables["team"]
    traces = team["trace"].to_numpy()
    return {
        "case": case,
        "mode": mode,
        "steps": scenario.steps,
        "wall_s": time.perf_counter() - started,
        "build_s": build_s,
        "plan_ms": summary_ms(plan_ms),
        "over_period": int(np.sum(np.asarray(plan_ms) > 100.0)),
        "solver_failures": failures,
        "mean_trace": float(np.mean(traces)),
        "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
    }


def in_child(case: str, mode: str, steps: int | None, cache: str) -> dict[str, Any]:
    """:func:`run_case` in a fresh process with its own compiled-code cache."""
    env = dict(os.environ, RTRACK_CACHE_DIR=cache)
    args = [sys.executable, "-m", "benchmarks.swarm", "--child", case, mode]
    if steps is not None:
        args += ["--steps", str(steps)]
    done = subprocess.run(args, env=env, capture_output=True, text=True, check=True)
    result: dict[str, Any] = json.loads(done.stdout.splitlines()[-1])
    return result


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="40×20 only, 30 steps")
    parser.add_argument("--cases", nargs="+", choices=CASES, help="only these cases")
    parser.add_argument("--modes", nargs="+", choices=("joint", "subteams"), help="only these")
    parser.add_argument("--child", nargs=2, metavar=("CASE", "MODE"), help=argparse.SUPPRESS)
    parser.add_argument("--steps", type=int, default=None, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        case, mode = args.child
        print(json.dumps(run_case(case, mode, args.steps)))
        return 0
    cases = args.cases or (["40x20"] if args.quick else list(CASES))
    runs = []
    for case in cases:
        for mode in args.modes or ("joint", "subteams"):
            steps = 30 if args.quick else None
            if case == "64x32" and mode == "joint":
                steps = JOINT_64_STEPS
            if case == "20x20" and mode == "subteams":
                mode = "subteams16"  # a 20-robot league is joint by default: split it too
            with tempfile.TemporaryDirectory(prefix="rtrack-swarm-") as cache:
                for start in ("cold", "warm"):
                    result = in_child(case, mode, steps, cache)
                    result["start"] = start
                    runs.append(result)
                    print(_row(result), flush=True)
    rows = [_row(r) for r in runs]
    header = [
        "case", "planner", "start", "steps", "run s", "build s", "plan median ms",
        "plan p99 ms", "steps > 100 ms", "failures", "mean trace", "peak MB",
    ]  # fmt: skip
    print(table(rows, header))
    for case in cases:
        joint = next((r for r in runs if r["case"] == case and r["mode"] == "joint"), None)
        splits = [r for r in runs if r["case"] == case and r["mode"] != "joint"]
        if joint is None or not splits:
            continue
        split = splits[-1]
        if joint["steps"] == split["steps"]:
            ratio = split["mean_trace"] / joint["mean_trace"]
            print(f"{case}: sub-team trace / joint trace = {ratio:.3f} (same steps and seed)")
    save(
        "swarm" if args.cases is None and args.modes is None else "swarm_part",
        {"machine": machine(), "runs": runs},
    )
    return 0


def _row(r: dict[str, Any]) -> list[Any]:
    p = r["plan_ms"]
    return [
        r["case"], r["mode"], r.get("start", ""), r["steps"], r["wall_s"], r["build_s"],
        p["median"], p["p99"], r["over_period"], r["solver_failures"], r["mean_trace"],
        r["peak_mb"],
    ]  # fmt: skip


if __name__ == "__main__":
    sys.exit(main())
