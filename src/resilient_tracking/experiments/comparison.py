"""``rtrack compare``: policies side by side on your own scenarios, over seeds.

The runs are stored like those of ``rtrack reproduce`` (``OUT/runs/<scenario>/<policy>/
seed-NNN/``, resumable, a stale run is run again), then summarised in ``OUT/report.md``:

- per scenario and policy, the mean of each time-averaged metric over seeds with its 95 %
  confidence interval (Student's t on the seed means: ``mean ± t₀.₉₇₅,ₙ₋₁ · s/√n``);
- paired win counts: runs of different policies with the same seed meet the same zone draws
  (common random numbers), so seed by seed one policy either did better or did not;
- mean ± 1 std bands over time, box plots over seeds and trajectory snapshots.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import yaml
from scipy import stats

from resilient_tracking import scenarios
from resilient_tracking.experiments.catalog import Task, Variant, set_path
from resilient_tracking.experiments.summary import summarise_run
from resilient_tracking.experiments.sweep import is_done, run_dir
from resilient_tracking.runs.folders import write_text_atomic
from resilient_tracking.runs.reading import RunData, load_run
from resilient_tracking.scenario import Scenario, ScenarioError, parse_scenario
from resilient_tracking.viz.sweeps import (
    BAND_METRICS,
    EFFORT_METRIC,
    plot_bands,
    plot_policy_boxes,
    plot_snapshots,
)

#: Metrics of the summary table: column of the per-run summary, label, whether lower is better.
METRICS: tuple[tuple[str, str, bool], ...] = (
    ("trace", "trace [m²]", True),
    ("mse", "MSE [m²]", True),
    ("effort", "effort [m/s]", True),
    ("sensing_attacks", "sensing attacks", True),
    ("comm_attacks", "comm attacks", True),
    ("survival_steps", "survival steps", False),
)


@dataclass(frozen=True)
class Study:
    """What ``rtrack compare`` was asked: scenarios (label → validated scenario), policies,
    seeds and the overrides applied to every scenario."""

    scenarios: dict[str, Scenario]
    policies: tuple[str, ...]
    seeds: tuple[int, ...]
    overrides: tuple[tuple[str, object], ...] = ()

    def tasks(self) -> list[Task]:
        """Every run, validated: one per (scenario, policy, seed)."""
        out = []
        for label, scenario in self.scenarios.items():
            for policy in self.policies:
                data = scenario.model_dump(mode="json")
                data["policy"]["name"] = policy
                variant = Variant(policy, policy, tags={"scenario": label})
                base = parse_scenario(data, f"{label} [{policy}]")
                out += [
                    Task(label, variant, seed, base.with_overrides(seed=seed))
                    for seed in self.seeds
                ]
        return out


def parse_override(text: str) -> tuple[str, object]:
    """``dotted.path=value`` → (path, value); the value is read as YAML (``0.05``, ``[1, 2]``)."""
    path, sep, value = text.partition("=")
    if not sep or not path.strip():
        raise ValueError(f"--set: expected dotted.path=value (got {text!r})")
    try:
        return path.strip(), yaml.safe_load(value)
    except yaml.YAMLError as err:
        raise ValueError(f"--set {path}: value is not valid YAML ({err})") from None


def apply_overrides(scenario: Scenario, overrides: Sequence[tuple[str, object]]) -> Scenario:
    """A validated copy of ``scenario`` with each dotted path set; a path that does not exist or
    a value the schema refuses raises :class:`ScenarioError` naming the field."""
    if not overrides:
        return scenario
    data = scenario.model_dump(mode="json")
    for path, value in overrides:
        try:
            set_path(data, path, value)
        except (IndexError, KeyError, TypeError):
            raise ScenarioError(
                scenario.name, [f"{path}: no such field to set (got {value!r})"]
            ) from None
    return parse_scenario(data, f"{scenario.name} (with --set)")


def make_study(
    scenario_args: Sequence[str],
    policies: Sequence[str],
    n_seeds: int,
    overrides: Sequence[tuple[str, object]] = (),
) -> Study:
    """Load and validate everything before anything runs (``ScenarioError`` / ``ValueError``)."""
    from resilient_tracking.policies import POLICIES
    from resilient_tracking.registry import UnknownName

    if not policies:
        raise ValueError(f"--policies: none given; choose from {', '.join(POLICIES.names())}")
    for name in policies:
        try:
            POLICIES.get(name)
        except UnknownName as err:
            raise ValueError(f"--policies: {err}") from None
    if n_seeds < 1:
        raise ValueError(f"--seeds: must be at least 1 (got {n_seeds})")
    loaded: dict[str, Scenario] = {}
    for arg in scenario_args:
        label = Path(arg).stem if Path(arg).suffix in (".yaml", ".yml") else str(arg)
        if label in loaded:
            label = f"{label}-{len(loaded) + 1}"
        loaded[label] = apply_overrides(scenarios.load(arg), overrides)
    return Study(
        loaded, tuple(dict.fromkeys(policies)), tuple(range(1, n_seeds + 1)), tuple(overrides)
    )


# ---------------------------------------------------------------------------- summary


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


def summary_table(runs: pd.DataFrame) -> pd.DataFrame:
    """One row per (scenario, policy, metric): n, mean, std, 95 % CI, seeds where best."""
    rows = []
    for (scenario, policy), group in runs.groupby(["scenario", "policy"], sort=False):
        same = runs[runs["scenario"] == scenario]
        for metric, _, lower in METRICS:
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


# ---------------------------------------------------------------------------- report


def _fmt(x: float) -> str:
    return "–" if not np.isfinite(x) else f"{x:.4g}"


def _markdown_summary(table: pd.DataFrame) -> str:
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


def _markdown_wins(runs: pd.DataFrame) -> str:
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


def scenario_section(label: str, tasks: list[Task], out: Path) -> tuple[str, pd.DataFrame]:
    """Markdown and per-run rows of one scenario, from its stored runs; draws its figures."""
    done = [t for t in tasks if is_done(out, t)]
    header = f"## {label}\n\n{tasks[0].scenario.description}".rstrip()
    if not done:
        return header + "\n\nNo finished runs.\n", pd.DataFrame()
    by_policy: dict[str, list[RunData]] = {}
    for t in done:
        by_policy.setdefault(t.variant.policy, []).append(load_run(run_dir(out, t)))
    runs = pd.DataFrame(
        [{"scenario": label, **summarise_run(r)} for rs in by_policy.values() for r in rs]
    )
    figures = out / label / "figures"
    drawn = [
        (
            "MSE, trace and effort over time: mean ± 1 std over seeds",
            plot_bands(by_policy, figures / "bands.png", (*BAND_METRICS, *EFFORT_METRIC), label),
        ),
        (
            "time-averaged metrics, one point per seed",
            plot_policy_boxes(runs, figures / "boxes.png", ("trace", "mse", "effort")),
        ),
    ]
    for policy, rs in by_policy.items():
        drawn.append(
            (
                f"snapshots, {policy}, seed {rs[0].seed}",
                plot_snapshots(rs[0], figures / f"snapshots-{policy}.png"),
            )
        )
    parts = [
        header,
        f"{len(done)} of {len(tasks)} runs finished.",
        "Mean over seeds of each time-averaged metric, its 95 % confidence interval in brackets, "
        "and in how many seeds the policy did strictly better than every other one "
        "(lower is better, except survival steps).",
        _markdown_summary(summary_table(runs)),
        "**Paired wins** (same seed, so the same zone draws):",
        _markdown_wins(runs),
        *[f"![{caption}]({path.relative_to(out).as_posix()})" for caption, path in drawn],
    ]
    return "\n\n".join(parts) + "\n", runs


def write_compare_report(study: Study, tasks: list[Task], out: Path, command: str) -> Path:
    """``out/report.md``, ``out/runs.csv`` (one row per run) and ``out/summary.csv``."""
    out = Path(out)
    sections, frames = [], []
    for label in study.scenarios:
        text, runs = scenario_section(label, [t for t in tasks if t.experiment == label], out)
        sections.append(text)
        frames.append(runs)
    runs = (
        pd.concat([f for f in frames if len(f)], ignore_index=True)
        if any(len(f) for f in frames)
        else pd.DataFrame()
    )
    if len(runs):
        runs.to_csv(out / "runs.csv", index=False)
        summary_table(runs).to_csv(out / "summary.csv", index=False)
    overrides = ", ".join(f"`{p}={v}`" for p, v in study.overrides) or "none"
    lines = [
        "# Policy comparison",
        "",
        f"Produced by `{command}`: policies {', '.join(study.policies)}; seeds "
        f"{study.seeds[0]}..{study.seeds[-1]}; overrides {overrides}. Per-run rows in "
        "`runs.csv`, the table below in `summary.csv`.",
        "",
        *sections,
    ]
    return write_text_atomic(out / "report.md", "\n".join(lines))
