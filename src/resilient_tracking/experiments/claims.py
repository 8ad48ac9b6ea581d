"""The paper's claims (docs/model.md §8), checked on an experiment's summary table.

Each check returns :class:`Claim` objects that say whether the claim holds and give the
numbers it was decided on, so that a report can state plainly which ones do not.
"""

from __future__ import annotations

from dataclasses import dataclass

import pandas as pd

from resilient_tracking.experiments.catalog import Experiment
from resilient_tracking.experiments.comparison_stats import confidence_interval
from resilient_tracking.experiments.generalization import (
    Proportion,
    straggler_share,
    wilson,
    win_rate,
)


@dataclass(frozen=True)
class Claim:
    """One of the paper's claims checked on an experiment's summary: the statement, whether it
    holds, and the numbers that decide it."""

    experiment: str
    statement: str
    holds: bool
    evidence: str


def _mean(df: pd.DataFrame, column: str, **where: object) -> float:
    rows = df
    for key, value in where.items():
        rows = rows[rows[key] == value]
    return float(rows[column].mean()) if len(rows) else float("nan")


def adaptive_beats_vanilla(exp: Experiment, s: pd.DataFrame) -> list[Claim]:
    """Claims of a ``pair`` experiment: the failure-aware policy has a lower time-averaged trace,
    and a lower MSE, than vanilla (mean over seeds, with the per-seed win count as evidence)."""
    out = []
    for metric in ("trace", "mse"):
        fa = _mean(s, metric, policy="failure_aware")
        va = _mean(s, metric, policy="vanilla")
        wins = s.pivot_table(index="seed", columns="policy", values=metric)
        n_wins = int((wins["failure_aware"] < wins["vanilla"]).sum()) if len(wins) else 0
        out.append(
            Claim(
                exp.name,
                f"adaptive < vanilla in time-averaged {metric}",
                fa < va,
                f"{fa:.4g} vs {va:.4g} (mean over {len(wins)} seeds; adaptive lower in "
                f"{n_wins}/{len(wins)})",
            )
        )
    if exp.keeps_sensing:
        out.append(keeps_a_sensor(exp, s))
    return out


def keeps_a_sensor(exp: Experiment, s: pd.DataFrame) -> Claim:
    """The paper's combined narrative: in most seeds at least one failure-aware robot keeps
    sensing to the end."""
    fa = s[s["policy"] == "failure_aware"]
    alive = int((fa["sensing_end"] >= 1).sum())
    return Claim(
        exp.name,
        "adaptive: in most seeds at least one robot keeps sensing to the end",
        alive > len(fa) / 2,
        f"{alive}/{len(fa)} seeds end with a sensing robot "
        f"(mean {fa['sensing_end'].mean():.2f} sensing robots at the end)",
    )


def risky_fails_more(exp: Experiment, s: pd.DataFrame) -> list[Claim]:
    """Claims of a ``risk`` experiment: for each method (ours, SOG) the risky setting ends with more
    failed sensors than the conservative one, on average over seeds."""
    out = []
    for method in ("ours", "sog"):
        risky = _mean(s, "sensing_failed_end", tag_method=method, tag_risk="risky")
        safe = _mean(s, "sensing_failed_end", tag_method=method, tag_risk="conservative")
        out.append(
            Claim(
                exp.name,
                f"{method}: the risky setting loses more sensors than the conservative one",
                risky > safe,
                f"robots with a failed sensor at the end, mean over seeds: risky {risky:.2f}, "
                f"conservative {safe:.2f}",
            )
        )
    return out


def more_robots_lower_trace(exp: Experiment, s: pd.DataFrame) -> list[Claim]:
    """Claims of a ``scale`` experiment: for each method and number of targets, the mean trace with
    the largest team is below that with the smallest."""
    out = []
    for (method, targets), rows in s.groupby(["tag_method", "targets"]):
        means = rows.groupby("robots")["trace"].mean().sort_index()
        falls = int((means.diff().dropna() < 0).sum())
        out.append(
            Claim(
                exp.name,
                f"{method}, {targets} targets: mean trace falls as robots are added",
                bool(means.iloc[-1] < means.iloc[0]),
                ", ".join(f"{r} robots {v:.4g}" for r, v in means.items())
                + f" ({falls}/{len(means) - 1} steps fall)",
            )
        )
    return out


def only_conservative_survives(exp: Experiment, s: pd.DataFrame) -> list[Claim]:
    """Claims of a ``complex`` experiment: for each method, the conservative setting keeps a sensing
    robot to the end in more than half of the seeds and the risky one in fewer than half."""
    out = []
    alive = s.assign(survivor=s["sensing_failed_end"] < s["robots"])
    for method in ("ours", "sog"):
        share = {
            risk: float(
                alive[(alive.tag_method == method) & (alive.tag_risk == risk)].survivor.mean()
            )
            for risk in ("risky", "regular", "conservative")
        }
        out.append(
            Claim(
                exp.name,
                f"{method}: in most seeds the conservative setting keeps a sensing robot to "
                "the end and the risky one does not",
                share["conservative"] > 0.5 > share["risky"],
                "share of seeds with a sensing robot alive at the end: "
                + ", ".join(f"{k} {v:.0%}" for k, v in share.items()),
            )
        )
    return out


#: The targets set for the generated suite (docs/generalization.md): shares of scenarios
#: (trace, MSE) in which failure-aware beats vanilla, and the largest share of stragglers among
#: sensing robots.
GENERALIZATION_TARGETS = {"trace": 0.9, "mse": 0.8, "stragglers": 0.1}


def generalization_targets(exp: Experiment, s: pd.DataFrame) -> list[Claim]:
    """Claims of the ``generalization`` benchmark: failure-aware beats vanilla in trace and in MSE
    in at least the target share of generated scenarios, and at most the target share of its
    still-sensing robots end as stragglers."""
    out = []
    for metric in ("trace", "mse"):
        wins, target = win_rate(s, metric), GENERALIZATION_TARGETS[metric]
        out.append(
            Claim(
                exp.name,
                f"failure-aware has a lower mean {metric} than vanilla in at least "
                f"{target:.0%} of the generated scenarios",
                wins.n > 0 and wins.rate >= target,
                str(wins),
            )
        )
    share, target = straggler_share(s), GENERALIZATION_TARGETS["stragglers"]
    out.append(
        Claim(
            exp.name,
            f"at most {target:.0%} of the failure-aware robots that can still sense at the end "
            "are stragglers (> 1.5 m from every target)",
            share.n > 0 and share.rate <= target,
            str(share),
        )
    )
    return out


#: With lures, the guarded team's permanent losses per run at most this share of the default
#: team's, at a time-mean trace at most this factor of its (docs/model.md §8).
LURE_LOSS_SHARE = 0.5
LURE_TRACE_FACTOR = 1.2


def _paired(s: pd.DataFrame, metric: str, better: str, worse: str) -> tuple[float, float, str]:
    """Means of ``metric`` for teams ``better`` and ``worse`` and the 95 % interval of their
    per-seed difference (``better − worse``), as evidence text."""
    table = s.pivot_table(index="seed", columns="tag_team", values=metric)
    diff = (table[better] - table[worse]).dropna().to_numpy()
    low, high = confidence_interval(diff)
    wins = int((diff < 0).sum())
    a, b = float(table[better].mean()), float(table[worse].mean())
    return (
        a,
        b,
        (
            f"{a:.4g} vs {b:.4g}; difference 95 % CI [{low:.3g}, {high:.3g}]; "
            f"lower in {wins}/{len(diff)} seeds"
        ),
    )


#: The two teams an experiment's extended team (the team named after the experiment's kind:
#: ``adversarial``, ``beyond``) is compared with, and how claims name them.
OTHER_TEAMS = (("default", "the default team"), ("vanilla", "vanilla"))


def _extended_lower(exp: Experiment, name: str, rows: pd.DataFrame) -> list[Claim]:
    """Per scenario: the experiment's extended team has a lower mean trace and MSE than each
    other team, with the 95 % interval of the per-seed differences."""
    out = []
    for other, who in OTHER_TEAMS:
        for metric in ("trace", "mse"):
            a, b, evidence = _paired(rows, metric, exp.kind, other)
            out.append(
                Claim(
                    exp.name,
                    f"{name}: the {exp.kind} team has a lower mean {metric} than {who}",
                    a < b,
                    evidence,
                )
            )
    return out


def adversarial_targets(exp: Experiment, s: pd.DataFrame) -> list[Claim]:
    """Targets of the ``adversarial`` experiment, per shipped scenario (``tag_part``
    ``shipped``): the ``adversarial`` team has a lower mean trace and MSE than the default team
    and than vanilla; with lures, the guarded team's (the adversarial team with the lure guard)
    permanent losses per run are at most :data:`LURE_LOSS_SHARE` of the default team's at a trace
    at most :data:`LURE_TRACE_FACTOR` times its. On the stored
    adversarial suite (``suite``) it has the lower mean trace in at least
    :data:`ADVERSARIAL_SUITE_TARGET` of the scenarios."""
    part = s["tag_part"] if "tag_part" in s else pd.Series("shipped", index=s.index)
    out = []
    for name, rows in s[part == "shipped"].groupby("tag_scenario", sort=False):
        out += _extended_lower(exp, str(name), rows)
        if (rows.tag_team == "guarded").any():  # targets that lure: the guard's losses
            losses = rows.losses_known_permanent + rows.losses_unknown_permanent
            guarded = float(losses[rows.tag_team == "guarded"].mean())
            default = float(losses[rows.tag_team == "default"].mean())
            trace_guarded = _mean(rows, "trace", tag_team="guarded")
            trace_default = _mean(rows, "trace", tag_team="default")
            out.append(
                Claim(
                    exp.name,
                    f"{name}: with the lure guard, permanent losses per run at most "
                    f"{LURE_LOSS_SHARE:.0%} of the default team's, at a trace at most "
                    f"{LURE_TRACE_FACTOR}× its",
                    guarded <= LURE_LOSS_SHARE * default
                    and trace_guarded <= LURE_TRACE_FACTOR * trace_default,
                    f"losses {guarded:.2f} vs {default:.2f} per run; trace {trace_guarded:.4g} vs "
                    f"{trace_default:.4g}",
                )
            )
    suite = s[part == "suite"]
    for metric in ("trace", "mse"):
        out += _suite_claims(exp, suite, "adversarial", ADVERSARIAL_SUITE_TARGET, metric)
    return out


#: The share of the stored adversarial suite's scenarios in which the extended team is to have
#: the lower mean trace, and the lower mean MSE, than the default team and than vanilla
#: (docs/adversarial.md).
ADVERSARIAL_SUITE_TARGET = {"default": 0.85, "vanilla": 0.85}


def _suite_claims(
    exp: Experiment,
    suite: pd.DataFrame,
    label: str,
    targets: dict[str, float],
    metric: str = "trace",
) -> list[Claim]:
    """Per other team, whether the extended team has the lower mean ``metric`` in at least
    ``targets[other]`` of the scenarios of ``suite`` (none when it has no runs)."""
    if not len(suite):
        return []
    out = []
    for other, who in OTHER_TEAMS:
        wins, evidence = suite_wins(suite, exp.kind, other, metric)
        target = targets[other]
        out.append(
            Claim(
                exp.name,
                f"{label} suite: the {exp.kind} team has a lower mean {metric} than {who} in "
                f"at least {target:.0%} of the scenarios",
                wins.n > 0 and wins.rate >= target,
                evidence,
            )
        )
    return out


#: The targets set for the stored beyond suite (docs/beyond.md): shares of its scenarios in
#: which the extended team has the lower mean trace than the default team and than vanilla.
BEYOND_SUITE_TARGETS = {"default": 0.85, "vanilla": 0.9}


def suite_wins(
    suite: pd.DataFrame, extended: str, other: str, metric: str = "trace"
) -> tuple[Proportion, str]:
    """Scenarios of a suite in which the extended team's mean ``metric`` over its seeds is
    below ``other``'s, with the Wilson interval, and as evidence also the ties and the 95 %
    interval of the per-scenario differences."""
    means = suite.pivot_table(index="tag_scenario", columns="tag_team", values=metric)
    if extended not in means or other not in means:
        return wilson(0, 0), "no paired runs"
    pair = means[[extended, other]].dropna()
    diff = (pair[extended] - pair[other]).to_numpy()
    wins = wilson(int((diff < 0).sum()), len(diff))
    if not len(diff):
        return wins, "no paired runs"
    low, high = confidence_interval(diff)
    return wins, (
        f"{wins}; equal in {int((diff == 0).sum())}; mean difference {diff.mean():.3g}, "
        f"95 % CI [{low:.3g}, {high:.3g}]"
    )


def beyond_targets(exp: Experiment, s: pd.DataFrame) -> list[Claim]:
    """Targets of the ``beyond`` experiment: per shipped scenario (``tag_part`` ``shipped``),
    the ``beyond`` team has a lower mean trace and MSE than the default team and than vanilla;
    on the stored beyond suite (``suite``) it has the lower mean trace in at least
    :data:`BEYOND_SUITE_TARGETS` of the scenarios."""
    part = s["tag_part"] if "tag_part" in s else pd.Series("shipped", index=s.index)
    out = []
    for name, rows in s[part == "shipped"].groupby("tag_scenario", sort=False):
        out += _extended_lower(exp, str(name), rows)
    out += _suite_claims(exp, s[part == "suite"], "beyond", BEYOND_SUITE_TARGETS)
    return out


CHECKS = {
    "pair": adaptive_beats_vanilla,
    "risk": risky_fails_more,
    "scale": more_robots_lower_trace,
    "complex": only_conservative_survives,
    "generalization": generalization_targets,
    "adversarial": adversarial_targets,
    "beyond": beyond_targets,
}


def check(exp: Experiment, summary: pd.DataFrame) -> list[Claim]:
    """Every claim of docs/model.md §8 that applies to ``exp``."""
    return CHECKS[exp.kind](exp, summary)
