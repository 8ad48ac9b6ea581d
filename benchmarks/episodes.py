"""Episode throughput and tracking quality: the SQP ladder against IPOPT only, one run.

    python -m benchmarks.episodes            # throughput + quality over seeds 1..5
    python -m benchmarks.episodes --quick    # seed 1 only

Throughput: each shipped scenario with its own policy, run in this process one after the other
(after a warm-up run that fills the compiled-code cache), wall time including the world, the
EKF, planning and logging; steps per second and real-time factor (simulated / wall seconds).
The target case is the 300-step ``sensing-temp`` failure-aware episode (median of 5 runs).
Quality: the time-averaged trace ``Σ_j tr P_j`` of each scenario over the seeds, ladder vs
IPOPT only (same scenario, same seeds, only ``planner.solver`` differs).
"""

from __future__ import annotations

import argparse
import time
from typing import Any

import numpy as np
from joblib import Parallel, delayed

from benchmarks.common import SCENARIOS, SHIPPED, machine, save, table
from resilient_tracking import team as team_module
from resilient_tracking.planning.nlp_cache import wait_for_compilers
from resilient_tracking.planning.planner import LeaguePlanner
from resilient_tracking.scenario import Scenario, load_scenario
from resilient_tracking.sim.episode import run_episode


def scenario(name: str, solver: str) -> Scenario:
    return load_scenario(SCENARIOS / f"{name}.yaml").with_overrides(planner={"solver": solver})


#: A third arm for the quality comparison: IPOPT only with a tighter tolerance (1e-9 instead
#: of 1e-8). Nobody would call that a change of quality, so the differences it makes show how
#: far a mere change of solver path moves these chaotic closed loops.
TIGHT = "ipopt-tol1e-9"


class TightIpoptPlanner(LeaguePlanner):
    """The league planner with IPOPT's tolerance at 1e-9 (the scenario picks IPOPT only)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **{**kwargs, "options": {"ipopt": {"tol": 1e-9}}})


def timed(name: str, solver: str, seed: int) -> dict[str, Any]:
    if solver == TIGHT:
        team_module.LeaguePlanner = TightIpoptPlanner  # type: ignore[misc]
        s = scenario(name, "ipopt")
    else:
        team_module.LeaguePlanner = LeaguePlanner  # type: ignore[misc]
        s = scenario(name, solver)
    start, cpu = time.perf_counter(), time.process_time()
    result = run_episode(s, seed=seed)
    wall, cpu = time.perf_counter() - start, time.process_time() - cpu
    team_module.LeaguePlanner = LeaguePlanner  # type: ignore[misc]
    team = result["team"]
    events = result["events"]
    return {
        "scenario": name,
        "solver": solver,
        "seed": seed,
        "steps": s.steps,
        "wall_s": wall,
        "cpu_s": cpu,
        "plan_s": float(result["timing"]["plan_ms"].sum() / 1e3),
        "trace_mean": float(team["trace"].mean()),
        "mse_mean": float(team["mse"].mean()),
        "fallbacks": int((events["event"] == "solver_fallback").sum()),
        "safe_actions": int(team["n_solver_failures"].sum()),
        "sim_s": s.steps * s.dt,
    }


def throughput(repeats: int) -> dict[str, Any]:
    rows = []
    for name in SHIPPED:
        for solver in ("ladder", "ipopt"):
            timed(name, solver, 1)  # warm-up: imports, and the compiled-code cache
            wait_for_compilers()
            runs = [timed(name, solver, 1) for _ in range(repeats)]
            best = sorted(runs, key=lambda r: r["wall_s"])[len(runs) // 2]  # the median run
            rows.append(best | {"wall_runs_s": [r["wall_s"] for r in runs]})
    target = [timed("sensing-temp", "ladder", 1) for _ in range(5)]
    return {
        "rows": rows,
        "sensing_temp_300_steps_wall_s": [r["wall_s"] for r in target],
        "sensing_temp_300_steps_cpu_s": [r["cpu_s"] for r in target],
    }


def quality(seeds: list[int], jobs: int) -> list[dict[str, Any]]:
    tasks = [(n, s, k) for n in SHIPPED for s in ("ladder", "ipopt", TIGHT) for k in seeds]
    return list(Parallel(n_jobs=jobs)(delayed(timed)(*t) for t in tasks))


def report(data: dict[str, Any]) -> str:
    out = []
    rows = []
    for r in data["throughput"]["rows"]:
        rows.append(
            [
                r["scenario"],
                r["solver"],
                r["steps"],
                r["wall_s"],
                r["cpu_s"],
                r["steps"] / r["wall_s"],
                r["sim_s"] / r["wall_s"],
                r["plan_s"] / r["wall_s"],
                r["fallbacks"],
            ]
        )
    out.append(
        table(
            rows,
            [
                "scenario",
                "solver",
                "steps",
                "wall s",
                "CPU s",
                "steps/s",
                "real-time factor",
                "planning share",
                "fallback events",
            ],
        )
    )
    target = data["throughput"]["sensing_temp_300_steps_wall_s"]
    cpu = data["throughput"]["sensing_temp_300_steps_cpu_s"]
    out.append(
        f"sensing-temp, failure_aware, 300 steps, ladder: median wall {np.median(target):.3f} s "
        f"over {len(target)} runs (min {min(target):.3f}, max {max(target):.3f}; "
        f"CPU median {np.median(cpu):.3f} s); real-time factor {30.0 / np.median(target):.0f}"
    )
    q = data["quality"]
    arms = ("ladder", "ipopt", TIGHT)
    rows = []
    totals: dict[str, list[float]] = {arm: [] for arm in arms}
    for name in SHIPPED:
        per = {
            arm: np.array(
                [r["trace_mean"] for r in q if r["scenario"] == name and r["solver"] == arm]
            )
            for arm in arms
        }
        for arm in arms:
            totals[arm].extend(per[arm])
        se = {
            arm: per[arm].std(ddof=1) / np.sqrt(len(per[arm])) if len(per[arm]) > 1 else np.nan
            for arm in arms
        }
        fb = sum(r["fallbacks"] for r in q if r["scenario"] == name and r["solver"] == "ladder")
        rows.append(
            [
                name,
                f"{per['ladder'].mean():.4g} ± {se['ladder']:.2g}",
                f"{per['ipopt'].mean():.4g} ± {se['ipopt']:.2g}",
                100 * (per["ladder"].mean() / per["ipopt"].mean() - 1),
                100 * (per[TIGHT].mean() / per["ipopt"].mean() - 1),
                fb,
            ]
        )
    mean = {arm: float(np.mean(totals[arm])) for arm in arms}
    rows.append(
        [
            "all six (pooled)",
            f"{mean['ladder']:.4g}",
            f"{mean['ipopt']:.4g}",
            100 * (mean["ladder"] / mean["ipopt"] - 1),
            100 * (mean[TIGHT] / mean["ipopt"] - 1),
            "",
        ]
    )
    rows.append(
        [
            "mean of the six % differences",
            "",
            "",
            float(np.mean([row[3] for row in rows[: len(SHIPPED)]])),
            float(np.mean([row[4] for row in rows[: len(SHIPPED)]])),
            "",
        ]
    )
    seeds = sorted({r["seed"] for r in q})
    out.append(
        f"quality over seeds {seeds[0]}..{seeds[-1]} (time-averaged trace, mean ± standard error "
        "over seeds):\n\n"
        + table(
            rows,
            [
                "scenario",
                "ladder",
                "IPOPT only",
                "ladder vs IPOPT (%)",
                "IPOPT tol 1e-9 vs IPOPT (%)",
                "fallback events (ladder)",
            ],
        )
    )
    return "\n\n".join(out)


def main(argv: list[str] | None = None) -> dict[str, Any]:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="one repeat, seed 1 only")
    parser.add_argument("--seeds", type=int, default=5, help="quality over seeds 1..N")
    parser.add_argument("--jobs", type=int, default=2, help="processes for the quality runs")
    args = parser.parse_args(argv)
    info = machine()
    print("# episodes: throughput and quality, SQP ladder vs IPOPT only")
    print(
        f"machine: {info['cpu']}, {info['cores']} cores, load {info['load_average_1m']}; "
        f"Python {info['python']}, CasADi {info['casadi']}, NumPy {info['numpy']}"
    )
    t = time.perf_counter()
    data: dict[str, Any] = {"machine": info, "throughput": throughput(1 if args.quick else 3)}
    print(f"  throughput: {time.perf_counter() - t:.0f} s", flush=True)
    t = time.perf_counter()
    seeds = [1] if args.quick else list(range(1, args.seeds + 1))
    data["quality"] = quality(seeds, args.jobs)
    print(f"  quality: {time.perf_counter() - t:.0f} s", flush=True)
    print()
    print(report(data))
    path = save("episodes" + ("_quick" if args.quick else ""), data)
    print(f"\nresults: {path}")
    return data


if __name__ == "__main__":
    main()
