"""``rtrack reproduce``, ``compare`` and ``generate``: sweeps of many runs and their scenarios."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from tqdm import tqdm

from resilient_tracking.cli.common import (
    MAX_SEEDS,
    advance,
    max_jobs,
    out_of_range,
    policy_problem,
    prepare_compiled_code,
    shown,
    unusable_name,
)
from resilient_tracking.experiments.report_files import ReportFiles
from resilient_tracking.scenario import ScenarioError
from resilient_tracking.spec import MAX_SEED

if TYPE_CHECKING:
    from collections.abc import Sequence

    from resilient_tracking.experiments.catalog import Task
    from resilient_tracking.experiments.sweep import SweepError


def cmd_reproduce(args: argparse.Namespace) -> int:
    """``rtrack reproduce``: run the paper's experiments (docs/model.md §8) as a resumable sweep
    into ``--out`` and write ``report.md``, printing how many of the claims hold."""
    from resilient_tracking.experiments.catalog import select, tasks, with_policy, with_team
    from resilient_tracking.experiments.report import files_of_report, write_report

    if out_of_range("--seeds", args.seeds, 1, MAX_SEEDS):
        return 1
    if out_of_range("--first-seed", args.first_seed, 0, MAX_SEED - MAX_SEEDS):
        return 1
    if out_of_range("--jobs", args.jobs, 1, max_jobs()):
        return 1
    why = policy_problem(args.policy)
    if why is not None:
        print(f"error: --policy: {shown(why)}", file=sys.stderr)
        return 1
    try:
        experiments = select(args.names, quick=args.quick)
        plan = {e.name: tasks(e, args.seeds, first_seed=args.first_seed) for e in experiments}
        if args.team is not None:
            plan = {e.name: with_team(e, plan[e.name], args.team) for e in experiments}
        if args.policy is not None:
            plan = {e.name: with_policy(plan[e.name], args.policy) for e in experiments}
    except KeyError as err:
        print(f"error: {shown(err.args[0])}", file=sys.stderr)
        return 1
    except ScenarioError as err:
        print(f"error: {shown(err, lines=True)}", file=sys.stderr)
        return 1
    everything = [t for ts in plan.values() for t in ts]
    swept = _swept(everything, files_of_report(experiments), args, "reproduce")
    if isinstance(swept, int):
        return swept
    out, ran = swept
    command = " ".join(["rtrack reproduce", *args.argv])
    report = write_report(experiments, plan, out, command, jobs=args.jobs)
    print(
        f"{len(ran)} run(s) done, {len(everything) - len(ran)} already stored; "
        f"wrote {shown(report)}"
    )
    for line in report.read_text().splitlines():
        if line.startswith("**") and ("claims hold" in line or "targets hold" in line):
            print(shown(line.replace("**", "")))
    return 0


def _swept(
    tasks: Sequence[Task], wanted: ReportFiles, args: argparse.Namespace, desc: str
) -> tuple[Path, list[Task]] | int:
    """Check ``--out`` (a usable folder holding no file rtrack did not write), then run the sweep
    with a progress bar: the folder and the runs done, or the exit code to return."""
    from resilient_tracking.experiments.sweep import SweepError, dask_problem, run_sweep

    if unusable_name("--out", args.out):
        return 1
    if args.dask and (why := dask_problem()) is not None:  # before anything is created
        print(f"error: {why}", file=sys.stderr)
        return 1
    out = Path(args.out)
    if _not_a_folder(out) or _holds_foreign_report_files(out, wanted):
        return 1
    prepare_compiled_code()
    try:
        with tqdm(total=len(tasks), desc=desc, unit="run", disable=args.quiet) as bar:
            ran = run_sweep(
                tasks, out, jobs=args.jobs, dask=args.dask, on_done=lambda t, r: advance(bar, 1)
            )
    except SweepError as err:
        return _failed_runs(err, out)
    return out, ran


def _failed_runs(err: SweepError, out: Path) -> int:
    """Say which runs of a sweep failed, one line each (the traceback with -vv); exit 2."""
    for failure in err.failures:
        print(f"error: {failure.message}", file=sys.stderr)
    print(
        f"error: {err}; the other runs are stored in {out}, no report written "
        "(rerun with -vv for the tracebacks)",
        file=sys.stderr,
    )
    return 2


def _not_a_folder(out: Path) -> bool:
    """Whether ``--out`` names something that is not a folder (said to the person)."""
    if out.exists() and not out.is_dir():
        print(f"error: --out: {shown(out)} exists and is not a folder", file=sys.stderr)
        return True
    return False


def _holds_foreign_report_files(out: Path, wanted: ReportFiles) -> bool:
    """Whether ``--out`` holds a file the report would replace that rtrack did not write
    (said to the person, before anything runs)."""
    from resilient_tracking.experiments import report_files

    try:
        report_files.check(out, wanted)
    except FileExistsError as err:
        print(f"error: --out: {err}", file=sys.stderr)
        return True
    return False


def cmd_compare(args: argparse.Namespace) -> int:
    """``rtrack compare``: run every ``--policies`` entry on every scenario for each seed as a
    resumable sweep and write ``OUT/report.md`` (docs/compare.md)."""
    from resilient_tracking.experiments.comparison import (
        files_of_report,
        make_study,
        parse_override,
        parse_seeds,
        write_compare_report,
    )

    if out_of_range("--jobs", args.jobs, 1, max_jobs()):
        return 1
    if any(unusable_name("scenario", path) for path in args.scenario):
        return 1
    try:
        seeds = parse_seeds(args.seeds, MAX_SEEDS)
        overrides = [parse_override(text) for text in args.set]
        if args.team is not None:  # the team first: the --set paths then override its settings
            overrides.insert(0, ("team", args.team))
        policies = [p.strip() for p in args.policies.split(",") if p.strip()]
        study = make_study(
            args.scenario,
            policies,
            seeds,
            overrides,
            args.zone_free,
            args.by_zone_kind,
            bound=args.bound,
        )
        tasks = study.tasks()
    except (ScenarioError, ValueError) as err:
        print(f"error: {shown(err, lines=True)}", file=sys.stderr)
        return 1
    swept = _swept(tasks, files_of_report(study), args, "compare")
    if isinstance(swept, int):
        return swept
    out, ran = swept
    given = list(sys.argv[1:] if args.argv is None else args.argv)
    command = " ".join(["rtrack compare", *given[given.index("compare") + 1 :]])
    report = write_compare_report(study, tasks, out, command)
    print(f"{len(ran)} run(s) done, {len(tasks) - len(ran)} already stored; wrote {shown(report)}")
    return 0


def cmd_generate(args: argparse.Namespace) -> int:
    """``rtrack generate``: write scenarios of the generalization benchmark's family as YAML
    files (the benchmark's stored suite by default); never replaces a file."""
    import yaml

    from resilient_tracking.experiments.generator import (
        SUITE_SEED,
        drawn,
        stored_adversarial_suite,
        stored_beyond_suite,
        stored_suite,
    )
    from resilient_tracking.runs.folders import write_text_atomic

    if out_of_range("-n", args.n, 1, MAX_SEEDS):
        return 1
    if args.seed is not None and args.seed < 0:
        print("error: --seed: must be non-negative", file=sys.stderr)
        return 1
    if not args.out:
        print("error: --out: empty; give a name", file=sys.stderr)
        return 1
    out = Path(args.out)
    if _not_a_folder(out):
        return 1
    names = [out / f"g{i:02d}.yaml" for i in range(args.n)]
    taken = [path for path in names if path.exists()]
    if taken:
        print(f"error: --out: {shown(taken[0])} exists (nothing is replaced)", file=sys.stderr)
        return 1
    seed = SUITE_SEED if args.seed is None else args.seed
    # the default seed's suites are stored (the same scenarios, without drawing them again)
    stored_of = {
        (False, False): stored_suite,
        (False, True): stored_beyond_suite,
        (True, False): stored_adversarial_suite,
    }
    load = stored_of.get((args.adversarial, args.beyond)) if seed == SUITE_SEED else None
    stored = load(args.n) if load is not None else []
    scenarios = (
        stored if len(stored) == args.n else drawn(seed, args.n, args.adversarial, args.beyond)
    )
    how = f"--seed {seed}" + (" --adversarial" if args.adversarial else "")
    how += " --beyond" if args.beyond else ""
    out.mkdir(parents=True, exist_ok=True)
    with tqdm(total=args.n, desc="generate", unit="scenario", disable=args.quiet) as bar:
        for path, scenario in zip(names, scenarios, strict=True):
            header = f"# drawn by `rtrack generate {how}` (docs/generalization.md)\n"
            data = scenario.model_dump(mode="json", exclude_defaults=True)
            write_text_atomic(path, header + yaml.safe_dump(data, sort_keys=False))
            advance(bar, 1)
    print(shown(f"wrote {args.n} scenarios to {out} (run one with: rtrack run {names[0]})"))
    return 0
