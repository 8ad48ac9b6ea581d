"""``report.md`` of a sweep: per experiment a table, the figures and the paper's claims.

Everything is read back from the stored run folders, so a report can be rebuilt at any time
from a finished (or partly finished) sweep.
"""

from __future__ import annotations

import logging
import os
import platform
import subprocess
from collections import defaultdict
from pathlib import Path

import casadi
import numpy as np
import pandas as pd

from resilient_tracking.experiments import generalization, report_files
from resilient_tracking.experiments.catalog import Experiment, Task, catalog
from resilient_tracking.experiments.claims import Claim, check
from resilient_tracking.experiments.report_figures import (
    FigureJob,
    draw,
    figure_jobs,
    inputs_digest,
    keep,
    read_kept,
    up_to_date,
)
from resilient_tracking.experiments.report_files import ReportFiles
from resilient_tracking.experiments.summary import summarise_run
from resilient_tracking.experiments.sweep import is_done, run_dir
from resilient_tracking.kernels import numeric_kernels, pinned_prefix
from resilient_tracking.runs.folders import write_text_atomic
from resilient_tracking.runs.reading import RunData, load_run
from resilient_tracking.version import __version__

log = logging.getLogger(__name__)


def _pm(values: pd.Series, digits: int = 4) -> str:
    return f"{values.mean():.{digits}g} ± {values.std(ddof=0):.2g}"


#: The accuracy columns of a variant table, by what leads: the paper's trace for its own
#: experiments (its filters are the same EKF), MSE and NLL where the filters may differ.
ACCURACY = {
    "paper": (("trace", "trace"), ("mse", "MSE"), ("nll", "NLL"), ("anees", "ANEES")),
    "truth": (("mse", "MSE"), ("nll", "NLL"), ("anees", "ANEES"), ("trace", "trace")),
}


def variant_table(summary: pd.DataFrame, lead: str = "truth") -> str:
    """Markdown table: time-averaged accuracy (mean ± std; :data:`ACCURACY` ``[lead]``), the
    runs whose ANEES lies in its 95 % band, failures, survival, and the permanent hazard attacks
    by zones the robot already knew (of all permanent ones). ANEES is 2 for a consistent
    filter."""
    accuracy = ACCURACY[lead]
    lines = [
        "| variant | runs | "
        + " | ".join(label for _, label in accuracy)
        + " | ANEES in band | effort | sensing failures | comm failures "
        "| survival steps | solver failures | permanent losses to known zones |",
        "|---|---|" + "---|" * (len(accuracy) + 8),
    ]
    for variant, rows in summary.groupby("variant", sort=False):
        known = int(rows.losses_known_permanent.sum())
        permanent = known + int(rows.losses_unknown_permanent.sum())
        cells = " | ".join(_pm(rows[column]) for column, _ in accuracy)
        lines.append(
            f"| {variant} | {len(rows)} | {cells} "
            f"| {int(rows.anees_in_band.astype(bool).sum())}/{len(rows)} "
            f"| {_pm(rows.effort, 3)} | {rows.sensing_attacks.mean():.2f} "
            f"| {rows.comm_attacks.mean():.2f} | {rows.survival_steps.mean():.0f} "
            f"| {int(rows.solver_failures.sum())} | {known}/{permanent} |"
        )
    return "\n".join(lines)


def beyond_tables(summary: pd.DataFrame) -> str:
    """The ``beyond`` experiment's tables: its shipped scenarios' arms, then the stored suite's
    three teams over all its scenarios."""
    part = summary["tag_part"] if "tag_part" in summary else pd.Series("shipped", summary.index)
    parts = [variant_table(summary[part == "shipped"])]
    suite = summary[part == "suite"]
    if len(suite):
        teams = suite.assign(variant="suite, " + suite["tag_team"].astype(str))
        n = suite["tag_scenario"].nunique()
        parts.append(
            f"The stored beyond suite ({n} scenarios), per team:\n\n" + variant_table(teams)
        )
    return "\n\n".join(parts)


def _tables(exp: Experiment, summary: pd.DataFrame) -> str:
    if exp.kind == "generalization":
        return generalization.section(summary)
    if exp.kind == "beyond":
        return beyond_tables(summary)
    return variant_table(summary, "truth" if exp.kind in BEYOND_PAPER else "paper")


#: Kinds of experiment that are not the paper's: their targets are counted apart.
BEYOND_PAPER = ("generalization", "adversarial", "beyond")

#: An experiment's figures still to draw: (figures folder, inputs digest, figures).
Pending = tuple[Path, str, list[FigureJob]]


def experiment_section(
    exp: Experiment, tasks: list[Task], out: Path, pending: list[Pending] | None = None
) -> tuple[str, list[Claim]]:
    """Summarise and check one experiment; returns its markdown and claims. Its figures are
    drawn at once, or, with ``pending`` given, appended to it for the caller to draw (only
    when their inputs changed: :mod:`~.report_figures`)."""
    done = [t for t in tasks if is_done(out, t)]
    generated = exp.kind == "generalization"
    header = f"## {exp.name}\n\n{exp.description}." + (
        " Not one of the paper's experiments: its targets are counted apart from the paper's "
        "claims. The teams compared may differ in their filters, so they are judged by MSE and "
        "NLL against truth, not by the covariance trace an overconfident filter wins (ANEES: 2 "
        "for a consistent filter); each comparison is decided by the 95 % interval of its "
        "per-seed differences, a tie (🟰) when it spans zero (docs/model.md §8.1)."
        if generated or exp.kind in BEYOND_PAPER
        else f" Shipped scenario `{exp.scenario}`."
    )
    if not done:
        return header + "\n\nNo finished runs.\n", []
    folder = out / exp.name
    folder.mkdir(parents=True, exist_ok=True)
    digest = inputs_digest(out, done)
    kept = read_kept(folder, digest)
    figures: list[FigureJob] = []
    if kept is not None and up_to_date(folder / "figures", digest, kept.figures):
        summary, listing = kept.summary, kept.figures  # the same runs: nothing to read
    else:
        runs: dict[str, list[RunData]] = defaultdict(list)
        for t in done:
            runs[t.variant.label].append(load_run(run_dir(out, t)))
        summary = pd.DataFrame([summarise_run(r) for rs in runs.values() for r in rs])
        figures = [] if generated else figure_jobs(exp, runs, summary, folder / "figures")
        listing = [(job.caption, job.path) for job in figures]
        keep(folder, digest, summary, figures)
    summary.to_csv(folder / "summary.csv", index=False)
    claims = check(exp, summary)
    seeds = int(summary["seed"].nunique())
    full = catalog()[exp.name].seeds if exp.name in catalog() else seeds
    mark = f" *(indicative: {seeds} of the protocol's {full} seeds)*" if seeds < full else ""
    parts = [
        header,
        f"{len(done)} of {len(tasks)} runs finished; per-run rows in `{exp.name}/summary.csv`.",
        _tables(exp, summary),
        f"**{'Targets' if generated or exp.kind in BEYOND_PAPER else 'Claims'}**"
        + mark
        + "\n\n"
        + "\n".join(
            f"- {'✅' if c.holds else '🟰' if c.tie else '❔' if c.short else '❌'}{mark} "
            f"{c.statement}: {c.evidence}" + (f"\n  - why: {c.why}" if c.why else "")
            for c in claims
        ),
    ]
    for caption, path in listing:
        parts.append(f"![{caption}]({path.relative_to(out).as_posix()})")
    if figures and not up_to_date(folder / "figures", digest, listing):
        entry = (folder / "figures", digest, figures)
        if pending is None:
            draw([entry])
        else:
            pending.append(entry)
    return "\n\n".join(parts) + "\n", claims


def _is_short(exp: Experiment, tasks: list[Task], out: Path) -> bool:
    """Whether an experiment's finished runs cover fewer seeds than its full protocol."""
    seeds = {t.seed for t in tasks if is_done(out, t)}
    full = catalog()[exp.name].seeds if exp.name in catalog() else len(seeds)
    return bool(seeds) and len(seeds) < full


def _source_revision() -> str:
    """The git commit of the code, when run from a checkout (empty otherwise)."""
    try:
        done = subprocess.run(
            ["git", "rev-parse", "--short", "HEAD"],
            cwd=Path(__file__).parent,
            capture_output=True,
            text=True,
            timeout=5,
        )
    except (OSError, subprocess.SubprocessError):
        return ""
    return f" (commit {done.stdout.strip()})" if done.returncode == 0 else ""


def _numeric_stack() -> str:
    """NumPy, its BLAS and the kernels it chose, and CasADi: with the CPU kind, what decides
    the tables' last bits (docs/model.md §9)."""
    kernels = numeric_kernels()
    return (
        f"NumPy {np.__version__} ({kernels['blas']}, {kernels['blas_core']} kernels), "
        f"CasADi {casadi.CasadiMeta.version()}"
    )


#: Headline groups of the report: (experiment program or kind, how the line names them).
GROUPS = (
    ("one_step", "claims hold with the paper's one-step program"),
    ("route", "claims hold with the route program (the default planner)"),
    ("generalization", "generalization-benchmark targets hold (not claims of the paper)"),
    ("adversarial", "adversarial-target targets hold (not claims of the paper)"),
    ("beyond", "beyond-the-paper targets hold (not claims of the paper)"),
)


def _group(exp: Experiment) -> str:
    if exp.kind in BEYOND_PAPER:
        return exp.kind
    return exp.program or "one_step"


def _headline(label: str, claims: list[Claim], short: bool) -> str:
    failing = [c for c in claims if not c.holds and not c.tie and not c.short]
    ties = [c for c in claims if c.tie]
    undecided = [c for c in claims if c.short]
    line = f"**{sum(c.holds for c in claims)} of {len(claims)} {label}.**"
    if short:
        line += (
            " *Indicative only: some experiments ran fewer seeds than the protocol "
            "(`--quick` or `--seeds`), so a claim may hold or fail by chance.*"
        )
    if failing:
        line += " Not holding: " + "; ".join(
            f"{c.experiment}: {c.statement} ({c.evidence})" for c in failing
        )
    if ties:
        line += (
            " Tied (the interval of the per-seed differences spans zero: neither won nor lost): "
            + "; ".join(f"{c.experiment}: {c.statement} ({c.evidence})" for c in ties)
        )
    if undecided:
        line += " Undecided (fewer than two paired seeds, so no interval): " + "; ".join(
            f"{c.experiment}: {c.statement}" for c in undecided
        )
    return line


def files_of_report(experiments: list[Experiment]) -> ReportFiles:
    """What :func:`write_report` writes into its folder: ``report.md``, and per experiment
    ``summary.csv`` and the figures folder."""
    return ReportFiles(
        ("report.md", *(f"{exp.name}/summary.csv" for exp in experiments)),
        tuple(f"{exp.name}/figures" for exp in experiments),
    )


def write_report(
    experiments: list[Experiment],
    tasks: dict[str, list[Task]],
    out: Path,
    command: str,
    jobs: int = 1,
) -> Path:
    """Write ``out/report.md`` (atomically) for the experiments' stored runs; figures whose
    inputs changed are drawn over ``jobs`` processes. ``FileExistsError`` before writing if a
    file it would replace was not written by rtrack (:mod:`.report_files`)."""
    written = files_of_report(experiments)
    report_files.claim(out, written)
    sections: list[str] = []
    claims: dict[str, list[Claim]] = defaultdict(list)
    short: dict[str, bool] = defaultdict(bool)
    pending: list[Pending] = []
    for exp in experiments:
        text, found = experiment_section(exp, tasks[exp.name], out, pending)
        sections.append(text)
        claims[_group(exp)] += found
        short[_group(exp)] |= _group(exp) != "generalization" and _is_short(
            exp, tasks[exp.name], out
        )
    draw(pending, jobs)
    headlines = [
        _headline(label, claims[group], short[group])
        for group, label in GROUPS
        if claims.get(group)
    ]
    lines = [
        "# Reproduction report",
        "",
        f"Produced by `{pinned_prefix()}{command}` with resilient-tracking {__version__}"
        f"{_source_revision()}, {_numeric_stack()}, Python {platform.python_version()} on "
        f"{platform.machine()} ({os.cpu_count()} cores).",
        "",
        *[line for h in headlines for line in (h, "")],
        "In the tables, `a ± b` is the mean over seeds of the run's time-averaged value, and "
        "`b` the standard deviation across seeds (population, not a confidence interval); "
        "failures and survival are means over seeds, solver failures a total. Bands in the "
        "figures are the mean ± 1 standard deviation across seeds at each time.",
        "",
        *sections,
    ]
    path = write_text_atomic(out / "report.md", "\n".join(lines))
    report_files.seal(out, written)
    log.info("wrote %s", path)
    return path
