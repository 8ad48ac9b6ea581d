"""``rtrack``: the command line. The only module that talks to the person."""

from __future__ import annotations

import argparse
import logging
import os
import sys
from pathlib import Path

from tqdm import tqdm

from resilient_tracking import __version__
from resilient_tracking.scenario import POLICY_NAMES, Scenario, ScenarioError, load_scenario


def _load(path: str) -> Scenario | None:
    try:
        return load_scenario(path)
    except ScenarioError as err:
        print(f"error: {err}", file=sys.stderr)
        return None


def cmd_validate(args: argparse.Namespace) -> int:
    status = 0
    for path in args.scenario:
        scenario = _load(path)
        if scenario is None:
            status = 1
        else:
            print(
                f"{path}: ok ({len(scenario.robots)} robots, {len(scenario.targets)} targets, "
                f"{len(scenario.zones)} zones, {scenario.steps} steps)"
            )
    return status


def cmd_run(args: argparse.Namespace) -> int:
    scenario = _load(args.scenario)
    if scenario is None:
        return 1
    if args.steps is not None:
        if args.steps < 1:
            print("error: --steps: must be at least 1", file=sys.stderr)
            return 1
        try:
            scenario = scenario.with_overrides(steps=args.steps)
        except ScenarioError as err:
            print(f"error: --steps: {err}", file=sys.stderr)
            return 1
    if args.seed is not None and args.seed < 0:
        print("error: --seed: must be non-negative", file=sys.stderr)
        return 1

    from resilient_tracking.sim.episode import run_episode
    from resilient_tracking.sim.records import is_run_folder, write_run
    from resilient_tracking.viz import make_run_figures

    policy = args.policy or scenario.policy.name
    seed = scenario.seed if args.seed is None else args.seed
    out = Path(args.out or f"runs/{scenario.name}-{policy}-seed{seed}")
    if out.exists() and not is_run_folder(out):
        print(f"error: --out: {out} exists and is not a run folder", file=sys.stderr)
        return 1
    figures: list[Path] = []

    def finish(folder: Path) -> None:
        if not args.no_figures:
            figures.extend(make_run_figures(folder))

    try:
        with tqdm(
            total=scenario.steps,
            desc=f"{scenario.name} [{policy}]",
            unit="step",
            disable=args.quiet,
        ) as bar:
            result = run_episode(
                scenario, policy=policy, seed=seed, progress=lambda n: bar.update(n)
            )
        write_run(result, out, finish=finish)
    except Exception as err:  # report, never a traceback; nothing is left half-written
        logging.getLogger(__name__).debug("run failed", exc_info=True)
        print(
            f"error: {args.scenario}: run failed ({type(err).__name__}: {err}); "
            f"nothing written to {out} (rerun with -vv for the traceback)",
            file=sys.stderr,
        )
        return 2
    team = result["team"]
    events = result["events"]
    attacks = int((events["event"] == "attack").sum()) if len(events) else 0
    print(
        f"wrote {out}: {len(team)} steps, mean trace {team['trace'].mean():.3g}, "
        f"mean MSE {team['mse'].mean():.3g}, {attacks} attacks, "
        f"{len(figures)} figures, {result.manifest['wall_time_s']:.2f} s"
    )
    return 0


def cmd_reproduce(args: argparse.Namespace) -> int:
    from resilient_tracking.experiments.catalog import select, tasks
    from resilient_tracking.experiments.report import write_report
    from resilient_tracking.experiments.sweep import run_sweep

    for name, value in (("--seeds", args.seeds), ("--jobs", args.jobs)):
        if value is not None and value < 1:
            print(f"error: {name}: must be at least 1", file=sys.stderr)
            return 1
    try:
        experiments = select(args.names, quick=args.quick)
        plan = {e.name: tasks(e, args.seeds) for e in experiments}
    except KeyError as err:
        print(f"error: {err.args[0]}", file=sys.stderr)
        return 1
    except ScenarioError as err:
        print(f"error: {err}", file=sys.stderr)
        return 1
    out = Path(args.out)
    everything = [t for ts in plan.values() for t in ts]
    with tqdm(total=len(everything), desc="reproduce", unit="run", disable=args.quiet) as bar:
        ran = run_sweep(
            everything, out, jobs=args.jobs, dask=args.dask, on_done=lambda t, r: bar.update(1)
        )
    command = " ".join(["rtrack reproduce", *args.argv])
    report = write_report(experiments, plan, out, command)
    print(f"{len(ran)} run(s) done, {len(everything) - len(ran)} already stored; wrote {report}")
    for line in report.read_text().splitlines():
        if line.startswith("**") and ("claims hold" in line or "targets hold" in line):
            print(line.replace("**", ""))
    return 0


def cmd_animate(args: argparse.Namespace) -> int:
    from resilient_tracking.viz.animate import animate_run

    try:
        written = animate_run(args.run_dir, args.out, frames=args.frames, fps=args.fps)
    except (FileNotFoundError, ValueError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 1
    print("wrote " + ", ".join(str(p) for p in written))
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="rtrack", description="Failure-aware multi-robot target tracking."
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    parser.add_argument("-v", "--verbose", action="count", default=0, help="more logging")
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("validate", help="check scenario files, report every problem")
    p.add_argument("scenario", nargs="+")
    p.set_defaults(func=cmd_validate)

    p = sub.add_parser("run", help="run one episode and write tables and figures")
    p.add_argument("scenario")
    p.add_argument("--seed", type=int, default=None, help="episode seed (default: the file's)")
    p.add_argument("--out", default=None, help="run folder (default: runs/NAME-POLICY-seedS)")
    p.add_argument(
        "--policy",
        choices=POLICY_NAMES,
        default=None,
        help="vanilla, failure_aware (the paper) or sog (Mayya et al. baseline, reconstructed)",
    )
    p.add_argument("--steps", type=int, default=None, help="override the number of steps")
    p.add_argument("--no-figures", action="store_true")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_run)

    p = sub.add_parser(
        "reproduce", help="run the paper's experiments (SPEC §6), resumable, and write report.md"
    )
    p.add_argument("names", nargs="*", default=["all"], help="experiment names, or all")
    p.add_argument("--out", default="results", help="sweep folder (default: results)")
    p.add_argument(
        "--seeds", type=int, default=None, help="seeds per cell (default: per experiment)"
    )
    p.add_argument("--quick", action="store_true", help="CI size: fewer seeds and cells")
    p.add_argument("--jobs", type=int, default=os.cpu_count() or 1, help="local worker processes")
    p.add_argument(
        "--dask",
        default=None,
        metavar="ADDRESS",
        help="run on a Dask scheduler at ADDRESS ('local' starts a LocalCluster)",
    )
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_reproduce, argv=[])

    p = sub.add_parser("animate", help="write a GIF (and MP4 with ffmpeg) of a run folder")
    p.add_argument("run_dir")
    p.add_argument("--out", default=None, help="GIF path (default: RUN_DIR/figures/animation.gif)")
    p.add_argument("--frames", type=int, default=60)
    p.add_argument("--fps", type=int, default=10)
    p.set_defaults(func=cmd_animate)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if getattr(args, "func", None) is cmd_reproduce:
        given = list(sys.argv[1:] if argv is None else argv)
        args.argv = given[given.index("reproduce") + 1 :]
    level = logging.WARNING - 10 * min(args.verbose, 2)
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s")
    return int(args.func(args))


if __name__ == "__main__":
    sys.exit(main())
