"""Numbers of the generalization benchmark, computed from its summary table.

The summary has one row per run (``summary.summarise_run``) with the tags the catalog gives the
generated arms: ``tag_scenario``, ``tag_method`` (the policy) and ``tag_no_zones`` (the
failure-aware run of the same scenario with ``zones: []``). Every comparison pairs runs of the
same scenario and seed.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy.stats import binomtest

from resilient_tracking.experiments.paired import HEADLINE, Outcomes, scenario_outcomes

POLICIES = ("failure_aware", "vanilla", "sog")


@dataclass(frozen=True)
class Proportion:
    """``k`` of ``n`` with its Wilson score interval."""

    k: int
    n: int
    low: float
    high: float

    @property
    def rate(self) -> float:
        """``k / n``; NaN when ``n`` is 0."""
        return self.k / self.n if self.n else float("nan")

    def __str__(self) -> str:
        if not self.n:
            return "0/0"
        return f"{self.k}/{self.n} = {self.rate:.0%} (95 % CI {self.low:.0%}–{self.high:.0%})"


def wilson(k: int, n: int, confidence: float = 0.95) -> Proportion:
    """``k`` successes in ``n`` trials with the Wilson score interval of the proportion."""
    if n == 0:
        return Proportion(0, 0, float("nan"), float("nan"))
    ci = binomtest(k, n).proportion_ci(confidence_level=confidence, method="wilson")
    return Proportion(k, n, float(ci.low), float(ci.high))


def zone_free_rows(summary: pd.DataFrame) -> pd.Series:
    """Which rows are zone-free reference runs: ``tag_no_zones`` true. A run without the tag (a
    sweep that made no zone-free runs, or a row missing it) is not one."""
    if "tag_no_zones" not in summary:
        return pd.Series(False, index=summary.index)
    return true_tags(summary["tag_no_zones"])


def true_tags(tags: pd.Series) -> pd.Series:
    """Which of a boolean tag's values are true, whether read back as bools or as text (a
    CSV's ``True``; blank or anything else is false)."""
    return tags.map(lambda tag: tag is True or str(tag).strip().lower() == "true").astype(bool)


def _with_zones(summary: pd.DataFrame) -> pd.DataFrame:
    return summary[~zone_free_rows(summary)]


def outcomes(
    summary: pd.DataFrame, metric: str, against: str = "vanilla", policy: str = "failure_aware"
) -> Outcomes:
    """Scenarios in which ``policy`` wins, ties or loses against ``against`` on ``metric``,
    paired by seed (:func:`~.paired.scenario_outcomes`; zone-free runs left out)."""
    return scenario_outcomes(_with_zones(summary), metric, policy, against, arm="policy")[0]


def nozone_ratios(
    summary: pd.DataFrame, policy: str = "failure_aware", reference: str | None = None
) -> pd.Series:
    """Per scenario and seed: ``policy``'s last-third trace ÷ that of the zone-free run of
    ``reference`` (default: the same policy) with the same seed."""
    if "tag_no_zones" not in summary:
        return pd.Series(dtype=float)
    free = zone_free_rows(summary)
    index = ["tag_scenario", "seed"]
    zoned = summary[~free & (summary["policy"] == policy)]
    base = summary[free & (summary["policy"] == (reference or policy))]
    ratios = (
        zoned.groupby(index)["last_third_trace"].mean()
        / base.groupby(index)["last_third_trace"].mean()
    )
    return ratios.dropna()


def zone_kind(kinds: Iterable[str]) -> str:
    """The kind of a scenario whose zones have ``kinds``: ``"with a comm zone"``, ``"sensing
    zones only"`` or ``"no zones"``."""
    kinds = list(kinds)
    if "comm" in kinds:
        return "with a comm zone"
    return "sensing zones only" if kinds else "no zones"


def outcomes_by_kind(
    summary: pd.DataFrame,
    kind_of: Mapping[str, str],
    metric: str,
    against: str = "vanilla",
    policy: str = "failure_aware",
) -> dict[str, Outcomes]:
    """:func:`outcomes` over all scenarios (``"all"``) and per kind (``kind_of`` maps a
    scenario's ``tag_scenario`` to its kind)."""
    rows = _with_zones(summary)
    out = {"all": outcomes(rows, metric, against, policy)}
    if not len(rows):
        return out
    kinds = rows["tag_scenario"].map(lambda name: kind_of[str(name)])
    for kind in sorted(set(kinds)):
        out[kind] = outcomes(rows[kinds == kind], metric, against, policy)
    return out


def straggler_share(summary: pd.DataFrame, policy: str = "failure_aware") -> Proportion:
    """Stragglers among the robots that can still sense at the end, over the suite's runs."""
    rows = _with_zones(summary)
    rows = rows[rows["policy"] == policy]
    return wilson(int(rows["stragglers"].sum()), int(rows["sensing_end"].sum()))


def _circling(rows: pd.DataFrame) -> str:
    """Stragglers circling their attacker, which the paper's Alg. 4 sends away from tracking."""
    if "stragglers_circling" not in rows:
        return "–"
    return f"{int(rows['stragglers_circling'].sum())} of {int(rows['stragglers'].sum())}"


def _quantiles(values: pd.Series) -> str:
    if values.empty:
        return "no pairs"
    return (
        f"median {values.median():.2f}×, 90th percentile {np.percentile(values, 90):.2f}×, "
        f"worst {values.max():.2f}× (over {len(values)} runs: scenario and seed)"
    )


def section(summary: pd.DataFrame) -> str:
    """The benchmark's tables in markdown."""
    lines = [
        "| comparison | MSE | NLL | trace (the paper's measure) |",
        "|---|---|---|---|",
    ]
    for other in ("vanilla", "sog"):
        found = [outcomes(summary, metric, other) for metric in (*HEADLINE, "trace")]
        if found[0].n:
            lines.append(f"| failure_aware vs {other} | " + " | ".join(map(str, found)) + " |")
    ratios = {policy: nozone_ratios(summary, policy) for policy in POLICIES}
    ratio_lines = [f"- {p}: {_quantiles(r)}" for p, r in ratios.items() if not r.empty] or [
        "- no zone-free runs"
    ]
    lost = [
        "| policy | runs | robots | robots lost (sensor or radio destroyed) | robots attacked "
        "| robots sensing at the end | stragglers (> 1.5 m from every target) "
        "| of them circling (radio destroyed) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    no_zones = zone_free_rows(summary)
    groups: list[tuple[str, pd.DataFrame]] = [
        (p, summary[~no_zones & (summary["policy"] == p)]) for p in POLICIES
    ]
    groups.append(("failure_aware, zones removed", summary[no_zones]))
    for label, r in groups:
        if r.empty:
            continue
        robots = int(r["robots"].sum())
        lost.append(
            f"| {label} | {len(r)} | {robots} | {wilson(int(r.robots_lost.sum()), robots)} "
            f"| {wilson(int(r.robots_attacked.sum()), robots)} | {int(r.sensing_end.sum())} "
            f"| {wilson(int(r.stragglers.sum()), int(r.sensing_end.sum()))} "
            f"| {_circling(r)} |"
        )
    return "\n\n".join(
        [
            "**Scenarios won, tied and lost** (per scenario, by the 95 % interval of the "
            "per-seed differences: below zero a win, above a loss, spanning zero a tie)\n\n"
            + "\n".join(lines),
            "**Last-third trace ÷ the zone-free run's** (same policy and seed)\n\n"
            + "\n".join(ratio_lines),
            "**Robots lost and stragglers** (shares of robots; stragglers among those that can "
            "still sense at the end; a robot whose radio a zone destroyed circles its attacker "
            "for good, as the paper's Alg. 4 prescribes, so it is a straggler by design)\n\n"
            + "\n".join(lost),
        ]
    )
