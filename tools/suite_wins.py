"""Win rates of failure-aware against vanilla over generated suites, overall and split by
whether a scenario has a comm zone (docs/generalization.md, "Where the shortfall is").

Usage (from the repository root), one ``SUITE_DIR:COMPARE_DIR`` pair per suite, where
``SUITE_DIR`` holds the scenario files of ``rtrack generate`` and ``COMPARE_DIR`` the output
of ``rtrack compare SUITE_DIR/*.yaml --policies failure_aware,vanilla``::

    python tools/suite_wins.py gen60:all60 s7:cmp7 s11:cmp11

Each line: scenarios, lower mean trace and lower mean MSE (failure-aware against vanilla,
the compare folder's seeds averaged per scenario), with Wilson 95 % intervals.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import pandas as pd

from resilient_tracking.experiments.generalization import paired, wilson
from resilient_tracking.scenario import load_scenario

PAIR = ("failure_aware", "vanilla")


def kind_of(scenario_file: Path) -> str:
    """``"sensing only"`` or ``"with a comm zone"``."""
    zones = load_scenario(scenario_file).zones
    return "with a comm zone" if any(z.kind == "comm" for z in zones) else "sensing only"


def suite_rows(suite: Path, runs: Path) -> pd.DataFrame:
    """One row per scenario: its kind and whether failure-aware won in trace and in MSE
    (the two policies' runs paired by scenario and seed, then averaged over seeds)."""
    table = pd.read_csv(runs / "runs.csv")
    wins = {}
    for metric in ("trace", "mse"):
        means = paired(table, metric, PAIR).groupby(level="tag_scenario").mean()
        wins[f"{metric}_win"] = means["failure_aware"] < means["vanilla"]
    rows = pd.DataFrame(wins)
    rows.insert(0, "kind", [kind_of(suite / f"{name}.yaml") for name in rows.index])
    rows.insert(0, "suite", suite.name)
    return rows.reset_index(drop=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("pairs", nargs="+", help="SUITE_DIR:COMPARE_DIR")
    args = parser.parse_args()
    frames = []
    for pair in args.pairs:
        suite, _, runs = pair.partition(":")
        frames.append(suite_rows(Path(suite), Path(runs)))
    rows = pd.concat(frames, ignore_index=True)
    groups = [(s, rows[rows.suite == s]) for s in rows.suite.unique()]
    if len(groups) > 1:
        groups.append(("all suites", rows))
    print("| suites | scenarios | kind | lower mean trace | lower mean MSE |")
    print("|---|---|---|---|---|")
    for label, part in groups:
        for kind in ("all", "sensing only", "with a comm zone"):
            sel = part if kind == "all" else part[part.kind == kind]
            n = len(sel)
            trace = wilson(int(sel.trace_win.sum()), n)
            mse = wilson(int(sel.mse_win.sum()), n)
            print(f"| {label} | {n} | {kind} | {trace} | {mse} |")


if __name__ == "__main__":
    main()
