"""Paired comparisons over seeds: the Student-t interval of a mean, and a win, a tie or a loss
per scenario decided by the interval of the per-seed differences (ties apart: an interval that
spans zero decides nothing). Runs of two arms with the same seed meet the same zone draws
(common random numbers), so their difference is what the arms changed."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
import pandas as pd
from scipy import stats

#: The headline metrics wherever the filters compared may differ (docs/model.md §8): the error
#: against truth and a proper scoring rule, neither of which an overconfident filter can win.
HEADLINE: tuple[str, ...] = ("mse", "nll")


def confidence_interval(values: np.ndarray, level: float = 0.95) -> tuple[float, float]:
    """Student-t interval of the mean; NaN bounds with fewer than two values."""
    values = np.asarray(values, dtype=float)
    n = len(values)
    mean = float(values.mean()) if n else float("nan")
    if n < 2:
        return float("nan"), float("nan")
    half = float(stats.t.ppf(0.5 + level / 2, n - 1) * values.std(ddof=1) / np.sqrt(n))
    return mean - half, mean + half


Outcome = Literal["win", "tie", "loss", "short"]


def paired_outcome(differences: np.ndarray, level: float = 0.95) -> Outcome:
    """One comparison decided from its per-seed differences (``mine − theirs``, lower is
    better): ``win`` when their ``level`` Student-t interval lies below zero, ``loss`` above,
    ``tie`` when it spans zero; ``short`` with fewer than two paired seeds."""
    values = np.asarray(differences, dtype=float)
    values = values[np.isfinite(values)]
    if len(values) < 2:
        return "short"
    low, high = confidence_interval(values, level)
    if high < 0:
        return "win"
    if low > 0:
        return "loss"
    return "tie"


@dataclass(frozen=True)
class Outcomes:
    """Scenarios won, tied and lost (ties apart: an interval that spans zero decides nothing),
    and those with fewer than two paired seeds, which decide nothing either."""

    wins: int = 0
    ties: int = 0
    losses: int = 0
    short: int = 0

    @property
    def n(self) -> int:
        """Scenarios compared with at least two paired seeds."""
        return self.wins + self.ties + self.losses

    def __str__(self) -> str:
        text = f"{self.wins} won, {self.ties} tied, {self.losses} lost of {self.n}"
        return text + (f" ({self.short} with fewer than two paired seeds)" if self.short else "")


def scenario_outcomes(
    runs: pd.DataFrame, metric: str, mine: str, theirs: str, arm: str = "tag_team"
) -> tuple[Outcomes, np.ndarray]:
    """Per scenario (``tag_scenario``), ``mine`` against ``theirs`` (values of column ``arm``)
    on ``metric``, paired by seed (:func:`paired_outcome`); and each scenario's mean
    difference (``mine − theirs``)."""
    if not len(runs) or arm not in runs:
        return Outcomes(), np.empty(0)
    wide = runs.pivot_table(index=["tag_scenario", "seed"], columns=arm, values=metric)
    if mine not in wide or theirs not in wide:
        return Outcomes(), np.empty(0)
    diff = (wide[mine] - wide[theirs]).dropna()
    counts = {"win": 0, "tie": 0, "loss": 0, "short": 0}
    means = []
    for _, rows in diff.groupby(level="tag_scenario", sort=False):
        counts[paired_outcome(rows.to_numpy())] += 1
        means.append(float(rows.mean()))
    outcomes = Outcomes(counts["win"], counts["tie"], counts["loss"], counts["short"])
    return outcomes, np.array(means)
