"""Throughput of the learning environments: environment steps per second, without a planner
(random velocities), at 3×3 (``sensing-temp``) and 20×20 (``soak-20x20``), in one process and
as a vector of processes (Gymnasium's ``AsyncVectorEnv``, one per core), with the run tables
recorded (the default) and without (``record=False``); then where one step's time goes, part by
part.

    python -m benchmarks.env_steps                        # about a minute
    python -m benchmarks.env_steps --quick                # a smoke run
    python -m benchmarks.env_steps --before ../old/src    # and another source tree, side by side

Each measurement first runs a few steps untimed (imports, first allocations). Steps count every
``step`` call; an episode that ends is reset (its reset is timed too). The random velocities are
drawn before the clock starts, so the numbers are the environment's alone. With ``--before``,
the 3×3 ``record=False`` case also runs in fresh processes, this checkout's code and the other
tree's in turn, ``--rounds`` times each: the best CPU time per step of each and their ratio.
"""

from __future__ import annotations

import argparse
import functools
import os
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np

from benchmarks.common import machine, run_in_tree, save, table

CASES = (("sensing-temp", "3×3"), ("soak-20x20", "20×20"))


def make_env(name: str, record: bool = True) -> Any:
    from resilient_tracking.env import TeamEnv

    return TeamEnv(name, record=record)


def random_actions(env: Any, steps: int) -> list[Any]:
    """``steps`` random velocities of ``env``'s action space (seeded)."""
    env.action_space.seed(0)
    return [env.action_space.sample() for _ in range(steps)]


def one_process(
    name: str, steps: int, planner: bool = False, record: bool = True
) -> tuple[float, float]:
    """Steps per second of wall time and per second of this process's CPU time, of one
    ``TeamEnv`` driven by random velocities (or, with ``planner``, by the failure-aware
    policy's own). On a machine shared with other work the CPU figure is what one core of
    one's own would give."""
    env = make_env(name, record)
    actions = random_actions(env, steps)
    env.reset(seed=0)

    def run(n: int) -> None:
        for i in range(n):
            action = env.expert_action() if planner else actions[i]
            _, _, terminated, truncated, _ = env.step(action)
            if terminated or truncated:
                env.reset()

    run(min(20, steps))
    start, cpu = time.perf_counter(), time.process_time()
    run(steps)
    return steps / (time.perf_counter() - start), steps / (time.process_time() - cpu)


def vector(name: str, steps: int, workers: int) -> float:
    """Steps per second (all workers' together) of ``workers`` environments in their own
    processes, stepped together."""
    import gymnasium

    return vector_rate(
        gymnasium.vector.AsyncVectorEnv([functools.partial(make_env, name)] * workers), steps
    )


def vector_rate(envs: Any, steps: int) -> float:
    """Steps per second (every environment's together) of a Gymnasium vector environment
    stepped ``steps`` times in all with random velocities drawn before the clock starts, after
    ten untimed steps; closes it."""
    workers = envs.num_envs
    try:
        envs.action_space.seed(0)
        actions = [envs.action_space.sample() for _ in range(steps // workers)]
        envs.reset(seed=0)
        for action in actions[:10]:
            envs.step(action)
        start = time.perf_counter()
        for action in actions:
            envs.step(action)
        return workers * len(actions) / (time.perf_counter() - start)
    finally:
        envs.close()


@contextmanager
def timed_parts(spent: dict[str, float]) -> Iterator[None]:
    """Add each part's time to ``spent`` while inside (the parts' methods wrapped)."""
    from resilient_tracking.belief.team_belief import TeamBelief
    from resilient_tracking.env import session
    from resilient_tracking.runs.team_recorder import TeamRecorder
    from resilient_tracking.runs.truth_recorder import TruthRecorder
    from resilient_tracking.team import Team
    from resilient_tracking.world import World

    parts: list[tuple[Any, str, str]] = [
        (World, "observe", "world: observe"),
        (World, "step", "world: move, attacks, links"),
        (TeamBelief, "update", "belief: EKF, leagues, zones"),
        (Team, "decide", "decision checks"),
        (TeamRecorder, "step", "run tables"),
        (TruthRecorder, "step", "run tables"),
        (session, "team_views", "agents' views"),
    ]
    saved = [(owner, attr, getattr(owner, attr)) for owner, attr, _ in parts]

    def wrap(function: Callable[..., Any], label: str) -> Callable[..., Any]:
        def timed(*args: Any, **kwargs: Any) -> Any:
            start = time.perf_counter()
            try:
                return function(*args, **kwargs)
            finally:
                spent[label] = spent.get(label, 0.0) + time.perf_counter() - start

        return timed

    for (owner, attr, label), (_, _, original) in zip(parts, saved, strict=True):
        setattr(owner, attr, wrap(original, label))
    try:
        yield
    finally:
        for owner, attr, original in saved:
            setattr(owner, attr, original)


def parts(name: str, steps: int, record: bool = True) -> dict[str, float]:
    """Microseconds per step of each part of an environment step (random velocities)."""
    env = make_env(name, record)
    actions = random_actions(env, steps)
    env.reset(seed=0)
    spent: dict[str, float] = {}
    with timed_parts(spent):
        start = time.perf_counter()
        for action in actions:
            _, _, terminated, truncated, _ = env.step(action)
            if terminated or truncated:
                env.reset()
        total = time.perf_counter() - start
    spent["the rest (reward, info, clipping)"] = total - sum(spent.values())
    return {label: 1e6 * seconds / steps for label, seconds in spent.items()} | {
        "total": 1e6 * total / steps
    }


def cpu_us_per_step(name: str, steps: int) -> float:
    """CPU µs per step of :func:`one_process` with ``record=False`` (a child's job)."""
    return 1e6 / one_process(name, steps, record=False)[1]


def side_by_side(before: str, name: str, steps: int, rounds: int) -> dict[str, float]:
    """The best CPU µs per step of the ``before`` tree's code and of this checkout's, in fresh
    processes taken in turn, and the speed-up."""
    best = {"before": float("inf"), "after": float("inf")}
    for k in range(rounds):
        order = [("before", before), ("after", None)]
        for label, tree in order if k % 2 == 0 else order[::-1]:
            us = run_in_tree(tree, "benchmarks.env_steps", "cpu_us_per_step", name, steps)
            best[label] = min(best[label], us)
    return best | {"speed-up": best["before"] / best["after"]}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--before", help="source tree (the folder holding resilient_tracking)")
    parser.add_argument("--rounds", type=int, default=6, help="side-by-side rounds per tree")
    args = parser.parse_args(argv)
    scale = 0.1 if args.quick else 1.0
    workers = os.cpu_count() or 1
    rows, results = [], {}
    for name, size in CASES:
        n = int((3000 if size == "3×3" else 600) * scale)
        single, single_cpu = one_process(name, n)
        vec = vector(name, n, workers)
        rows.append([size, name, "random", single, single_cpu, vec])
        bare, bare_cpu = one_process(name, n, record=False)
        rows.append([size, name, "random, record=False", bare, bare_cpu, np.nan])
        results[name] = {
            "one_process": single,
            "one_process_cpu": single_cpu,
            f"vector_{workers}": vec,
            "one_process_no_record": bare,
            "one_process_no_record_cpu": bare_cpu,
        }
    planned, planned_cpu = one_process("sensing-temp", int(600 * scale), planner=True)
    rows.append(["3×3", "sensing-temp", "failure-aware planner", planned, planned_cpu, np.nan])
    results["sensing-temp"]["one_process_planner"] = planned
    results["sensing-temp"]["one_process_planner_cpu"] = planned_cpu
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"load average (1 min): {load:.2f} on {workers} cores")
    header = ["size", "scenario", "velocities", "steps/s, 1 process", "per CPU second"]
    print(table(rows, [*header, f"steps/s, {workers} processes"]))
    split = {
        name: parts(name, int((3000 if size == "3×3" else 600) * scale)) for name, size in CASES
    }
    bare_name = CASES[0][0]
    split[f"{bare_name}, record=False"] = parts(bare_name, int(3000 * scale), record=False)
    columns = [*(f"{size} ({name})" for name, size in CASES), "3×3, record=False"]
    labels = list(split[CASES[0][0]])
    print()
    print(
        table(
            [[label, *(split[name].get(label, np.nan) for name in split)] for label in labels],
            ["µs per step", *columns],
        )
    )
    saved: dict[str, object] = {"machine": machine(), "steps_per_s": results, "parts_us": split}
    if args.before:
        compared = side_by_side(args.before, bare_name, int(3000 * scale), args.rounds)
        print(f"\n3×3 ({bare_name}), record=False, best CPU µs per step over {args.rounds} rounds:")
        print(
            table(
                [[label, value] for label, value in compared.items()],
                [f"before: {args.before}", "CPU µs per step (speed-up: ratio)"],
            )
        )
        saved["side_by_side"] = {"before_tree": args.before, **compared}
    path = save("env_steps", saved)
    print(f"\nsaved {path}")


if __name__ == "__main__":
    main()
