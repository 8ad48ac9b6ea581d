"""Whole reproductions timed end to end, before and after a change, side by side in one run.

    python -m benchmarks.reproduce --before ../main/src   # both trees, one after the other
    python -m benchmarks.reproduce                        # this tree only
    python -m benchmarks.reproduce --quick                # sensing-temp, 10 seeds

Cases (each a fresh ``rtrack reproduce … --jobs 2`` process into an empty folder, so every run
and figure is made; wall time of the whole command, report included):

* ``paper``: the paper's nine experiments at full seeds on the paper's one-step program —
  ``rtrack reproduce sensing-temp sensing-perm comm-temp comm-perm combined-temp
  combined-perm bench-risk bench-scale bench-complex --jobs 2`` (330 runs; ``all`` adds the
  route program's copies and the generalization suite);
* ``sensing-temp x100``: ``rtrack reproduce sensing-temp --seeds 100 --jobs 2`` (200 runs);
* ``rerun``: the ``paper`` command again on its finished folder (every run stored).

With ``--before`` the other tree runs each case first, then this one, so both see the same
machine. Each episode's own wall time is in its run's manifest; their sum over the wall time
is how busy the two workers were kept.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from benchmarks.common import machine, save, table
from resilient_tracking.experiments.catalog import SIX

#: the catalog's names of the paper's nine experiments on its one-step program
PAPER = [*SIX, "bench-risk", "bench-scale", "bench-complex"]
CASES: dict[str, list[str]] = {
    "paper": [*PAPER, "--jobs", "2"],
    "sensing-temp x100": ["sensing-temp", "--seeds", "100", "--jobs", "2"],
}
QUICK: dict[str, list[str]] = {"sensing-temp x10": ["sensing-temp", "--seeds", "10", "--jobs", "2"]}


def reproduce(source: str | None, args: list[str], out: Path) -> dict[str, Any]:
    """One ``rtrack reproduce`` process of ``source``'s code (None: this tree's)."""
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    if source is not None:
        env["PYTHONPATH"] = str(Path(source).resolve())
    command = [sys.executable, "-m", "resilient_tracking.cli", "reproduce", *args]
    start = time.perf_counter()
    subprocess.run([*command, "--out", str(out), "-q"], env=env, check=True, cwd=out.parent)
    wall = time.perf_counter() - start
    episodes = [
        json.loads(p.read_text()).get("wall_time_s", 0.0)
        for p in (out / "runs").glob("*/*/*/manifest.json")
    ]
    return {"wall_s": wall, "runs": len(episodes), "episodes_s": float(sum(episodes))}


def main(argv: list[str] | None = None) -> dict[str, Any]:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--before", help="source tree (the folder holding resilient_tracking)")
    parser.add_argument("--quick", action="store_true", help="sensing-temp, 10 seeds")
    args = parser.parse_args(argv)
    cases = QUICK if args.quick else CASES
    trees = {"after": None} if args.before is None else {"before": args.before, "after": None}
    results: dict[str, Any] = {"machine": machine(), "before_tree": args.before, "cases": {}}
    rows = []
    with tempfile.TemporaryDirectory(prefix="rtrack-bench-") as tmp:
        for case, case_args in cases.items():
            found = {}
            for label, source in trees.items():
                out = Path(tmp) / f"{label}-{case.replace(' ', '_')}"
                found[label] = reproduce(source, case_args, out)
                if case == "paper":  # the same command again, every run stored
                    found[f"{label} rerun"] = reproduce(source, case_args, out)
            results["cases"][case] = found
            for label, r in found.items():
                rows.append([case, label, r["runs"], r["wall_s"], r["episodes_s"] / r["wall_s"]])
    print(table(rows, ["case", "tree", "runs", "wall s", "episode seconds per wall second"]))
    for case, found in results["cases"].items():
        if "before" in found:
            ratio = found["after"]["wall_s"] / found["before"]["wall_s"]
            print(f"{case}: after ÷ before = {ratio:.3f}")
            if "before rerun" in found:
                ratio = found["after rerun"]["wall_s"] / found["before rerun"]["wall_s"]
                print(f"{case} rerun: after ÷ before = {ratio:.3f}")
    save("reproduce", results)
    return results


if __name__ == "__main__":
    main()
