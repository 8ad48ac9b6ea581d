"""Machine instructions per learning-environment step, counted by Valgrind's cachegrind: a
measure of the environment's cost that other work on a shared machine does not disturb (wall
and CPU times on two shared cores differ by 20–40 % from run to run).

    python -m benchmarks.env_instructions                        # this checkout
    python -m benchmarks.env_instructions --before ../old/src    # and another source tree

Needs ``valgrind`` on the PATH (Debian: ``apt install valgrind``); about a minute per tree.
Each tree's count is that of a process stepping ``TeamEnv("sensing-temp", record=False)``
``WARM_UP + --steps`` times with random velocities, less that of one stepping it ``WARM_UP``
times (imports, setup and first-time work cancel out), divided by ``--steps``.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

from benchmarks.common import ROOT, table

SCENARIO = "sensing-temp"
#: steps in both counted processes (more than an episode of ``SCENARIO``: a reset included)
WARM_UP = 400


def step(steps: int) -> None:
    """Step the environment ``steps`` times (the counted process's job)."""
    from benchmarks.env_steps import make_env, random_actions

    env = make_env(SCENARIO, record=False)
    actions = random_actions(env, steps)
    env.reset(seed=0)
    for action in actions:
        _, _, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            env.reset()


def _process(source: str | None, steps: int) -> tuple[list[str], dict[str, str]]:
    """The command and environment of a process that steps the environment ``steps`` times,
    with ``resilient_tracking`` from the source tree ``source`` (``None``: the installed
    one)."""
    env = dict(os.environ, PYTHONHASHSEED="0", MPLBACKEND="Agg")
    if source is not None:
        env["PYTHONPATH"] = str(Path(source).resolve())
    code = (
        f"import sys; sys.path.insert(1, {str(ROOT)!r}); "
        f"from benchmarks.env_instructions import step; step({steps})"
    )
    return [sys.executable, "-c", code], env


def instructions(source: str | None, steps: int) -> int:
    """Instructions of that process, counted by cachegrind."""
    command, env = _process(source, steps)
    counting = ["valgrind", "--tool=cachegrind", "--cache-sim=no"]
    counting.append("--cachegrind-out-file=/dev/null")
    out = subprocess.run([*counting, *command], env=env, check=True, capture_output=True, text=True)
    found = re.search(r"I\s+refs:\s+([\d,]+)", out.stderr)
    if found is None:
        raise RuntimeError(f"no instruction count in cachegrind's output:\n{out.stderr[-2000:]}")
    return int(found.group(1).replace(",", ""))


def per_step(source: str | None, steps: int) -> float:
    """Instructions per environment step of the tree ``source``: the count of ``WARM_UP +
    steps`` steps less that of ``WARM_UP`` steps, so imports and first-time work done on the
    way (an episode's end and reset included) cancel out."""
    return (instructions(source, WARM_UP + steps) - instructions(source, WARM_UP)) / steps


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--before", help="source tree (the folder holding resilient_tracking)")
    parser.add_argument("--steps", type=int, default=2000)
    parser.add_argument("--quick", action="store_true", help="100 steps: a smoke run")
    args = parser.parse_args(argv)
    if args.quick:
        args.steps = 100
    if shutil.which("valgrind") is None:
        parser.exit(2, "valgrind is not on the PATH (Debian: apt install valgrind)\n")
    trees = {"this checkout": None} | ({"before": args.before} if args.before else {})
    counts = {label: per_step(tree, args.steps) for label, tree in trees.items()}
    rows = [[label, counts[label]] for label in trees]
    if args.before:
        rows.append(["after / before", counts["this checkout"] / counts["before"]])
    print(f"3×3 ({SCENARIO}), record=False, random velocities, {args.steps} steps")
    print(table(rows, ["", "instructions per step"]))


if __name__ == "__main__":
    main()
