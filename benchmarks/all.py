"""Every benchmark in one go: ``python -m benchmarks.all`` (add ``--quick`` for a smoke run).

Runs :mod:`benchmarks.plan_step`, :mod:`benchmarks.episodes` and :mod:`benchmarks.sweep` one
after the other (never concurrently, so they do not disturb each other's timings); each prints
its tables and saves its numbers under ``benchmarks/results/``.
"""

from __future__ import annotations

import argparse
import time

from benchmarks import episodes, plan_step, sweep


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args(argv)
    flags = ["--quick"] if args.quick else []
    start = time.perf_counter()
    for module in (plan_step, episodes, sweep):
        module.main(flags)
        print()
    print(f"all benchmarks: {time.perf_counter() - start:.0f} s")


if __name__ == "__main__":
    main()
