"""Sweep scaling: the same 20 episodes with one worker process and with two.

    python -m benchmarks.sweep            # 20 runs: the six shipped scenarios × seeds, cycled
    python -m benchmarks.sweep --quick    # 6 runs

Runs go through ``joblib`` (process workers) over
:func:`resilient_tracking.sim.episode.run_episode`, as a seed sweep would; each worker
returns only the time-averaged trace, so the cost of shipping tables back is not measured.
Each sweep starts fresh (new workers, problems not yet built in the process; compiled code
already in the disk cache). "Cores kept busy" is the episodes' summed CPU time over the wall
time: on an idle 2-core machine two workers approach 2, on a shared one they cannot.
"""

from __future__ import annotations

import argparse
import itertools
import time
from typing import Any, TypedDict

from joblib import Parallel, delayed
from joblib.externals.loky import get_reusable_executor

from benchmarks.common import SCENARIOS, SHIPPED, machine, save, table
from resilient_tracking.planning.nlp_cache import nlp_cache, wait_for_compilers
from resilient_tracking.scenario import load_scenario
from resilient_tracking.sim.episode import run_episode


class SweepResult(TypedDict):
    """One sweep's wall seconds, time-averaged traces and the episodes' summed CPU seconds."""

    wall_s: float
    traces: list[float]
    episode_cpu_s: float


def one(name: str, seed: int) -> tuple[float, float]:
    """(time-averaged trace, CPU seconds) of one episode."""
    cpu = time.process_time()
    result = run_episode(load_scenario(SCENARIOS / f"{name}.yaml"), seed=seed)
    return float(result["team"]["trace"].mean()), time.process_time() - cpu


def sweep(runs: list[tuple[str, int]], jobs: int) -> tuple[float, list[float], float]:
    """Wall seconds, traces and the episodes' summed CPU seconds of one sweep, started as a
    fresh sweep would: problems not yet built in this process, new worker processes."""
    nlp_cache().clear()
    get_reusable_executor().shutdown(wait=True)
    start = time.perf_counter()
    out = Parallel(n_jobs=jobs)(delayed(one)(name, seed) for name, seed in runs)
    wall = time.perf_counter() - start
    return wall, [trace for trace, _ in out], sum(cpu for _, cpu in out)


def main(argv: list[str] | None = None) -> dict[str, Any]:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--runs", type=int, default=20)
    args = parser.parse_args(argv)
    n = 6 if args.quick else args.runs
    pairs = ((name, seed) for seed in itertools.count(1) for name in SHIPPED)
    runs = list(itertools.islice(pairs, n))
    info = machine()
    print(f"# sweep: {n} episodes (300 steps each), joblib with 1 and 2 workers")
    print(
        f"machine: {info['cpu']}, {info['cores']} cores, load {info['load_average_1m']}; "
        f"Python {info['python']}, CasADi {info['casadi']}, NumPy {info['numpy']}"
    )
    for name, seed in runs:  # warm-up: fill the compiled-code cache for every structure
        one(name, seed)
    wait_for_compilers()
    results: dict[int, SweepResult] = {}
    for jobs in (1, 2):
        wall, traces, cpu = sweep(runs, jobs)
        results[jobs] = {"wall_s": wall, "traces": traces, "episode_cpu_s": cpu}
        print(f"  jobs={jobs}: {wall:.1f} s", flush=True)
    same = results[1]["traces"] == results[2]["traces"]
    rows = [
        [
            jobs,
            r["wall_s"],
            n / r["wall_s"],
            results[1]["wall_s"] / r["wall_s"],
            r["episode_cpu_s"],
            r["episode_cpu_s"] / r["wall_s"],
        ]
        for jobs, r in results.items()
    ]
    print()
    print(
        table(
            rows,
            ["jobs", "wall s", "episodes/s", "speed-up", "episodes' CPU s", "cores kept busy"],
        )
    )
    print(f"\nidentical results with 1 and 2 workers: {same}")
    data = {"machine": info, "runs": runs, "results": results, "identical": same}
    path = save("sweep" + ("_quick" if args.quick else ""), data)
    print(f"results: {path}")
    return data


if __name__ == "__main__":
    main()
