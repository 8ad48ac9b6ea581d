"""Print the "evade, then come back" table of docs/calibration.md: both planner programs on the
six paper scenarios, failure-aware against vanilla, and each against its zone-free run.

Usage (from the repository root)::

    python tools/comeback_table.py                   # seeds 1..10
    python tools/comeback_table.py --seeds 101-110   # seeds nobody tuned on
    python tools/comeback_table.py --programs route --set planner.route.standoff=0.1

Columns, each a mean over seeds: the last-third ratio (mean trace over the final third of the
episode ÷ the same for the same seed with ``zones: []``), the time-averaged trace and MSE of
the failure-aware (FA) and vanilla (VA) teams on the same program, robots attacked (hazard or
jamming) per run, stragglers (robots that can sense at the end but are more than 1.5 m from
every target) over robots that can sense, and the filter's consistency ``N · MSE / trace``
(1 when the EKF's covariance matches its errors; the zone-free FA runs).
"""

from __future__ import annotations

import argparse

import pandas as pd
import yaml

from resilient_tracking import scenarios
from resilient_tracking.experiments.compare import compare

SIX = ["sensing-temp", "sensing-perm", "comm-temp", "comm-perm", "combined-temp", "combined-perm"]


def seed_range(text: str) -> list[int]:
    if "-" in text:
        lo, hi = text.split("-")
        return list(range(int(lo), int(hi) + 1))
    return [int(s) for s in text.split(",")]


def runs(program: str, seeds: list[int], jobs: int, extra: dict[str, object]) -> pd.DataFrame:
    paths = [scenarios.folder() / f"{n}.yaml" for n in SIX]
    program_only = {"planner.program": program, **extra}
    both = compare(paths, ["failure_aware", "vanilla"], seeds, jobs, program_only)
    free = compare(paths, ["failure_aware"], seeds, jobs, {**program_only, "zones": []})
    return pd.concat([both.assign(zones=True), free.assign(zones=False)], ignore_index=True)


def row(df: pd.DataFrame, name: str, program: str) -> str:
    d = df[df.scenario == name]
    fa = d[(d.policy == "failure_aware") & d.zones].set_index("seed")
    va = d[(d.policy == "vanilla") & d.zones].set_index("seed")
    free = d[~d.zones].set_index("seed")
    ratio = (fa["last_third_trace"] / free["last_third_trace"]).mean()
    consistency = (free["targets"] * free["mse"] / free["trace"]).mean()
    return (
        f"| {name} | {program} | {ratio:.2f} | {fa.trace.mean():.4f} / {va.trace.mean():.4f} "
        f"| {fa.mse.mean():.4f} / {va.mse.mean():.4f} "
        f"| {fa.robots_attacked.mean():.1f} / {va.robots_attacked.mean():.1f} "
        f"| {fa.stragglers.sum()}/{fa.sensing_end.sum()} | {consistency:.2f} |"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="1-10", help="'1-10' or '1,2,3'")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--programs", default="one_step,route")
    parser.add_argument(
        "--set", action="append", default=[], help="dotted.path=value (YAML), repeatable"
    )
    args = parser.parse_args()
    seeds = seed_range(args.seeds)
    extra = {k: yaml.safe_load(v) for k, v in (item.split("=", 1) for item in args.set)}
    found = {p: runs(p, seeds, args.jobs, extra) for p in args.programs.split(",")}
    print(f"seeds {seeds[0]}..{seeds[-1]} ({len(seeds)})\n")
    print(
        "| scenario | program | last third ÷ no-zone (FA) | trace FA / VA | MSE FA / VA "
        "| robots attacked FA / VA | FA stragglers | consistency (no-zone FA) |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for name in SIX:
        for program, df in found.items():
            print(row(df, name, program))


if __name__ == "__main__":
    main()
