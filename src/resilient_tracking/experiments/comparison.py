"""``rtrack compare``: policies side by side on your own scenarios, over seeds.

The runs are stored like those of ``rtrack reproduce`` (``OUT/runs/<scenario>/<policy>/
seed-NNN/``, resumable, a stale run is run again), then summarised in ``OUT/report.md``:

- per scenario and policy, the mean of each time-averaged metric over seeds with its 95 %
  confidence interval (Student's t on the seed means: ``mean ± t₀.₉₇₅,ₙ₋₁ · s/√n``);
- paired win counts: runs of different policies with the same seed meet the same zone draws
  (common random numbers), so seed by seed one policy either did better or did not;
- mean ± 1 std bands over time, box plots over seeds and trajectory snapshots;
- with a zone-free reference (``--zone-free``), each scenario is also run with its zones removed
  (same seeds) and each policy's last-third ratio reported: mean trace over the final third of
  the episode ÷ the zone-free run's, how far the team comes back after the zones struck;
- with ``--by-zone-kind``, the first policy's win rates against each other one over the
  scenarios, split by whether a scenario has a comm zone, with Wilson intervals.

Seeds are ``N`` (1..N), a range ``A-B`` or a list ``a,b,c``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from scipy import stats

from resilient_tracking import builtin_scenarios
from resilient_tracking.experiments import report_files
from resilient_tracking.experiments.catalog import Task, Variant
from resilient_tracking.experiments.generalization import (
    nozone_ratios,
    win_rates_by_kind,
    zone_free_rows,
    zone_kind,
)
from resilient_tracking.experiments.report_files import ReportFiles
from resilient_tracking.experiments.summary import STRAGGLER_DISTANCE, summarise_run
from resilient_tracking.experiments.sweep import is_done, run_dir
from resilient_tracking.runs.folders import write_text_atomic
from resilient_tracking.runs.reading import RunData, load_run
from resilient_tracking.scenario import Scenario
from resilient_tracking.scenario.overrides import overridden
from resilient_tracking.viz.sweeps import (
    BAND_METRICS,
    EFFORT_METRIC,
    plot_bands,
    plot_policy_boxes,
    plot_snapshots,
)
from resilient_tracking.yaml_io import YamlInputError, parse_yaml

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

#: Label suffix of the zone-free reference runs (``OUT/runs/<scenario>/<policy>-nozone/``).
NOZONE = "-nozone"


@dataclass(frozen=True)
class Study:
    """What ``rtrack compare`` was asked: scenarios (label → validated scenario), policies,
    seeds, the overrides applied to every scenario, the policy of the zone-free reference runs
    (``None``: no reference) and whether to split win rates by zone kind."""

    scenarios: dict[str, Scenario]
    policies: tuple[str, ...]
    seeds: tuple[int, ...]
    overrides: tuple[tuple[str, object], ...] = ()
    zone_free: str | None = None
    by_zone_kind: bool = False

    def tasks(self) -> list[Task]:
        """Every run, validated: one per (scenario, policy, seed), then one per (scenario,
        seed) of the zone-free reference."""
        out = []
        for label, scenario in self.scenarios.items():
            for policy in self.policies:
                variant = Variant(policy, policy, tags={"scenario": label})
                base = overridden(scenario, {"policy.name": policy}, f"{label} [{policy}]")
                out += self._seeded(label, variant, base)
            if self.zone_free is not None:
                variant = Variant(
                    self.zone_free + NOZONE,
                    self.zone_free,
                    tags={"scenario": label, "no_zones": True},
                )
                source = f"{label} [{variant.label}]"
                free = overridden(scenario, {"policy.name": self.zone_free, "zones": []}, source)
                out += self._seeded(label, variant, free)
        return out

    def _seeded(self, label: str, variant: Variant, base: Scenario) -> list[Task]:
        return [Task(label, variant, seed, base.with_overrides(seed=seed)) for seed in self.seeds]

    def zone_kinds(self) -> dict[str, str]:
        """Each scenario's kind by label (:func:`~.generalization.zone_kind`)."""
        return {
            label: zone_kind(k for z in s.zones for k in z.kinds)
            for label, s in self.scenarios.items()
        }


def parse_seeds(text: str, most: int) -> tuple[int, ...]:
    """``--seeds``: ``N`` is seeds 1..N, ``A-B`` seeds A..B, ``a,b,c`` those seeds; at most
    ``most`` of them (``ValueError`` naming the option otherwise)."""
    text = text.strip()
    try:
        if "," in text:
            seeds = tuple(dict.fromkeys(int(part) for part in text.split(",")))
        elif "-" in text.lstrip("-"):
            low, _, high = text.partition("-")
            seeds = tuple(range(int(low), int(high) + 1))
            if not seeds:
                raise ValueError(f"--seeds: {text!r} is an empty range")
        else:
            count = int(text)
            if not 1 <= count <= most:
                raise ValueError(f"--seeds: must be between 1 and {most} (got {count})")
            return tuple(range(1, count + 1))
    except ValueError as err:
        if str(err).startswith("--seeds"):
            raise
        raise ValueError(f"--seeds: expected N, A-B or a,b,c (got {text!r})") from None
    if min(seeds) < 0:
        raise ValueError(f"--seeds: seeds must be non-negative (got {min(seeds)})")
    if len(seeds) > most:
        raise ValueError(f"--seeds: at most {most} seeds (got {len(seeds)})")
    return seeds


def describe_seeds(seeds: Sequence[int]) -> str:
    """``1..5`` for consecutive seeds, ``1, 3, 7`` otherwise."""
    if list(seeds) == list(range(seeds[0], seeds[0] + len(seeds))):
        return f"{seeds[0]}..{seeds[-1]}"
    return ", ".join(str(s) for s in seeds)


def parse_override(text: str) -> tuple[str, object]:
    """``dotted.path=value`` → (path, value); the value is read as YAML (``0.05``, ``[1, 2]``)
    by the rules scenario files are read with (``1e-3`` is a number, as in YAML 1.2)."""
    path, sep, value = text.partition("=")
    if not sep or not path.strip():
        raise ValueError(f"--set: expected dotted.path=value (got {text!r})")
    try:
        return path.strip(), parse_yaml(value)
    except YamlInputError as err:
        raise ValueError(f"--set {path.strip()}: {err.reason}") from None


def make_study(
    scenario_args: Sequence[str],
    policies: Sequence[str],
    seeds: int | Sequence[int],
    overrides: Sequence[tuple[str, object]] = (),
    zone_free: str | None = None,
    by_zone_kind: bool = False,
) -> Study:
    """Load and validate everything before anything runs (``ScenarioError`` / ``ValueError``);
    ``seeds`` is a count ``N`` (seeds 1..N) or the seeds themselves."""
    from resilient_tracking.policies import POLICIES

    if not policies:
        raise ValueError(f"--policies: none given; choose from {', '.join(POLICIES.names())}")
    if by_zone_kind and len(set(policies)) < 2:
        raise ValueError("--by-zone-kind: needs at least two --policies to compare")
    named = [("--policies", name) for name in policies]
    if zone_free is not None:
        named.append(("--zone-free", zone_free))
    for option, name in named:
        why = POLICIES.problem(name)
        if why is not None:
            raise ValueError(f"{option}: {why}")
    seeds = tuple(range(1, seeds + 1)) if isinstance(seeds, int) else tuple(seeds)
    if not seeds:
        raise ValueError("--seeds: none given")
    loaded: dict[str, Scenario] = {}
    for arg in scenario_args:
        label = Path(arg).stem if Path(arg).suffix in (".yaml", ".yml") else str(arg)
        if label in loaded:
            label = f"{label}-{len(loaded) + 1}"
        scenario = builtin_scenarios.load(arg)
        loaded[label] = overridden(scenario, dict(overrides), f"{scenario.name} (with --set)")
    return Study(
        loaded,
        tuple(dict.fromkeys(policies)),
        seeds,
        tuple(overrides),
        zone_free=zone_free,
        by_zone_kind=by_zone_kind,
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


def _markdown_zone_free(runs: pd.DataFrame, reference: str) -> str:
    free = zone_free_rows(runs)
    base, zoned = runs[free], runs[~free]
    if base.empty:
        return "**Zone-free reference**: no finished runs."
    consistency = (base["targets"] * base["mse"] / base["trace"]).mean()
    lines = [
        f"**Zone-free reference** ({reference} with the zones removed, same seeds): trace "
        f"{_fmt(base['trace'].mean())}, MSE {_fmt(base['mse'].mean())}, filter consistency "
        f"N · MSE / trace {consistency:.2f} (1 when the filter's covariance matches its "
        "errors). Per policy, the mean over seeds of the **last-third ratio** (mean trace over "
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


def zone_kind_win_rates(runs: pd.DataFrame, study: Study) -> pd.DataFrame:
    """The first policy's win rates against each other one (lower mean over seeds, scenario
    by scenario), over all scenarios and per zone kind, with Wilson 95 % intervals."""
    first, kinds = study.policies[0], study.zone_kinds()
    rows = []
    for against in study.policies[1:]:
        for metric in ("trace", "mse"):
            rates = win_rates_by_kind(runs, kinds, metric, against, first)
            rows += [
                {
                    "policy": first,
                    "against": against,
                    "kind": kind,
                    "metric": metric,
                    "wins": p.k,
                    "scenarios": p.n,
                    "rate": p.rate,
                    "ci95_low": p.low,
                    "ci95_high": p.high,
                    "text": str(p),
                }
                for kind, p in rates.items()
            ]
    return pd.DataFrame(rows)


def _markdown_zone_kinds(rates: pd.DataFrame) -> str:
    lines = [
        "## Win rates by zone kind",
        "",
        "Share of scenarios in which the first policy has the lower mean over seeds, with the "
        "Wilson 95 % interval; a scenario has a comm zone or only sensing zones.",
        "",
        "| comparison | kind | scenarios | lower mean trace | lower mean MSE |",
        "|---|---|---|---|---|",
    ]
    for (policy, against, kind), rows in rates.groupby(["policy", "against", "kind"], sort=False):
        text = rows.set_index("metric")["text"]
        n = int(rows["scenarios"].iloc[0])
        lines.append(f"| {policy} vs {against} | {kind} | {n} | {text['trace']} | {text['mse']} |")
    return "\n".join(lines) + "\n"


def scenario_section(
    label: str, tasks: list[Task], out: Path, reference: str | None = None
) -> tuple[str, pd.DataFrame]:
    """Markdown and per-run rows of one scenario, from its stored runs; draws its figures.
    With a zone-free ``reference`` policy the rows say which runs are the reference
    (``tag_no_zones``), and the section gives each policy's last-third ratio."""
    done = [t for t in tasks if is_done(out, t)]
    header = f"## {label}\n\n{tasks[0].scenario.description}".rstrip()
    by_policy: dict[str, list[RunData]] = {}
    rows = []
    for t in done:
        run = load_run(run_dir(out, t))
        free = bool(t.variant.tags.get("no_zones", False))
        row = {"scenario": label, **summarise_run(run)}
        if reference is not None:
            row["tag_no_zones"] = free
        rows.append(row)
        if not free:
            by_policy.setdefault(t.variant.policy, []).append(run)
    if not by_policy:
        return header + "\n\nNo finished runs.\n", pd.DataFrame()
    runs = pd.DataFrame(rows)
    zoned = runs[~zone_free_rows(runs)]
    figures = out / label / "figures"
    drawn = [
        (
            "MSE, trace and effort over time: mean ± 1 std over seeds",
            plot_bands(by_policy, figures / "bands.png", (*BAND_METRICS, *EFFORT_METRIC), label),
        ),
        (
            "time-averaged metrics, one point per seed",
            plot_policy_boxes(zoned, figures / "boxes.png", ("trace", "mse", "effort")),
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
        _markdown_summary(summary_table(zoned)),
        "**Paired wins** (same seed, so the same zone draws):",
        _markdown_wins(zoned),
    ]
    if reference is not None:
        parts.append(_markdown_zone_free(runs, reference))
    parts += [f"![{caption}]({path.relative_to(out).as_posix()})" for caption, path in drawn]
    return "\n\n".join(parts) + "\n", runs


def files_of_report(study: Study) -> ReportFiles:
    """What :func:`write_compare_report` writes into its folder: the report, its tables and
    each scenario's figures folder."""
    return ReportFiles(
        ("report.md", "runs.csv", "summary.csv", "win_rates.csv"),
        tuple(f"{label}/figures" for label in study.scenarios),
    )


def write_compare_report(study: Study, tasks: list[Task], out: Path, command: str) -> Path:
    """``out/report.md``, ``out/runs.csv`` (one row per run), ``out/summary.csv`` and, with
    ``by_zone_kind``, ``out/win_rates.csv``. ``FileExistsError`` before writing if a file it
    would replace was not written by rtrack (:mod:`.report_files`)."""
    out = Path(out)
    written = files_of_report(study)
    report_files.claim(out, written)
    sections, frames = [], []
    for label in study.scenarios:
        text, runs = scenario_section(
            label, [t for t in tasks if t.experiment == label], out, study.zone_free
        )
        sections.append(text)
        frames.append(runs)
    runs = (
        pd.concat([f for f in frames if len(f)], ignore_index=True)
        if any(len(f) for f in frames)
        else pd.DataFrame()
    )
    kinds = ""
    if len(runs):
        runs.to_csv(out / "runs.csv", index=False)
        table = summary_table(runs[~zone_free_rows(runs)])
        if study.zone_free is not None:
            ratios = summary_table(last_third_ratios(runs, study.zone_free), (RATIO_METRIC,))
            table = pd.concat([table, ratios], ignore_index=True)
        table.to_csv(out / "summary.csv", index=False)
        if study.by_zone_kind:
            rates = zone_kind_win_rates(runs, study)
            rates.drop(columns="text").to_csv(out / "win_rates.csv", index=False)
            kinds = _markdown_zone_kinds(rates)
    overrides = ", ".join(f"`{p}={v}`" for p, v in study.overrides) or "none"
    reference = (
        f"; zone-free reference runs of {study.zone_free}" if study.zone_free is not None else ""
    )
    lines = [
        "# Policy comparison",
        "",
        f"Produced by `{command}`: policies {', '.join(study.policies)}; seeds "
        f"{describe_seeds(study.seeds)}; overrides {overrides}{reference}. Per-run rows in "
        "`runs.csv`, the tables below in `summary.csv`"
        + (", the win rates in `win_rates.csv`" if kinds else "")
        + ".",
        "",
        *([kinds] if kinds else []),
        *sections,
    ]
    path = write_text_atomic(out / "report.md", "\n".join(lines))
    report_files.seal(out, written)
    return path
