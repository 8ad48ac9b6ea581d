"""The SOG baseline's plan per step: before (MX program, IPOPT only) and after (the league
problem's fast path: SX, compiled derivatives, SQP ladder), side by side in one run.

    python -m benchmarks.sog_plan            # bench-risk seed 4 (4×4), sensing-perm, bench-complex
    python -m benchmarks.sog_plan --quick    # bench-risk, 100 steps

The league inputs of one SOG episode per case are recorded once (the episode runs on today's
planner), then replayed through each planner: ``before``
(:class:`benchmarks.sog_reference.ReferenceSogProblem`, warm-started from its own last
solution as before), ``after`` (:class:`~resilient_tracking.planning.sog_problem.SogPlanner`,
the default ladder) and ``ipopt`` (the same fast-path problem with IPOPT only). A first replay
builds and compiles every structure untimed; the timed replays alternate the planners.
Reported per case: median and p99 time per solve, after ÷ before, SQP iterations, fallbacks,
and how far the plans are from the reference's: the largest velocity difference (m/s) and the
largest objective difference ``|Δf| / (1 + |f|)`` over all steps.
"""

from __future__ import annotations

import argparse
import time
from collections import Counter
from typing import Any

import numpy as np

from benchmarks.common import SCENARIOS, machine, save, summary_ms, table
from benchmarks.sog_reference import ReferenceSogProblem
from resilient_tracking.planning.sog_nlp import wait_for_sog_compilers
from resilient_tracking.planning.sog_problem import SogInputs, SogPlanner, SogStructure
from resilient_tracking.policies import sog as sog_policy
from resilient_tracking.scenario import load_scenario
from resilient_tracking.sim.episode import run_episode

CASES = {
    "4x4 bench-risk seed 4": ("bench-risk", 4),
    "3x3 sensing-perm seed 1": ("sensing-perm", 1),
    "4x4 bench-complex seed 1": ("bench-complex", 1),
}
PLANNERS = ("before", "after", "ipopt")

Step = tuple[tuple[int, ...], SogInputs]


def record(name: str, seed: int, steps: int | None) -> list[Step]:
    """The SOG league inputs of one episode, in order."""
    found: list[Step] = []

    class Recording(SogPlanner):
        def plan_sog(self, members: tuple[int, ...], q: SogInputs) -> Any:
            found.append((members, q))
            return super().plan_sog(members, q)

    scenario = load_scenario(SCENARIOS / f"{name}.yaml")
    if steps is not None:
        scenario = scenario.with_overrides(steps=steps)
    original = sog_policy.SogPlanner
    sog_policy.SogPlanner = Recording  # type: ignore[misc]
    try:
        run_episode(scenario, policy="sog", seed=seed)
    finally:
        sog_policy.SogPlanner = original  # type: ignore[misc]
    return found


class Reference:
    """The before-planner: one MX problem per structure, a warm start per league."""

    def __init__(self) -> None:
        self.problems: dict[SogStructure, ReferenceSogProblem] = {}
        self.warm: dict[tuple[SogStructure, tuple[int, ...]], dict[str, np.ndarray]] = {}

    def plan(self, members: tuple[int, ...], q: SogInputs) -> tuple[np.ndarray, float, str]:
        s = SogStructure(len(q.positions), len(q.targets), len(q.zones), q.sensor_model)
        if s not in self.problems:
            self.problems[s] = ReferenceSogProblem(s)
        solution, stats = self.problems[s].solve(q, self.warm.get((s, members)))
        if stats.get("success"):
            self.warm[s, members] = solution
        return solution["x"], float(solution["f"][0]), "ipopt" if stats.get("success") else "fail"


def replay(planner: str, steps: list[Step], keep: list[Any]) -> dict[str, Any]:
    """Solve every step with ``planner``; times in ms, controls and objectives per step."""
    times, controls, objectives, iterations = [], [], [], []
    rungs: Counter[str] = Counter()
    if planner == "before":
        ref = Reference()
        for members, q in steps:
            start = time.perf_counter()
            x, f, rung = ref.plan(members, q)
            times.append((time.perf_counter() - start) * 1e3)
            controls.append(x[: 2 * len(members)].reshape(-1, 2))
            objectives.append(f)
            rungs[rung] += 1
    else:
        sog = SogPlanner(solver="ladder" if planner == "after" else "ipopt")
        for members, q in steps:
            start = time.perf_counter()
            result = sog.plan_sog(members, q)
            times.append((time.perf_counter() - start) * 1e3)
            controls.append(result.controls)
            rungs[result.rung] += 1
            iterations.append(result.iterations)
            problem = sog.problem(
                SogStructure(len(q.positions), len(q.targets), len(q.zones), q.sensor_model)
            )
            warm = sog._warm.get((problem.structure, members))
            objectives.append(float(warm["f"][0]) if warm is not None else float("nan"))
        keep.append(sog)
    return {
        "ms": times,
        "controls": controls,
        "f": objectives,
        "rungs": dict(rungs),
        "iterations": iterations,
    }


def run_case(name: str, seed: int, steps: int | None, repeats: int) -> dict[str, Any]:
    recorded = record(name, seed, steps)
    keep: list[Any] = []
    for planner in PLANNERS:  # untimed: builds every structure, starts the compile jobs
        replay(planner, recorded, keep)
    wait_for_sog_compilers()
    runs: dict[str, list[dict[str, Any]]] = {p: [] for p in PLANNERS}
    for k in range(repeats):
        order = PLANNERS if k % 2 == 0 else PLANNERS[::-1]
        for planner in order:
            runs[planner].append(replay(planner, recorded, keep))
    out: dict[str, Any] = {"scenario": name, "seed": seed, "solves": len(recorded)}
    for planner in PLANNERS:
        ms = np.concatenate([r["ms"] for r in runs[planner]])
        out[planner] = {
            "per_solve": summary_ms(ms),
            "rungs": runs[planner][-1]["rungs"],
            "iterations_median": float(np.median(runs[planner][-1]["iterations"] or [np.nan])),
        }
    before = runs["before"][-1]
    for planner in ("after", "ipopt"):
        mine = runs[planner][-1]
        pairs = zip(mine["controls"], before["controls"], strict=True)
        gaps = [float(np.abs(a - b).max()) for a, b in pairs]
        du = max(gaps)
        worst = int(np.argmax(gaps))
        out[planner]["worst_step"] = {
            "solve": worst,
            "max_control_difference": du,
            "f": mine["f"][worst],
            "f_before": before["f"][worst],
            "solves_over_1e-3": int(sum(g > 1e-3 for g in gaps)),
        }
        df = np.nanmax(np.abs(np.array(mine["f"]) - before["f"]) / (1.0 + np.abs(before["f"])))
        out[planner]["max_control_difference"] = du
        out[planner]["max_objective_difference"] = float(df)
    return out


def main(argv: list[str] | None = None) -> dict[str, Any]:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="bench-risk only, 100 steps")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args(argv)
    cases = dict(list(CASES.items())[:1]) if args.quick else CASES
    results: dict[str, Any] = {"machine": machine(), "cases": {}}
    rows = []
    for label, (name, seed) in cases.items():
        found = run_case(name, seed, 100 if args.quick else None, args.repeats)
        results["cases"][label] = found
        before, after, ipopt = found["before"], found["after"], found["ipopt"]
        rows.append(
            [
                f"{label} ({found['solves']} solves)",
                before["per_solve"]["median"],
                after["per_solve"]["median"],
                after["per_solve"]["median"] / before["per_solve"]["median"],
                before["per_solve"]["p99"],
                after["per_solve"]["p99"],
                ipopt["per_solve"]["median"],
                after["iterations_median"],
                ", ".join(f"{k} {v}" for k, v in sorted(after["rungs"].items())),
                after["max_control_difference"],
                after["max_objective_difference"],
                ipopt["max_control_difference"],
            ]
        )
    print(
        table(
            rows,
            [
                "case",
                "before median (ms)",
                "after median (ms)",
                "after ÷ before",
                "before p99",
                "after p99",
                "fast-path IPOPT only median",
                "SQP iterations (median)",
                "rungs (after)",
                "max |Δu| after vs before (m/s)",
                "max |Δf| / (1 + |f|) after vs before",
                "max |Δu| IPOPT only vs before",
            ],
        )
    )
    for label, found in results["cases"].items():
        w = found["after"]["worst_step"]
        print(
            f"{label}: largest |Δu| after vs before at solve {w['solve']}: "
            f"{w['max_control_difference']:.3g} m/s, "
            f"objective {w['f']:.6g} (before {w['f_before']:.6g}); "
            f"{w['solves_over_1e-3']} of {found['solves']} solves differ by more than 1e-3 m/s"
        )
    save("sog_plan", results)
    return results


if __name__ == "__main__":
    main()
