"""Print the calibration table of docs/calibration.md (six shipped scenarios, both policies).

Usage (from the repository root)::

    python tools/calibration_table.py                  # seeds 1..5, as in docs/calibration.md
    python tools/calibration_table.py --seeds 1-10     # a wider check
    python tools/calibration_table.py --scenarios comm-temp,comm-perm

Each cell is the mean ± standard deviation over seeds of the time-averaged metric (the mean of
``team.parquet``'s ``trace`` or ``mse`` over the steps of one episode). "FA wins" counts the
seeds where the failure-aware policy's time-averaged trace is below the vanilla one.
"""

from __future__ import annotations

import argparse

from resilient_tracking import scenarios
from resilient_tracking.experiments.compare import compare

SIX = ["sensing-temp", "sensing-perm", "comm-temp", "comm-perm", "combined-temp", "combined-perm"]
SCENARIOS = scenarios.folder()


def seed_range(text: str) -> list[int]:
    if "-" in text:
        lo, hi = text.split("-")
        return list(range(int(lo), int(hi) + 1))
    return [int(s) for s in text.split(",")]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="1-5", help="'1-5' or '1,2,3'")
    parser.add_argument("--scenarios", default=",".join(SIX))
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args()
    names = args.scenarios.split(",")
    seeds = seed_range(args.seeds)
    df = compare(
        [SCENARIOS / f"{n}.yaml" for n in names],
        ["vanilla", "failure_aware"],
        seeds,
        jobs=args.jobs,
    )

    def cell(rows, col: str) -> str:
        return f"{rows[col].mean():.4f} ± {rows[col].std():.4f}"

    print(f"seeds {seeds[0]}..{seeds[-1]} ({len(seeds)})\n")
    print(
        "| scenario | trace vanilla | trace failure-aware | MSE vanilla | MSE failure-aware "
        "| FA wins (trace) | robots attacked va / fa | solver failures |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for name in names:
        rows = df[df.scenario == name]
        va = rows[rows.policy == "vanilla"].set_index("seed")
        fa = rows[rows.policy == "failure_aware"].set_index("seed")
        wins = int((fa["trace"] < va["trace"]).sum())
        print(
            f"| {name} | {cell(va, 'trace')} | {cell(fa, 'trace')} | {cell(va, 'mse')} "
            f"| {cell(fa, 'mse')} | {wins}/{len(seeds)} "
            f"| {va['robots_attacked'].mean():.1f} / {fa['robots_attacked'].mean():.1f} "
            f"| {int(rows['solver_failures'].sum())} |"
        )


if __name__ == "__main__":
    main()
