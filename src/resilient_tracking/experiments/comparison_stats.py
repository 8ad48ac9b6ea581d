"""The statistics of ``rtrack compare``'s report: from one row per run (the summary of
:func:`~resilient_tracking.experiments.summary.summarise_run` with the run's scenario label),
paired win counts, the summary table per scenario and policy, and each run's last-third ratio
to its zone-free reference run (intervals and paired outcomes: :mod:`.paired`)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd

from resilient_tracking.experiments.generalization import nozone_ratios, zone_free_rows
from resilient_tracking.experiments.paired import confidence_interval

#: Metrics of the summary table: column of the per-run summary, label, whether lower is better
#: (for ``anees``, see :data:`TARGET_VALUES`). MSE and NLL lead; the covariance trace, which an
#: overconfident filter wins, comes after them.
METRICS: tuple[tuple[str, str, bool], ...] = (
    ("mse", "MSE [m²]", True),
    ("nll", "NLL [nats]", True),
    ("anees", "ANEES (2 when consistent)", True),
    ("trace", "trace [m²]", True),
    ("effort", "effort [m/s]", True),
    ("sensing_attacks", "sensing attacks", True),
    ("comm_attacks", "comm attacks", True),
    ("robots_attacked", "robots attacked", True),
    ("survival_steps", "survival steps", False),
)

#: Metrics whose best value is a target, not the lowest: the distance to it is what is lower.
TARGET_VALUES: dict[str, float] = {"anees": 2.0}

#: The metric of the zone-free comparison: last-third trace ÷ the zone-free reference's.
RATIO_METRIC = ("last_third_ratio", "last third ÷ zone-free", True)


def _better(mine: pd.Series, theirs: pd.Series, metric: str, lower: bool) -> pd.Series:
    """Seeds in which ``mine`` did strictly better than ``theirs`` on ``metric``."""
    if metric in TARGET_VALUES:
        target = TARGET_VALUES[metric]
        return (mine - target).abs() < (theirs - target).abs()
    return mine < theirs if lower else mine > theirs


def wins(runs: pd.DataFrame, metric: str, lower_is_better: bool = True) -> pd.DataFrame:
    """Paired win counts of one metric: entry (a, b) is the number of seeds in which policy
    ``a`` did strictly better than policy ``b`` (same scenario, same seed)."""
    table = runs.pivot_table(index="seed", columns="policy", values=metric)
    policies = list(table.columns)
    out = pd.DataFrame(0, index=policies, columns=policies)
    for a in policies:
        for b in policies:
            if a != b:
                out.loc[a, b] = int(_better(table[a], table[b], metric, lower_is_better).sum())
    return out


def paired_differences(runs: pd.DataFrame, metric: str) -> pd.DataFrame:
    """Per pair of policies ``(a, b)``, the mean over paired seeds of ``a − b`` on ``metric``
    and its 95 % Student-t interval (columns ``mean``, ``low``, ``high``, ``n``)."""
    table = runs.pivot_table(index="seed", columns="policy", values=metric)
    rows = []
    for a in table.columns:
        for b in table.columns:
            if a != b:
                diff = (table[a] - table[b]).dropna().to_numpy()
                low, high = confidence_interval(diff)
                mean = float(diff.mean()) if len(diff) else float("nan")
                rows.append(dict(a=a, b=b, mean=mean, low=low, high=high, n=len(diff)))
    return pd.DataFrame(rows, columns=["a", "b", "mean", "low", "high", "n"])


def summary_table(
    runs: pd.DataFrame, metrics: Sequence[tuple[str, str, bool]] = METRICS
) -> pd.DataFrame:
    """One row per (scenario, policy, metric): n, mean, std, 95 % CI, seeds where best."""
    rows = []
    for (scenario, policy), group in runs.groupby(["scenario", "policy"], sort=False):
        same = runs[runs["scenario"] == scenario]
        for metric, _, lower in metrics:
            table = same.pivot_table(index="seed", columns="policy", values=metric)
            others = table.drop(columns=policy)
            mine = table[policy]
            best_in = (
                int(
                    np.logical_and.reduce(
                        [_better(mine, others[o], metric, lower) for o in others.columns]
                    ).sum()
                )
                if others.shape[1]
                else 0
            )
            values = group[metric].to_numpy(dtype=float)
            low, high = confidence_interval(values)
            rows.append(
                {
                    "scenario": scenario,
                    "policy": policy,
                    "metric": metric,
                    "n": len(values),
                    "mean": float(values.mean()),
                    "std": float(values.std(ddof=1)) if len(values) > 1 else float("nan"),
                    "ci95_low": low,
                    "ci95_high": high,
                    "best_in": best_in,
                }
            )
    return pd.DataFrame(rows)


def last_third_ratios(runs: pd.DataFrame, reference: str) -> pd.DataFrame:
    """One row per (scenario, policy, seed) with a zone-free run of ``reference`` at the same
    seed: ``last_third_ratio``, the run's last-third trace ÷ the zone-free run's."""
    free = zone_free_rows(runs)
    frames = [
        nozone_ratios(runs, policy, reference)
        .rename(RATIO_METRIC[0])
        .reset_index()
        .assign(policy=policy)
        for policy in runs.loc[~free, "policy"].unique()
    ]
    frames = [f for f in frames if len(f)]
    if not frames:
        return pd.DataFrame(columns=["scenario", "policy", "seed", RATIO_METRIC[0]])
    ratios = pd.concat(frames, ignore_index=True).rename(columns={"tag_scenario": "scenario"})
    order = {name: i for i, name in enumerate(dict.fromkeys(runs["scenario"]))}
    ratios = ratios.iloc[np.argsort(ratios["scenario"].map(order).to_numpy(), kind="stable")]
    return ratios[["scenario", "policy", "seed", RATIO_METRIC[0]]].reset_index(drop=True)
