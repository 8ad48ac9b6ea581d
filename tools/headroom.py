"""Headroom of caution: per scenario, the best of a grid of fixed caution settings chosen in
hindsight (a reference, not a team), against vanilla and the paper's team.

The grid varies one thing of the team ``route`` (the paper's method at its fixed risk levels)
at a time: each zone kind's risk level (the paper's value, ×0.2, ×5, or ×3 for ε2, whose ×5 is
not a probability below ½), no avoidance of that kind (zero slack weights), and each bundle of
extensions (the beyond team's mechanisms, the adaptive estimator). The default team, which
prices caution, is measured beside it. Scenarios: the three stored suites on seeds 1–2, and
the shipped scenarios of the paper, the beyond and the adversarial experiments on seeds 1–4.
Runs are stored under ``OUT/runs`` like ``rtrack reproduce``'s (the reproduction's own runs
are reused), so an interrupted measurement resumes::

    python tools/headroom.py --out docs/results --jobs 2

writes ``OUT/headroom.md`` and ``OUT/headroom.csv`` (one row per run).
"""

from __future__ import annotations

import argparse
import json
import logging
import shutil
import sys
from collections.abc import Iterable
from itertools import zip_longest
from pathlib import Path
from typing import Any

import pandas as pd

from resilient_tracking.experiments.arms import Task, Variant, team_arm
from resilient_tracking.experiments.catalog import (
    ADVERSARIAL,
    BEYOND,
    SIX,
    _generated_arm,
    _shipped,
)
from resilient_tracking.experiments.generator import (
    stored_adversarial_suite,
    stored_beyond_suite,
    stored_suite,
)
from resilient_tracking.experiments.paired import scenario_outcomes
from resilient_tracking.experiments.summary import summarise_run
from resilient_tracking.experiments.sweep import is_done, run_dir, run_sweep
from resilient_tracking.policies.failure_aware_params import FailureAwareParams
from resilient_tracking.runs.reading import load_run
from resilient_tracking.scenario import Scenario
from resilient_tracking.scenario.teams import get_team

log = logging.getLogger("headroom")


def _no_slack(kind: str) -> dict[str, Any]:
    """The three weight sets of eq. 10 with zero slack weight on ``kind``'s chance
    constraints: its zones are known but not avoided."""
    defaults = FailureAwareParams()
    field = "sensing_slack" if kind == "sensing" else "comm_slack"
    return {
        f"policy.failure_aware.{name}": getattr(defaults, name).model_dump() | {field: 0.0}
        for name in ("risky", "safe", "cooldown")
    }


_ROUTE = {"team": "route"}
#: What the beyond team adds to the default team's settings.
_BEYOND = {
    path: value
    for path, value in get_team("beyond").settings.items()
    if path not in get_team("default").settings
}

#: The caution grid: label → settings over the team ``route``, by dotted path.
GRID: dict[str, dict[str, Any]] = {
    "route": _ROUTE,
    "eps1-x0.2": _ROUTE | {"policy.failure_aware.eps1": 0.004},
    "eps1-x5": _ROUTE | {"policy.failure_aware.eps1": 0.1},
    "sensing-off": _ROUTE | _no_slack("sensing"),
    "eps2-x0.2": _ROUTE | {"policy.failure_aware.eps2": 0.03},
    "eps2-x3": _ROUTE | {"policy.failure_aware.eps2": 0.45},
    "comm-off": _ROUTE | _no_slack("comm") | {"guards.comm_hazard.enabled": False},
    "beyond-route": _ROUTE | _BEYOND,
    "adaptive": _ROUTE | {"estimator.type": "adaptive"},
}
#: The references every oracle is measured against.
BASELINES = ("vanilla", "paper")
#: Teams measured beside the oracle: label → settings.
CANDIDATES: dict[str, dict[str, Any]] = {
    "default": {"team": "default"},
    "evidence": _ROUTE | {"estimator.type": "adaptive", "estimator.on_evidence": True},
    "default-redundancy": {"team": "default", "guards.priced.information_share": False},
    "default-permanent-x2": {"team": "default", "guards.priced.reference_share": 0.5},
    "default-silence-0.45": {"team": "default", "belief.provisional_zone.std": 0.45},
    "default-silence-0.6": {"team": "default", "belief.provisional_zone.std": 0.6},
    "beyond": {"team": "beyond"},
}


def arms() -> dict[str, Variant]:
    """Every arm by label: the grid's and the candidates' (failure-aware), and the
    baselines' teams."""
    out = {
        label: Variant(label, "failure_aware", settings)
        for label, settings in (GRID | CANDIDATES).items()
    }
    for team in BASELINES:
        # the paper's team on its own program, although a generated suite's files name the route
        out[team] = team_arm(team, over_file=team == "paper")
    return out


def cases() -> list[tuple[str, Scenario, int]]:
    """(suite, scenario, seeds): the shipped scenarios on 4 seeds, then the stored suites on 2,
    taken in turn (one scenario of each suite, then the next), so that a measurement stopped
    early has covered every suite alike."""
    found: list[tuple[str, Scenario, int]] = []
    for suite, names in (
        ("paper", SIX),
        ("beyond-shipped", BEYOND),
        ("adversarial-shipped", ADVERSARIAL),
    ):
        found += [(suite, s, 4) for s in _shipped(names, None)]
    suites = [
        [("generalization", s, 2) for s in stored_suite()],
        [("beyond", s, 2) for s in stored_beyond_suite()],
        [("adversarial", s, 2) for s in stored_adversarial_suite()],
    ]
    found += [case for turn in zip_longest(*suites) for case in turn if case is not None]
    return found


def tasks(chosen: Iterable[str] | None = None, suites: Iterable[str] | None = None) -> list[Task]:
    """Every run of the measurement (only the arms ``chosen`` and the ``suites``, if given)."""
    table = arms()
    labels = list(chosen or table)
    unknown = sorted(set(labels) - set(table))
    if unknown:
        raise SystemExit(f"--arms: unknown arm(s) {', '.join(unknown)}; known: {', '.join(table)}")
    out = []
    picked = cases()
    if suites is not None:
        known = {suite for suite, _, _ in picked}
        wanted = set(suites)
        if wanted - known:
            raise SystemExit(
                f"--suites: unknown suite(s) {', '.join(sorted(wanted - known))}; "
                f"known: {', '.join(sorted(known))}"
            )
        picked = [case for case in picked if case[0] in wanted]
    for suite, scenario, seeds in picked:
        for label in labels:
            arm = table[label]
            variant = Variant(
                f"{scenario.name}-{label}",
                arm.policy,
                arm.overrides,
                tags={"suite": suite, "scenario": scenario.name, "arm": label},
            )
            arm_scenario = _generated_arm(scenario, variant)
            out += [
                Task(f"headroom-{suite}", variant, seed, arm_scenario.with_overrides(seed=seed))
                for seed in range(1, seeds + 1)
            ]
    return out


def adopt_stored(out: Path, runs: list[Task]) -> int:
    """Copy into place every run not yet stored whose fingerprint a run stored elsewhere under
    ``out/runs`` carries (the reproduction's own runs of the same arm); returns how many."""
    wanted = {t.fingerprint: t for t in runs if not is_done(out, t)}
    adopted = 0
    for manifest in (out / "runs").glob("*/*/seed-*/manifest.json"):
        try:
            fingerprint = json.loads(manifest.read_text())["fingerprint"]
        except (OSError, ValueError, KeyError):
            continue
        task = wanted.pop(fingerprint, None)
        if task is not None and manifest.parent != run_dir(out, task):
            target = run_dir(out, task)
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copytree(manifest.parent, target)
            adopted += 1
    return adopted


def summary(out: Path, runs: list[Task]) -> pd.DataFrame:
    """One row per stored run, with its suite, scenario and arm."""
    rows = []
    for t in runs:
        if not is_done(out, t):
            continue
        row = summarise_run(load_run(run_dir(out, t)))
        rows.append({**{f"tag_{k}": v for k, v in t.variant.tags.items()}, **row})
    return pd.DataFrame(rows)


def oracle_rows(runs: pd.DataFrame, metric: str) -> pd.DataFrame:
    """Per (suite, scenario, seed), the value of the grid arm with the lowest mean ``metric``
    over that scenario's seeds (chosen in hindsight), as arm ``oracle``; with which arm it was."""
    grid = runs[runs["tag_arm"].isin(GRID)]
    means = grid.groupby(["tag_suite", "tag_scenario", "tag_arm"])[metric].mean()
    best = means.groupby(level=[0, 1]).idxmin().map(lambda key: key[2]).rename("best")
    picked = grid.merge(best, left_on=["tag_suite", "tag_scenario"], right_index=True)
    picked = picked[picked["tag_arm"] == picked["best"]].copy()
    picked["tag_arm"] = "oracle"
    return picked


def _share(runs: pd.DataFrame, metric: str, mine: str, theirs: str) -> str:
    """Scenarios won/tied/lost by ``mine`` against ``theirs`` (paired seeds), with the share
    won of those decided."""
    c, _ = scenario_outcomes(runs, metric, mine, theirs, arm="tag_arm")
    decided = c.wins + c.losses
    rate = f"{c.wins / decided:.0%}" if decided else "–"
    return f"{c.wins}/{c.ties}/{c.losses} ({rate})"


def complete(runs: pd.DataFrame) -> pd.DataFrame:
    """The runs of the scenarios on which every arm of the grid ran on every seed."""
    grid = runs[runs["tag_arm"].isin(GRID)]
    counts = grid.groupby(["tag_suite", "tag_scenario"])["tag_arm"].nunique()
    full = counts[counts == len(GRID)].index
    keys = pd.MultiIndex.from_frame(runs[["tag_suite", "tag_scenario"]])
    return runs[keys.isin(full)]


def _above(runs: pd.DataFrame, mine: str, theirs: str, factor: float = 1.1) -> str:
    """Scenarios where ``mine``'s mean MSE is more than ``factor`` times ``theirs``."""
    means = runs.groupby(["tag_scenario", "tag_arm"])["mse"].mean().unstack()
    if mine not in means or theirs not in means:
        return "–"
    both = means[[mine, theirs]].dropna()
    return f"{int((both[mine] > factor * both[theirs]).sum())}/{len(both)}"


def report(runs: pd.DataFrame) -> str:
    """The markdown: per suite and metric, the oracle's and each team's outcomes against
    vanilla and the paper's team, which grid arm the oracle picked, and the losses."""
    teams = [
        t for t in ("oracle", "route", *CANDIDATES) if t == "oracle" or t in set(runs["tag_arm"])
    ]
    lines = [
        "# Headroom of caution: the best fixed setting per scenario, in hindsight",
        "",
        "The oracle is a reference, not a team: per scenario, the arm of the caution grid with",
        "the lowest mean over that scenario's seeds, chosen after the fact, on the scenarios where",
        "the whole grid ran. Entries are scenarios won/tied/lost by the paired 95 % interval over",
        "seeds, the share won of those decided in brackets; `> 1.1× paper`: scenarios whose mean",
        "MSE is more than 1.1 times the paper team's. Made by `python tools/headroom.py`.",
        "",
        "Grid: " + ", ".join(f"`{g}`" for g in GRID) + ".",
        "",
        "| suite | metric | team | scenarios | vs vanilla | vs paper | > 1.1× paper |",
        "|---|---|---|---|---|---|---|",
    ]
    picks_lines = [
        "",
        "| suite | scenarios with the whole grid | the oracle's picks (MSE) |",
        "|---|---|---|",
    ]
    for suite, rows in runs.groupby("tag_suite", sort=False):
        full = complete(rows)
        for metric in ("mse", "nll"):
            for team in teams:
                if team == "oracle":
                    if not len(full):
                        continue
                    both = pd.concat([full, oracle_rows(full, metric)])
                else:
                    both = rows
                n = both[both["tag_arm"] == team]["tag_scenario"].nunique()
                cells = [_share(both, metric, team, theirs) for theirs in BASELINES]
                above = _above(both, team, "paper") if metric == "mse" else ""
                lines.append(
                    f"| {suite} | {metric.upper()} | {team} | {n} | "
                    + " | ".join(cells)
                    + f" | {above} |"
                )
        if len(full):
            picks = oracle_rows(full, "mse").drop_duplicates("tag_scenario")["best"]
            counts = ", ".join(f"`{k}` {v}" for k, v in picks.value_counts().items())
            picks_lines.append(f"| {suite} | {full['tag_scenario'].nunique()} | {counts} |")
    lines += picks_lines
    lines += [
        "",
        "Permanent losses to zones the robot already knew, as a share of permanent losses (the",
        "paper's six and the generalization suite), and `combined-perm` runs that end with a",
        "working sensor:",
        "",
        "| team | known / permanent losses | `combined-perm` runs sensing at the end |",
        "|---|---|---|",
    ]
    six = runs[runs["tag_suite"].isin(["paper", "generalization"])]
    for arm, rows in six.groupby("tag_arm"):
        known = int(rows["losses_known_permanent"].sum())
        total = known + int(rows["losses_unknown_permanent"].sum())
        cp = rows[rows["tag_scenario"] == "combined-perm"]
        share = f"{known}/{total} ({known / total:.1%})" if total else "–"
        lines.append(f"| {arm} | {share} | {int((cp['sensing_end'] > 0).sum())}/{len(cp)} |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=Path("docs/results"))
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--arms", nargs="*", help="only these arms (default: all)")
    parser.add_argument("--suites", nargs="*", help="only these suites (default: all)")
    parser.add_argument("--report-only", action="store_true", help="summarise what is stored")
    parser.add_argument(
        "--also", nargs="*", type=Path, default=[], help="headroom.csv files of other runs to add"
    )
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    runs = tasks(args.arms, args.suites)
    if not args.report_only:
        done = [0]

        def progress(task: Task, ran: bool) -> None:
            done[0] += 1
            if ran and done[0] % 50 == 0:
                log.info("%d/%d", done[0], len(runs))

        log.info("%d run(s) adopted from the reproduction", adopt_stored(args.out, runs))
        run_sweep(runs, args.out, jobs=args.jobs, on_done=progress)
    table = summary(args.out, runs)
    if args.also:
        table = pd.concat([table, *(pd.read_csv(f) for f in args.also)], ignore_index=True)
        table = table.drop_duplicates(["tag_suite", "tag_scenario", "tag_arm", "seed"])
    table.to_csv(args.out / "headroom.csv", index=False)
    (args.out / "headroom.md").write_text(report(table))
    print(report(table))
    return 0


if __name__ == "__main__":
    sys.exit(main())
