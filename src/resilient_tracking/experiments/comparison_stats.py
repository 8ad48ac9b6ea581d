"""The statistics of ``rtrack compare``'s report: the Student-t confidence interval of a mean
over seeds and, from one row per run (the summary of
:func:`~resilient_tracking.experiments.summary.summarise_run` with the run's scenario label),
paired win counts, the summary table per scenario and policy, and each run's last-third ratio
to its zone-free reference run."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd
from scipy import stats

from resilient_tracking.experiments.generalization import nozone_ratios, zone_free_rows

#: Metrics of the summary table: column of the per-run summary, label, whether lower is better.
METRICS: tuple[tuple[str, str, bool], ...] = (
    ("trace", "trace [m²]", True),
    ("mse", "MSE [m²]", True),
    ("effort", "effort [m/s]", True),
    ("sensing_attacks", "sensing attacks", True),
    ("comm_attacks", "comm attacks", True),
    ("robots_attacked", "robots attacked", True),
    ("survival_steps", "survival steps", False),
)

#: The metric of the zone-free comparison: last-third trace ÷ the zone-free reference's.
RATIO_METRIC = ("last_third_ratio", "last third ÷ zone-free", True)


def confidence_interval(values: np.ndarray, level: float = 0.95) -> tuple[float, float]:
    """Student-t interval of the mean; NaN bounds with fewer than two values."""
    values = np.asarray(values, dtype=float)
    n = len(values)
    mean = float(values.mean()) if n else float("nan")
    if n < 2:
        return float("nan"), float("nan")
    half = float(stats.t.ppf(0.5 + level / 2, n - 1) * values.std(ddof=1) / np.sqrt(n))
    return mean - half, mean + half


def wins(runs: pd.DataFrame, metric: str, lower_is_better: bool = True) -> pd.DataFrame:
    """Paired win counts of one metric: entry (a, b) is the number of seeds in which policy
    ``a`` did strictly better than policy ``b`` (same scenario, same seed)."""
    table = runs.pivot_table(index="seed", columns="policy", values=metric)
    policies = list(table.columns)
    out = pd.DataFrame(0, index=policies, columns=policies)
    for a in policies:
        for b in policies:
            if a != b:
                better = table[a] < table[b] if lower_is_better else table[a] > table[b]
                out.loc[a, b] = int(better.sum())
    return out


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
            if others.shape[1]:
                best = others.min(axis=1) if lower else others.max(axis=1)
                mine = table[policy]
                best_in = int((mine < best).sum() if lower else (mine > best).sum())
            else:
                best_in = 0
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
