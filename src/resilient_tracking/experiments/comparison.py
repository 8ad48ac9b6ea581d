"""``rtrack compare``: policies side by side on your own scenarios, over seeds.

The runs are stored like those of ``rtrack reproduce`` (``OUT/runs/<scenario>/<policy>/
seed-NNN/``, resumable, a stale run is run again), then summarised in ``OUT/report.md``:

- per scenario and policy, the mean of each time-averaged metric over seeds with its 95 %
  confidence interval (Student's t on the seed means: ``mean ± t₀.₉₇₅,ₙ₋₁ · s/√n``), led by
  MSE and NLL, which judge the estimate against truth (the policies' filters may differ, and
  the covariance trace rewards a filter for being sure rather than right), then ANEES (2 for
  a consistent filter) and the paper's trace;
- paired win counts in MSE and NLL: runs of different policies with the same seed meet the
  same zone draws (common random numbers), so seed by seed one policy either did better or
  did not;
- mean ± 1 std bands over time, box plots over seeds and trajectory snapshots;
- with a zone-free reference (``--zone-free``), each scenario is also run with its zones removed
  (same seeds) and each policy's last-third ratio reported: mean trace over the final third of
  the episode ÷ the zone-free run's, how far the team comes back after the zones struck;
- with ``--by-zone-kind`` (at least two seeds), the first policy's scenarios won, tied and lost
  against each other one in MSE and NLL, split by whether a scenario has a comm zone: a
  scenario is won when the 95 % interval of its per-seed differences lies below zero, lost
  when above, tied when it spans zero.

Seeds are ``N`` (1..N), a range ``A-B`` or a list ``a,b,c``. Each scenario's label (its section,
``OUT/runs/<label>``, ``OUT/<label>/figures``) is unique and one safe folder name
(:mod:`.comparison_labels`). The report's numbers come from :mod:`.comparison_stats`, its tables
from :mod:`.comparison_tables`.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

from resilient_tracking import builtin_scenarios
from resilient_tracking.experiments import report_files
from resilient_tracking.experiments.catalog import Task, Variant
from resilient_tracking.experiments.comparison_labels import scenario_labels
from resilient_tracking.experiments.comparison_stats import (
    RATIO_METRIC,
    last_third_ratios,
    summary_table,
)
from resilient_tracking.experiments.comparison_tables import (
    bound_markdown,
    consistency_markdown,
    differences_markdown,
    summary_markdown,
    wins_markdown,
    zone_free_markdown,
    zone_kinds_markdown,
)
from resilient_tracking.experiments.generalization import (
    outcomes_by_kind,
    wilson,
    zone_free_rows,
    zone_kind,
)
from resilient_tracking.experiments.paired import HEADLINE
from resilient_tracking.experiments.report_files import ReportFiles
from resilient_tracking.experiments.summary import summarise_run
from resilient_tracking.experiments.sweep import is_done, run_dir
from resilient_tracking.runs.folders import folder_name, write_text_atomic
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
    #: whether each run also computes the posterior Cramér–Rao bound
    bound: bool = False
    #: the argument each label was made from (:mod:`.comparison_labels`), shown in the report
    sources: dict[str, str] = field(default_factory=dict)

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
        return [
            Task(label, variant, seed, base.with_overrides(seed=seed), bound=self.bound)
            for seed in self.seeds
        ]

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
    bound: bool = False,
) -> Study:
    """Load and validate everything before anything runs (``ScenarioError`` / ``ValueError``);
    ``seeds`` is a count ``N`` (seeds 1..N) or the seeds themselves."""
    from resilient_tracking.policies import POLICIES

    if not policies:
        raise ValueError(f"--policies: none given; choose from {', '.join(POLICIES.names())}")
    if by_zone_kind and len(set(policies)) < 2:
        raise ValueError("--by-zone-kind: needs at least two --policies to compare")
    if by_zone_kind and (seeds if isinstance(seeds, int) else len(set(seeds))) < 2:
        raise ValueError(
            "--by-zone-kind: needs at least two --seeds (a scenario is won, tied or lost by "
            "the interval of its per-seed differences)"
        )
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
    labels = scenario_labels(scenario_args)
    for label, arg in zip(labels, scenario_args, strict=True):
        scenario = builtin_scenarios.load(arg)
        loaded[label] = overridden(scenario, dict(overrides), f"{scenario.name} (with --set)")
    return Study(
        loaded,
        tuple(dict.fromkeys(policies)),
        seeds,
        tuple(overrides),
        zone_free=zone_free,
        by_zone_kind=by_zone_kind,
        bound=bound,
        sources=dict(zip(labels, map(str, scenario_args), strict=True)),
    )


# ---------------------------------------------------------------------------- report


def zone_kind_win_rates(runs: pd.DataFrame, study: Study) -> pd.DataFrame:
    """The first policy's scenarios won, tied and lost against each other one, in MSE and NLL
    (paired by seed, :func:`~.paired.paired_outcome`), over all scenarios and per zone kind,
    with the Wilson 95 % interval of the share won."""
    first, kinds = study.policies[0], study.zone_kinds()
    rows = []
    for against in study.policies[1:]:
        for metric in HEADLINE:
            found = outcomes_by_kind(runs, kinds, metric, against, first)
            for kind, o in found.items():
                won = wilson(o.wins, o.n)
                rows.append(
                    {
                        "policy": first,
                        "against": against,
                        "kind": kind,
                        "metric": metric,
                        "wins": o.wins,
                        "ties": o.ties,
                        "losses": o.losses,
                        "scenarios": o.n,
                        "rate": won.rate,
                        "ci95_low": won.low,
                        "ci95_high": won.high,
                        "text": str(o),
                    }
                )
    return pd.DataFrame(rows)


def scenario_section(
    label: str,
    tasks: list[Task],
    out: Path,
    reference: str | None = None,
    source: str | None = None,
) -> tuple[str, pd.DataFrame]:
    """Markdown and per-run rows of one scenario, from its stored runs; draws its figures.
    With a zone-free ``reference`` policy the rows say which runs are the reference
    (``tag_no_zones``), and the section gives each policy's last-third ratio. ``source``: the
    argument the label was made from, said under the heading when it differs."""
    done = [t for t in tasks if is_done(out, t)]
    header = f"## {label}"
    if source is not None and source != label:
        header += f"\n\nScenario {_code(source)}."
    header = f"{header}\n\n{tasks[0].scenario.description}".rstrip()
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
            "MSE, NLL, trace and effort over time: mean ± 1 std over seeds",
            plot_bands(by_policy, figures / "bands.png", (*BAND_METRICS, *EFFORT_METRIC), label),
        ),
        (
            "time-averaged metrics, one point per seed",
            plot_policy_boxes(zoned, figures / "boxes.png", ("mse", "nll", "trace", "effort")),
        ),
    ]
    for policy, rs in by_policy.items():
        drawn.append(
            (
                f"snapshots, {policy}, seed {rs[0].seed}",
                plot_snapshots(rs[0], figures / f"snapshots-{folder_name(policy)}.png"),
            )
        )
    parts = [
        header,
        f"{len(done)} of {len(tasks)} runs finished.",
        "Mean over seeds of each time-averaged metric, its 95 % confidence interval in brackets, "
        "and in how many seeds the policy did strictly better than every other one "
        "(lower is better, except survival steps).",
        summary_markdown(summary_table(zoned)),
        consistency_markdown(zoned),
        "**Paired wins** (same seed, so the same zone draws):",
        wins_markdown(zoned),
        "**Paired differences** (same seed): the mean over seeds of row − column and its 95 % "
        "interval; an interval below zero means the row is lower, above zero the column:",
        differences_markdown(zoned),
    ]
    if zoned["bound"].notna().any():
        parts.append(bound_markdown(zoned))
    if reference is not None:
        parts.append(zone_free_markdown(runs, reference))
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
            label,
            [t for t in tasks if t.experiment == label],
            out,
            study.zone_free,
            study.sources.get(label),
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
            kinds = zone_kinds_markdown(rates)
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


def _code(text: str) -> str:
    """``text`` as a Markdown code span (fenced by more backticks than it holds in a row), its
    unprintable characters escaped."""
    shown = "".join(
        c if c.isprintable() else c.encode("unicode_escape").decode("ascii", "replace")
        for c in text
    )
    fence = "`" * (max((len(run) for run in re.findall("`+", shown)), default=0) + 1)
    pad = " " if shown.startswith("`") or shown.endswith("`") else ""
    return f"{fence}{pad}{shown}{pad}{fence}"
