"""Planning time per league solve, side by side: the SQP ladder, IPOPT only, and a naive reference.

    python -m benchmarks.plan_step            # 200 closed-loop steps per league size
    python -m benchmarks.plan_step --quick    # a short smoke run

The ladder (``LeaguePlanner("ladder")``) drives the closed loop; the same sequence of
:class:`ProblemInputs` is then replayed, in the same run, to the package's IPOPT-only path
(``LeaguePlanner("ipopt")``) and, on a subsample of steps, to the naive reference
(``benchmarks.naive``: ``Opti`` rebuilt every step, cold IPOPT). Times are wall-clock and CPU
around the whole call (packing, solver, unpacking). Also measured: one evaluation of the NLP's
functions and derivatives, the first-time build of a structure, and the fraction of robots at
a zone's boundary.
"""

from __future__ import annotations

import argparse
import collections
import copy
import json
import time
import timeit
from pathlib import Path
from typing import Any

import casadi as ca
import numpy as np

from benchmarks import naive
from benchmarks.common import IMAGES, machine, save, summary_ms, table
from benchmarks.league_loop import CASES, LeagueCase, LeagueLoop, active_fraction
from resilient_tracking.planning.layout import ProblemInputs
from resilient_tracking.planning.league_problem import LeagueProblem
from resilient_tracking.planning.planner import LeaguePlanner, PlanResult

#: steps between two naive solves, per league size (the naive 20×20 takes seconds per step)
NAIVE_EVERY = {"3x3": 1, "5x5": 2, "10x10": 10, "20x20": 20}


def evaluation_ms(fn: ca.Function, args: list[np.ndarray], repeat: int) -> float:
    """Median time of one evaluation through a zero-copy buffer (no Python conversion)."""
    buffer: Any
    buffer, evaluate = fn.buffer()
    inputs = [np.ascontiguousarray(a, dtype=float).ravel() for a in args]
    outputs = [np.zeros(fn.nnz_out(i)) for i in range(fn.n_out())]
    for i, a in enumerate(inputs):
        buffer.set_arg(i, a.data)
    for i, r in enumerate(outputs):
        buffer.set_res(i, r.data)
    evaluate()
    times = timeit.repeat(evaluate, number=max(1, repeat // 20), repeat=20)
    return float(np.median(times) / max(1, repeat // 20) * 1e3)


def evaluations(
    problem: LeagueProblem, q: Any, solution: dict[str, np.ndarray]
) -> dict[str, float]:
    """One evaluation of what an SQP iteration needs (f, g, ∇f, ∂g/∂x, ∇²L) of the problem
    the SQP solved at ``q`` (the reduced one when there was one), on CasADi's virtual machine
    and, when the solver uses it, compiled."""
    reduction = problem.reduction(q)
    method = "sqp" if reduction is None else "sqp_slots"
    fn = problem.symbolic(method).functions
    p = problem.pack_params(q)
    x, lam_g = solution["x"], solution["lam_g"]
    if reduction is not None:
        p = np.concatenate([p, reduction.selection])
        x, lam_g = reduction.reduce(x), reduction.reduce_rows(lam_g)
    repeat = 2000 if problem.structure.n_vars < 50 else 200
    args = {"fg": [x, p], "jac_fg": [x, p], "hess_clip": [x, p, np.ones(1), lam_g]}
    out = {f"vm_{k}": evaluation_ms(fn[k], a, repeat) for k, a in args.items()}
    out["vm_total"] = sum(out.values())
    job = problem._job(method)
    if problem.compiled(method) and job is not None:
        compiled = job.load()
        out["c_fg"] = evaluation_ms(compiled["fg"], args["fg"], repeat)
        out["c_jac_fg"] = evaluation_ms(compiled["jac_fg"], args["jac_fg"], repeat)
        out["c_hess_clip"] = evaluation_ms(compiled["hess_lag"], args["hess_clip"], repeat)
        out["c_total"] = out["c_fg"] + out["c_jac_fg"] + out["c_hess_clip"]
    out["total"] = out.get("c_total", out["vm_total"])
    return out


def run_case(case: LeagueCase, steps: int, naive_every: int, seed: int = 0) -> dict[str, Any]:
    loop = LeagueLoop(case, seed)
    s = case.structure
    members = tuple(range(case.n_robots))
    planners = {"ladder": LeaguePlanner("ladder"), "ipopt": LeaguePlanner("ipopt")}
    build_s, compile_s = {}, {}
    for name, planner in planners.items():  # a structure's first use: build and set up
        methods = ("sqp", "ipopt") if name == "ladder" else ("ipopt",)
        t = time.perf_counter()
        problem = planner.problem(s)
        for method in methods:
            problem.solver(method)
        if name == "ladder" and problem.slots:  # the SQP's reduced problem
            problem.solver("sqp_slots")
        build_s[name] = time.perf_counter() - t
        t = time.perf_counter()  # compiled code: from the cache, or wait for gcc once
        problem.wait_for_compiler(methods)
        compile_s[name] = time.perf_counter() - t
    times: dict[str, list[float]] = {"ladder": [], "ipopt": [], "naive": []}
    cpu: dict[str, list[float]] = {"ladder": [], "ipopt": [], "naive": []}
    iters: dict[str, list[int]] = {"ladder": [], "ipopt": [], "naive": []}
    rungs: dict[str, collections.Counter[str]] = {k: collections.Counter() for k in times}
    failures = dict.fromkeys(times, 0)
    controls: dict[str, list[np.ndarray]] = {"ladder": [], "ipopt": [], "naive": []}
    # Pass 1: the ladder drives the loop; its inputs are recorded for the other passes, which
    # replay them, so every solver sees exactly the same problems (and none disturbs the
    # others' caches, as interleaving a naive rebuild between two fast solves would).
    recorded, active = [], []
    last_q, last_solution = None, None
    reduced = 0  # steps the SQP could solve the reduced problem

    def solve(name: str, q: ProblemInputs) -> PlanResult:
        """One timed league solve by ``planners[name]``, recorded under ``name``."""
        t, c = time.perf_counter(), time.process_time()
        r = planners[name].plan(s, members, q)
        times[name].append((time.perf_counter() - t) * 1e3)
        cpu[name].append((time.process_time() - c) * 1e3)
        iters[name].append(r.iterations)
        rungs[name][r.rung] += 1
        failures[name] += not r.success
        controls[name].append(r.controls)
        return r

    for q in loop.run(steps):
        reduced += planners["ladder"].problem(s).reduction(q) is not None
        r = solve("ladder", q)
        active.append(active_fraction(q, r.controls))
        recorded.append(copy.deepcopy(q))
        last_q, last_solution = q, planners["ladder"]._warm.get((s, members))
        loop.apply(q, r.controls)
    # Pass 2: IPOPT only, warm-started from its own previous solution.
    for q in recorded:
        solve("ipopt", q)
    # Pass 3: the naive reference on every ``naive_every``-th step.
    du_naive = []
    for k in range(0, len(recorded), naive_every or len(recorded) + 1):
        c = time.process_time()
        u, stats, seconds = naive.solve(recorded[k])
        times["naive"].append(seconds * 1e3)
        cpu["naive"].append((time.process_time() - c) * 1e3)
        iters["naive"].append(int(stats.get("iter_count", 0)))
        ok = bool(stats.get("success", False))
        rungs["naive"]["ipopt" if ok else "failed"] += 1
        failures["naive"] += not ok
        du_naive.append(float(np.abs(u - controls["ipopt"][k]).max()))
    pairs = zip(controls["ladder"], controls["ipopt"], strict=True)
    du_ipopt = [float(np.abs(a - b).max()) for a, b in pairs]
    ladder_problem = planners["ladder"].problem(s)
    sqp_nlp = ladder_problem.slot_nlp if ladder_problem.slots else ladder_problem.nlp
    out: dict[str, Any] = {
        "case": case.label,
        "structure": vars(s) | {"n_vars": s.n_vars, "n_constraints": s.n_constraints},
        "sqp_problem": {
            "slots": vars(ladder_problem.slots) if ladder_problem.slots else None,
            "n_vars": sqp_nlp.n_vars,
            "n_constraints": sqp_nlp.n_constraints,
            "reduced_steps": reduced,
        },
        "steps": steps,
        "naive_every": naive_every,
        "build_s": build_s,
        "compile_wait_s": compile_s,
        "compiled": {n: p.problem(s).compiled("ipopt") for n, p in planners.items()},
        "active_fraction": float(np.mean(active)),
        "max_abs_du_ladder_vs_ipopt_median": float(np.median(du_ipopt)),
        "max_abs_du_naive_vs_ipopt_median": float(np.median(du_naive)) if du_naive else None,
    }
    for name in times:
        out[name] = {
            "ms": summary_ms(times[name]),
            "cpu_ms": summary_ms(cpu[name]),
            "samples": len(times[name]),
            "iterations_median": float(np.median(iters[name])) if iters[name] else float("nan"),
            "iterations_max": int(max(iters[name])) if iters[name] else 0,
            "rungs": dict(rungs[name]),
            "unhandled_failures": failures[name],
        }
    if last_q is not None and last_solution is not None:
        out["evaluation_ms"] = evaluations(planners["ladder"].problem(s), last_q, last_solution)
    return out


def report(results: list[dict[str, Any]]) -> str:
    rows = []
    for r in results:
        for name, label in (("ladder", "SQP ladder"), ("ipopt", "IPOPT only"), ("naive", "naive")):
            m = r[name]["ms"]
            rung_text = ", ".join(f"{k} {v}" for k, v in sorted(r[name]["rungs"].items()))
            rows.append(
                [
                    r["case"],
                    label,
                    r[name]["samples"],
                    m["median"],
                    m["p90"],
                    m["p99"],
                    m["max"],
                    r[name]["cpu_ms"]["median"],
                    f"{r[name]['iterations_median']:.0f} / {r[name]['iterations_max']}",
                    rung_text,
                    r[name]["unhandled_failures"],
                ]
            )
    text = [
        table(
            rows,
            [
                "league",
                "solver",
                "solves",
                "median ms",
                "p90 ms",
                "p99 ms",
                "max ms",
                "CPU median ms",
                "iters med / max",
                "rung used",
                "safe action",
            ],
        )
    ]
    rows = []
    for r in results:
        lad, ip, nv = r["ladder"]["ms"]["median"], r["ipopt"]["ms"]["median"], r["naive"]["ms"]
        ev = r.get("evaluation_ms", {})
        sqp = r.get("sqp_problem") or {}
        rows.append(
            [
                r["case"],
                f"{r['structure']['n_vars']} / {r['structure']['n_constraints']}",
                f"{sqp['n_vars']} / {sqp['n_constraints']} ({sqp['reduced_steps']} steps)"
                if sqp.get("slots")
                else "–",
                nv["median"] / lad,
                ip / lad,
                ev.get("vm_total", float("nan")) * 1e3,
                ev.get("c_total", float("nan")) * 1e3,
                lad / ev.get("total", float("nan")),
                r["build_s"]["ladder"],
                r["compile_wait_s"]["ladder"],
                r["active_fraction"],
                r["max_abs_du_ladder_vs_ipopt_median"],
                r["max_abs_du_naive_vs_ipopt_median"] or float("nan"),
            ]
        )
    text.append(
        table(
            rows,
            [
                "league",
                "vars / constraints",
                "SQP's reduced problem",
                "speed-up vs naive (median)",
                "speed-up vs IPOPT only",
                "one eval f,g,∇f,J,∇²L VM (µs)",
                "same, compiled (µs)",
                "solve / eval",
                "first build (s)",
                "compiler wait (s)",
                "robots at a zone boundary",
                "median max|Δu| ladder–IPOPT",
                "median max|Δu| naive–IPOPT",
            ],
        )
    )
    return "\n\n".join(text)


def plot(results: list[dict[str, Any]], path: Any, title: str = "") -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import NullLocator

    robots = [r["structure"]["n_robots"] for r in results]
    fig, ax = plt.subplots(figsize=(6, 4))
    styles = {
        "ladder": ("SQP ladder", "C0"),
        "ipopt": ("IPOPT only", "C1"),
        "naive": ("naive", "C3"),
    }
    for name, (label, color) in styles.items():
        med = np.array([r[name]["ms"]["median"] for r in results])
        p90 = np.array([r[name]["ms"]["p90"] for r in results])
        ax.plot(robots, med, "o-", color=color, label=f"{label} (median)")
        ax.plot(robots, p90, "--", color=color, alpha=0.6, label=f"{label} (p90)")
    ax.axhline(100, color="grey", lw=0.8, ls=":")
    ax.text(robots[-1], 125, "control period 100 ms", color="grey", fontsize=8, ha="right")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.xaxis.set_minor_locator(NullLocator())
    ax.set_xticks(robots)
    ax.set_xticklabels([r["case"] for r in results])
    if title:
        ax.set_title(title, fontsize=8)
    ax.set_xlabel("league size (robots × targets), with known zones")
    ax.set_ylabel("plan time per league solve (ms)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _title(info: dict[str, Any]) -> str:
    return (
        f"{info['cpu']}, {info['cores']} cores (load average {info['load_average_1m']}), "
        f"CasADi {info['casadi']}"
    )


def main(argv: list[str] | None = None) -> dict[str, Any]:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="40 steps, few naive solves")
    parser.add_argument("--steps", type=int, default=200)
    parser.add_argument("--sizes", nargs="*", help="subset of 3x3 5x5 10x10 20x20")
    parser.add_argument("--no-naive", action="store_true")
    parser.add_argument("--no-plot", action="store_true")
    parser.add_argument(
        "--plot-only", metavar="JSON", help="redraw the plot from a saved result file"
    )
    args = parser.parse_args(argv)
    if args.plot_only:
        saved = json.loads(Path(args.plot_only).read_text())
        image = IMAGES / "plan-time-vs-team-size.png"
        plot(saved["results"], image, _title(saved["machine"]))
        print(f"plot: {image}")
        return saved
    steps = 40 if args.quick else args.steps
    cases = [c for c in CASES if not args.sizes or c.label in args.sizes]
    info = machine()
    print(f"# plan_step: {steps} closed-loop steps per league size")
    print(
        f"machine: {info['cpu']}, {info['cores']} cores, load {info['load_average_1m']}; "
        f"Python {info['python']}, CasADi {info['casadi']}, NumPy {info['numpy']}"
    )
    results = []
    for case in cases:
        every = 0 if args.no_naive else NAIVE_EVERY[case.label] * (5 if args.quick else 1)
        t = time.perf_counter()
        r = run_case(case, steps, every)
        print(f"  {case.label}: done in {time.perf_counter() - t:.1f} s", flush=True)
        results.append(r)
    print()
    print(report(results))
    data = {"machine": info, "steps": steps, "results": results}
    path = save("plan_step" + ("_quick" if args.quick else ""), data)
    print(f"\nresults: {path}")
    if not args.no_plot and not args.no_naive:
        image = IMAGES / ("plan-time-vs-team-size" + ("-quick" if args.quick else "") + ".png")
        plot(results, image, _title(info))
        print(f"plot: {image}")
    return data


if __name__ == "__main__":
    main()
