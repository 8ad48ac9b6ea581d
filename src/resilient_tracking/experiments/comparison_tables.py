"""The Markdown tables of ``rtrack compare``'s report: the summary per policy, the paired wins,
the zone-free reference's last-third ratios and the win rates by zone kind, from the per-run
rows or the tables of their numbers (:mod:`.comparison_stats`)."""

from __future__ import annotations

import numpy as np
import pandas as pd

from resilient_tracking.experiments.comparison_stats import (
    METRICS,
    RATIO_METRIC,
    last_third_ratios,
    paired_differences,
    wins,
)
from resilient_tracking.experiments.generalization import zone_free_rows
from resilient_tracking.experiments.paired import confidence_interval
from resilient_tracking.experiments.summary import STRAGGLER_DISTANCE


def _fmt(x: float) -> str:
    return "–" if not np.isfinite(x) else f"{x:.4g}"


def summary_markdown(table: pd.DataFrame) -> str:
    """One row per policy of a scenario's :func:`~.comparison_stats.summary_table`: each
    metric's mean, its 95 % interval and in how many seeds the policy was best."""
    head = "| policy | runs | " + " | ".join(label for _, label, _ in METRICS) + " |"
    lines = [head, "|" + "---|" * (len(METRICS) + 2)]
    for policy, rows in table.groupby("policy", sort=False):
        cells = []
        for metric, _, _ in METRICS:
            r = rows[rows["metric"] == metric].iloc[0]
            ci = (
                "" if not np.isfinite(r.ci95_low) else f" [{_fmt(r.ci95_low)}, {_fmt(r.ci95_high)}]"
            )
            cells.append(f"{_fmt(r['mean'])}{ci}; best in {r.best_in}")
        lines.append(f"| {policy} | {int(rows['n'].iloc[0])} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def wins_markdown(runs: pd.DataFrame) -> str:
    """The paired win counts of MSE and NLL (:func:`~.comparison_stats.wins`) of a scenario's
    runs, one table per metric."""
    parts = []
    for metric, label, lower in METRICS[:2]:
        w = wins(runs, metric, lower)
        lines = [
            f"| {label}: row better than column, seeds | " + " | ".join(w.columns) + " |",
            "|" + "---|" * (len(w.columns) + 1),
        ]
        for a in w.index:
            lines.append(
                f"| {a} | "
                + " | ".join("–" if a == b else str(int(w.loc[a, b])) for b in w.columns)
                + " |"
            )
        parts.append("\n".join(lines))
    return "\n\n".join(parts)


def differences_markdown(runs: pd.DataFrame) -> str:
    """The paired differences of MSE and NLL (:func:`~.comparison_stats.paired_differences`)
    of a scenario's runs, one table per metric: row − column, mean over paired seeds and its
    95 % interval (an interval below zero: the row is better, whatever the seeds' spread)."""
    parts = []
    for metric, label, _ in METRICS[:2]:
        d = paired_differences(runs, metric)
        policies = list(dict.fromkeys(d["a"]))
        lines = [
            f"| {label}: row − column, mean [95 % interval] | " + " | ".join(policies) + " |",
            "|" + "---|" * (len(policies) + 1),
        ]
        for a in policies:
            cells = []
            for b in policies:
                if a == b:
                    cells.append("–")
                    continue
                r = d[(d["a"] == a) & (d["b"] == b)].iloc[0]
                interval = "" if not np.isfinite(r.low) else f" [{_fmt(r.low)}, {_fmt(r.high)}]"
                cells.append(f"{_fmt(r['mean'])}{interval}")
            lines.append(f"| {a} | " + " | ".join(cells) + " |")
        parts.append("\n".join(lines))
    return "\n\n".join(parts)


def zone_free_markdown(runs: pd.DataFrame, reference: str) -> str:
    """The zone-free reference runs of policy ``reference`` among a scenario's runs, and each
    policy's last-third ratio to them with its 95 % interval and its stragglers."""
    free = zone_free_rows(runs)
    base, zoned = runs[free], runs[~free]
    if base.empty:
        return "**Zone-free reference**: no finished runs."
    lines = [
        f"**Zone-free reference** ({reference} with the zones removed, same seeds): MSE "
        f"{_fmt(base['mse'].mean())}, NLL {_fmt(base['nll'].mean())}, ANEES "
        f"{_fmt(base['anees'].mean())} (2 when the filter's covariance matches its errors), "
        f"trace {_fmt(base['trace'].mean())}. Per policy, the mean over seeds of the "
        "**last-third ratio** (mean trace over "
        "the final third of the episode ÷ the reference's at the same seed; 1: at the end the "
        "team tracks as well as without zones) with its 95 % confidence interval, and the "
        f"stragglers (robots that can sense at the end but are more than "
        f"{STRAGGLER_DISTANCE:g} m from every target) among the robots that can sense:",
        "",
        f"| policy | {RATIO_METRIC[1]} | stragglers |",
        "|---|---|---|",
    ]
    ratios = last_third_ratios(runs, reference)
    for policy, rows in zoned.groupby("policy", sort=False):
        values = ratios.loc[ratios["policy"] == policy, RATIO_METRIC[0]].to_numpy(dtype=float)
        low, high = confidence_interval(values)
        ci = "" if not np.isfinite(low) else f" [{_fmt(low)}, {_fmt(high)}]"
        mean = _fmt(float(values.mean())) if len(values) else "–"
        far = f"{int(rows['stragglers'].sum())}/{int(rows['sensing_end'].sum())}"
        lines.append(f"| {policy} | {mean}{ci} | {far} |")
    return "\n".join(lines)


def consistency_markdown(runs: pd.DataFrame) -> str:
    """Per policy, the runs whose ANEES lies inside its 95 % χ² band, and the band (its width
    depends on a run's steps and targets only)."""
    low, high = float(runs["anees_low"].min()), float(runs["anees_high"].max())
    band = f"[{low:.3g}, {high:.3g}]" if np.isclose(low, runs["anees_low"].max()) else "per run"
    cells = ", ".join(
        f"{policy} {int(rows['anees_in_band'].astype(bool).sum())}/{len(rows)}"
        for policy, rows in runs.groupby("policy", sort=False)
    )
    return (
        f"**Consistency**: runs whose ANEES lies inside its 95 % band {band} (2 when the "
        f"filter's covariance matches its errors; the band takes the steps as independent, so "
        f"it is strict): {cells}."
    )


def bound_markdown(runs: pd.DataFrame) -> str:
    """Per policy, the mean posterior Cramér–Rao bound over seeds and the efficiency (mean bound
    ÷ mean MSE, pooled over seeds: 1 for an estimator that meets the bound)."""
    exact = bool(runs["bound_exact"].astype(bool).all())
    lines = [
        "**Posterior Cramér–Rao bound** of the target positions along the paths flown, with the "
        "measurements the robots had; "
        + (
            "every target moves by the linear-Gaussian model, so it is a true bound:"
            if exact
            else "some targets follow scripted paths, where the bound uses the estimator's "
            "model and is only indicative:"
        ),
        "",
        "| policy | bound [m²] | MSE [m²] | efficiency (bound ÷ MSE) |",
        "|---|---|---|---|",
    ]
    for policy, rows in runs.groupby("policy", sort=False):
        bound, mse = float(rows["bound"].mean()), float(rows["mse"].mean())
        lines.append(f"| {policy} | {_fmt(bound)} | {_fmt(mse)} | {bound / mse:.3f} |")
    return "\n".join(lines)


def zone_kinds_markdown(rates: pd.DataFrame) -> str:
    """The section of the outcomes by zone kind, from their table (one row per comparison,
    kind and metric, with the outcomes as ``text``)."""
    lines = [
        "## Scenarios won, tied and lost, by zone kind",
        "",
        "Per scenario, the first policy against each other one: won when the 95 % interval of "
        "the per-seed differences lies below zero, lost when above, tied when it spans zero; a "
        "scenario has a comm zone or only sensing zones.",
        "",
        "| comparison | kind | MSE | NLL |",
        "|---|---|---|---|",
    ]
    for (policy, against, kind), rows in rates.groupby(["policy", "against", "kind"], sort=False):
        text = rows.set_index("metric")["text"]
        lines.append(f"| {policy} vs {against} | {kind} | {text['mse']} | {text['nll']} |")
    return "\n".join(lines) + "\n"
