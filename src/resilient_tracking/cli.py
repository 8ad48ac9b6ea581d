"""``rtrack``: the command line. The only module that talks to the person."""

from __future__ import annotations

import argparse
import contextlib
import logging
import math
import os
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from tqdm import tqdm

from resilient_tracking import __version__, interrupts
from resilient_tracking.experiments.report_files import ReportFiles
from resilient_tracking.runs.folders import folder_name, holds_working_folder
from resilient_tracking.scenario import Scenario, ScenarioError

if TYPE_CHECKING:
    from collections.abc import Sequence

    from resilient_tracking.experiments.catalog import Task
    from resilient_tracking.experiments.sweep import SweepError

#: Bounds of the counting options: beyond them a typo would start hours of work or exhaust memory.
MAX_SEEDS = 1000
MAX_FRAMES = 2000
MAX_FPS = 120


def max_jobs() -> int:
    """More worker processes than four per core only adds memory (about 200 MB each)."""
    return 4 * (os.cpu_count() or 1)


def _out_of_range(name: str, value: float | None, low: float, high: float) -> bool:
    """Print an error and return True when ``value`` is given and not in ``[low, high]``
    (NaN is in no range)."""
    if value is None or low <= value <= high:
        return False
    print(f"error: {name}: must be between {low:g} and {high:g} (got {value})", file=sys.stderr)
    return True


def shown(text: object, lines: bool = False) -> str:
    """``text`` safe to print to a terminal: every character a terminal would act on instead of
    showing it (escape sequences, carriage returns, bells, Unicode format characters such as a
    right-to-left override) is written as its escape (``\\x1b``, ``\\u202e``), and so are the
    bytes of a file name that are not UTF-8 (``\\xff``); newlines too, unless ``lines``. Every
    text that comes from the person's files or arguments goes through it before it is printed."""
    text = str(text)
    if text.isprintable():
        return text
    out = []
    for char in text:
        if char.isprintable() or char == "\t" or (lines and char == "\n"):
            out.append(char)
        elif "\udc80" <= char <= "\udcff":  # a byte that was not UTF-8 (os.fsdecode)
            out.append(f"\\x{ord(char) - 0xDC00:02x}")
        else:
            out.append(char.encode("unicode_escape").decode("ascii"))
    return "".join(out)


def _unusable_name(option: str, path: str | None) -> bool:
    """Print an error and return True when ``path`` is given and empty (an unset shell variable,
    say: it would mean the current folder), or holds bytes that are not UTF-8 (a file name in
    another encoding: run tables, parquet, cannot be written or read under it). Checked before
    any work."""
    if path is None:
        return False
    if not path:
        print(f"error: {option}: empty; give a name", file=sys.stderr)
        return True
    try:
        path.encode("utf-8")
    except UnicodeEncodeError:
        print(
            f"error: {option}: {shown(path)}: the name is not UTF-8 text, which run tables "
            "and reports cannot hold; choose a UTF-8 name",
            file=sys.stderr,
        )
        return True
    return False


class _ShownFormatter(logging.Formatter):
    """Log lines made safe for the terminal (:func:`shown`), as every other printed text."""

    def format(self, record: logging.LogRecord) -> str:
        return shown(super().format(record), lines=True)


def _step(bar: tqdm, n: int) -> None:
    """Advance a progress bar, first stopping if Ctrl-C or SIGTERM came."""
    interrupts.check()
    bar.update(n)


def _load(path: str) -> Scenario | None:
    """A scenario given by file path or shipped name, or None after printing why not."""
    from resilient_tracking import builtin_scenarios as scenarios

    try:
        return scenarios.load(path)
    except ScenarioError as err:
        print(f"error: {shown(err, lines=True)}", file=sys.stderr)
        return None


def cmd_validate(args: argparse.Namespace) -> int:
    """``rtrack validate``: check each scenario file or shipped name and print a one-line summary of
    the valid ones; exit status 1 if any is invalid (the problems are printed, each with its
    field)."""
    status = 0
    for path in args.scenario:
        scenario = _load(path)
        if scenario is None:
            status = 1
        else:
            print(
                f"{shown(path)}: ok ({len(scenario.robots)} robots, "
                f"{len(scenario.targets)} targets, {len(scenario.zones)} zones, "
                f"{scenario.steps} steps)"
            )
    return status


def _policy_problem(name: str | None) -> str | None:
    """Why ``--policy name`` cannot be used (``None``: it can, or no name was given)."""
    if name is None:
        return None
    from resilient_tracking.policies import POLICIES

    return POLICIES.problem(name)


def cmd_run(args: argparse.Namespace) -> int:
    """``rtrack run``: run one episode and write its run folder (tables, manifest and, unless
    ``--no-figures``, figures); exit status 0 when written, 1 for bad input or a refused ``--out``,
    2 when the run failed (nothing is written)."""
    scenario = _load(args.scenario)
    if scenario is None:
        return 1
    why = _policy_problem(args.policy)
    if why is not None:
        print(f"error: --policy: {shown(why)}", file=sys.stderr)
        return 1
    if args.steps is not None:
        if args.steps < 1:
            print("error: --steps: must be at least 1", file=sys.stderr)
            return 1
        try:
            scenario = scenario.with_overrides(steps=args.steps)
        except ScenarioError as err:
            print(f"error: --steps: {shown(err, lines=True)}", file=sys.stderr)
            return 1
    if args.seed is not None and args.seed < 0:
        print("error: --seed: must be non-negative", file=sys.stderr)
        return 1

    from resilient_tracking.runs.folders import check_out_folder, folder_lock

    policy = args.policy or scenario.policy.name
    seed = scenario.seed if args.seed is None else args.seed
    if _unusable_name("--out", args.out):
        return 1
    out = Path(args.out or f"runs/{folder_name(f'{scenario.name}-{policy}')}-seed{seed}")
    with contextlib.ExitStack() as held:
        try:  # before the episode: a refused folder costs no run
            held.enter_context(folder_lock(out))
            check_out_folder(out, args.overwrite)
        except (OSError, RuntimeError) as err:
            why = str(err)
            if isinstance(err, OSError) and err.strerror:
                why = f"{out}: cannot write there ({err.strerror}: {err.filename})"
            print(f"error: --out: {shown(why)}", file=sys.stderr)
            return 1
        return _run_into(args, scenario, policy, seed, out)


def _run_into(
    args: argparse.Namespace, scenario: Scenario, policy: str, seed: int, out: Path
) -> int:
    from resilient_tracking.runs.records import write_run
    from resilient_tracking.sim.episode import run_episode
    from resilient_tracking.viz import make_run_figures

    figures: list[Path] = []

    def finish(folder: Path) -> None:
        if not args.no_figures:
            figures.extend(make_run_figures(folder))

    try:
        with tqdm(
            total=scenario.steps,
            desc=shown(f"{scenario.name} [{policy}]"),
            unit="step",
            disable=args.quiet,
        ) as bar:
            result = run_episode(
                scenario, policy=policy, seed=seed, progress=lambda n: _step(bar, n)
            )
        write_run(result, out, finish=finish, overwrite=args.overwrite)
    except Exception as err:  # report, never a traceback; nothing is left half-written
        interrupts.check()
        logging.getLogger(__name__).debug("run failed", exc_info=True)
        print(
            shown(
                f"error: {args.scenario}: run failed ({type(err).__name__}: {err}); "
                f"nothing written to {out} (rerun with -vv for the traceback)"
            ),
            file=sys.stderr,
        )
        return 2
    team = result["team"]
    events = result["events"]
    attacks = int((events["event"] == "attack").sum()) if len(events) else 0
    print(
        f"wrote {shown(out)}: {len(team)} steps, mean trace {team['trace'].mean():.3g}, "
        f"mean MSE {team['mse'].mean():.3g}, {attacks} attacks, "
        f"{len(figures)} figures, {result.manifest['wall_time_s']:.2f} s"
    )
    invalid = events[events["event"] == "invalid_decision"] if len(events) else events
    if len(invalid):
        first = invalid.iloc[0]
        print(
            f"warning: {len(invalid)} invalid decision(s) of the policy: {shown(first['detail'])} "
            f"(first at step {first['step']}, robot {first['robot']}); those robots held "
            "position (events.parquet, event invalid_decision)",
            file=sys.stderr,
        )
    return 0


def cmd_reproduce(args: argparse.Namespace) -> int:
    """``rtrack reproduce``: run the paper's experiments (docs/model.md §8) as a resumable sweep
    into ``--out`` and write ``report.md``, printing how many of the claims hold."""
    from resilient_tracking.experiments.catalog import select, tasks
    from resilient_tracking.experiments.report import files_of_report, write_report

    if _out_of_range("--seeds", args.seeds, 1, MAX_SEEDS):
        return 1
    if _out_of_range("--jobs", args.jobs, 1, max_jobs()):
        return 1
    try:
        experiments = select(args.names, quick=args.quick)
        plan = {e.name: tasks(e, args.seeds) for e in experiments}
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
    from resilient_tracking.experiments.sweep import SweepError, run_sweep

    if _unusable_name("--out", args.out):
        return 1
    out = Path(args.out)
    if _not_a_folder(out) or _holds_foreign_report_files(out, wanted):
        return 1
    try:
        with tqdm(total=len(tasks), desc=desc, unit="run", disable=args.quiet) as bar:
            ran = run_sweep(
                tasks, out, jobs=args.jobs, dask=args.dask, on_done=lambda t, r: _step(bar, 1)
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

    if _out_of_range("--jobs", args.jobs, 1, max_jobs()):
        return 1
    if any(_unusable_name("scenario", path) for path in args.scenario):
        return 1
    try:
        seeds = parse_seeds(args.seeds, MAX_SEEDS)
        overrides = [parse_override(text) for text in args.set]
        policies = [p.strip() for p in args.policies.split(",") if p.strip()]
        study = make_study(
            args.scenario, policies, seeds, overrides, args.zone_free, args.by_zone_kind
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


def cmd_animate(args: argparse.Namespace) -> int:
    """``rtrack animate``: write a GIF of a run folder, and an MP4 when ffmpeg is found."""
    from resilient_tracking.viz.animate import animate_run, ffmpeg_path

    if _out_of_range("--frames", args.frames, 2, MAX_FRAMES):
        return 1
    if _out_of_range("--fps", args.fps, 1, MAX_FPS):
        return 1
    if _unusable_name("run folder", args.run_dir) or _unusable_name("--out", args.out):
        return 1
    if args.out is not None and Path(args.out).is_dir():
        print(f"error: --out: {shown(args.out)} is a folder; give a GIF file name", file=sys.stderr)
        return 1
    passes = 2 if ffmpeg_path() else 1  # GIF, then MP4
    bars: list[tqdm] = []  # drawn at the first frame, so a run that cannot be read shows none

    def progress(n: int) -> None:
        if not bars:
            total = max(2, args.frames) * passes
            bars.append(tqdm(total=total, desc="animate", unit="frame", disable=args.quiet))
        bars[0].update(n)

    try:
        written = animate_run(
            args.run_dir, args.out, frames=args.frames, fps=args.fps, progress=progress
        )
    except (OSError, ValueError) as err:  # each names its file
        print(f"error: {shown(err)}", file=sys.stderr)
        return 1
    finally:
        for bar in bars:
            bar.close()
    print("wrote " + ", ".join(shown(p) for p in written))
    if len(written) == 1:
        print("no MP4: no ffmpeg found; pip install 'resilient-tracking[video]' for one")
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

    if _out_of_range("-n", args.n, 1, MAX_SEEDS):
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
            _step(bar, 1)
    print(shown(f"wrote {args.n} scenarios to {out} (run one with: rtrack run {names[0]})"))
    return 0


def _ros2_node_setup(args: argparse.Namespace) -> tuple[Scenario, int, object] | None:
    """Scenario, seed and node settings of ``rtrack node``/``world``; None after an error."""
    try:
        from resilient_tracking.ros2 import require_extra

        require_extra()
    except ImportError as err:
        print(f"error: {shown(err)}", file=sys.stderr)
        return None
    from resilient_tracking.ros2.topics import NodeSettings

    scenario = _load(args.scenario)
    if scenario is None:
        return None
    if args.seed is not None and args.seed < 0:
        print("error: --seed: must be non-negative", file=sys.stderr)
        return None
    for name in ("pose_timeout", "observation_timeout", "give_up", "startup_timeout"):
        value = getattr(args, name)
        if not (0 < value < math.inf):  # NaN fails too
            print(f"error: --{name.replace('_', '-')}: must be positive", file=sys.stderr)
            return None
    if _out_of_range("--altitude", args.altitude, 0.0, 1000.0):  # NaN too
        return None
    budget = getattr(args, "plan_budget", None)  # None: the settings' default
    if _out_of_range("--plan-budget", budget, 0.0, 1.0):
        return None
    if _out_of_range("--domain", args.domain, 0, 232):  # the DDS domain ids ROS 2 allows
        return None
    settings = NodeSettings.for_scenario(
        scenario,
        robot_prefix=args.robot_prefix,
        target_prefix=args.target_prefix,
        command=args.command,
        lockstep=args.lockstep,
        altitude=args.altitude,
        frame=args.frame,
        domain_id=args.domain,
        pose_timeout=args.pose_timeout,
        observation_timeout=args.observation_timeout,
        give_up=args.give_up,
        startup_timeout=args.startup_timeout,
        **({} if budget is None else {"plan_budget": budget or None}),
    )
    return scenario, (scenario.seed if args.seed is None else args.seed), settings


def _stop_on_signals() -> object:
    """An event set by SIGINT/SIGTERM, so a node stops cleanly (the tracker writes its run)."""
    import signal
    import threading

    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.set())
    return stop


def cmd_node(args: argparse.Namespace) -> int:
    """``rtrack node``: run the team as a ROS 2-compatible tracker node (docs/robots.md) and write
    its run folder; exit status 0 when every step ran, 3 when it stopped early, 1 for bad input."""
    setup = _ros2_node_setup(args)
    if setup is None:
        return 1
    scenario, seed, settings = setup
    from resilient_tracking.ros2.bag import BagRecorder
    from resilient_tracking.ros2.tracker_node import TrackerNode
    from resilient_tracking.runs.records import is_run_folder, write_run

    why = _policy_problem(args.policy)
    if why is not None:
        print(f"error: --policy: {shown(why)}", file=sys.stderr)
        return 1
    policy = args.policy or scenario.policy.name
    if _unusable_name("--out", args.out):
        return 1
    out = Path(args.out or f"runs/{folder_name(f'{scenario.name}-{policy}')}-seed{seed}-ros2")
    if out.exists() and not is_run_folder(out):
        print(f"error: --out: {shown(out)} exists and is not a run folder", file=sys.stderr)
        return 1
    if holds_working_folder(out):
        print(
            f"error: --out: {shown(out)}: is the current folder or holds it; give a new folder",
            file=sys.stderr,
        )
        return 1
    try:
        bag = BagRecorder(args.bag) if args.bag else None
    except FileExistsError as err:
        print(f"error: {shown(err)}", file=sys.stderr)
        return 1
    from resilient_tracking.sim.episode import start_truth

    initial_targets, zones = start_truth(scenario, seed)
    node = TrackerNode(
        scenario,
        seed,
        policy,
        settings,  # type: ignore[arg-type]
        initial_targets,
        bag=bag,
        zones=zones,
    )
    if args.warm_up:
        if not args.quiet:
            print("warming up: running the scenario once in simulation to build its problems")
        node.warm_up()
    stop = _stop_on_signals()
    try:
        with tqdm(total=scenario.steps, desc="node", unit="step", disable=args.quiet) as bar:
            result = node.run(stop=stop, progress=lambda n: bar.update(n))  # type: ignore[arg-type]
    finally:
        if bag is not None:
            bag.close()
    write_run(result, out)
    done = len(result["team"])
    print(
        shown(
            f"wrote {out}: {done}/{scenario.steps} steps, {node.holds} holds, "
            f"{node.dropped} dropped messages" + (f"; bag {args.bag}" if bag else "")
        )
    )
    return 0 if done == scenario.steps else 3


def cmd_world(args: argparse.Namespace) -> int:
    """``rtrack world``: publish a simulated (``--mode sim``) or motion-capture world over ROS 2 for
    ``rtrack node``; exit status 0 when every step ran, 3 when it stopped early, 1 on an error."""
    setup = _ros2_node_setup(args)
    if setup is None:
        return 1
    scenario, seed, settings = setup
    from resilient_tracking.ros2.world_node import WorldNode

    try:
        node = WorldNode(scenario, seed, settings, args.mode)  # type: ignore[arg-type]
        stop = _stop_on_signals()
        with tqdm(total=scenario.steps, desc="world", unit="step", disable=args.quiet) as bar:
            done = node.run(stop=stop, progress=lambda n: bar.update(n))  # type: ignore[arg-type]
    except (ValueError, TimeoutError) as err:
        print(f"error: {shown(err)}", file=sys.stderr)
        return 1
    print(f"world: {done}/{scenario.steps} steps")
    return 0 if done == scenario.steps else 3


def _add_ros2_parsers(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """``rtrack node`` and ``rtrack world``: the team and its world over ROS 2 (DDS)."""
    for verb, func, help_text in (
        ("node", cmd_node, "run the team as a ROS 2-compatible tracker node (docs/robots.md)"),
        ("world", cmd_world, "publish a simulated or motion-capture world over ROS 2"),
    ):
        p = sub.add_parser(verb, help=help_text)
        p.add_argument("scenario")
        p.add_argument("--seed", type=int, default=None, help="episode seed (default: the file's)")
        p.add_argument(
            "--lockstep", action="store_true", help="deterministic: world waits for commands"
        )
        p.add_argument(
            "--command",
            choices=("full_state", "twist"),
            default="full_state",
            help="Crazyswarm2 cmd_full_state (default) or geometry_msgs/Twist cmd_vel",
        )
        p.add_argument("--robot-prefix", default="cf", help="robot names PREFIX1.. (default cf)")
        p.add_argument("--target-prefix", default="target", help="target names (default target)")
        p.add_argument("--altitude", type=float, default=0.5, help="flight altitude, m")
        p.add_argument("--frame", default="world", help="frame_id of poses and setpoints")
        p.add_argument("--domain", type=int, default=None, help="DDS domain (ROS_DOMAIN_ID)")
        p.add_argument("--pose-timeout", type=float, default=0.5, help="stale pose, s")
        p.add_argument("--observation-timeout", type=float, default=1.0, help="hold after, s")
        p.add_argument("--give-up", type=float, default=30.0, help="stop after silence, s")
        p.add_argument("--startup-timeout", type=float, default=60.0, help="discovery wait, s")
        p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
        p.set_defaults(func=func)
        if verb == "node":
            p.add_argument("--out", default=None, help="run folder")
            p.add_argument("--policy", default=None, help="a policy name (default: the file's)")
            p.add_argument("--bag", default=None, metavar="FILE", help="also write a ROS 2 bag")
            p.add_argument(
                "--warm-up",
                action="store_true",
                help="run the scenario once in simulation first, to build its league problems",
            )
            p.add_argument(
                "--plan-budget",
                type=float,
                default=None,
                metavar="SHARE",
                help="running free: share of the control period into a tick by which sub-teams "
                "are planned; the rest coast or hold that tick (default 0.35; 0: no limit)",
            )
        else:
            p.add_argument("--mode", choices=("sim", "mocap"), default="sim")


def _add_sweep_options(p: argparse.ArgumentParser) -> None:
    """Where a sweep runs (``--jobs``, ``--dask``) and whether it shows progress."""
    p.add_argument("--jobs", type=int, default=os.cpu_count() or 1, help="local worker processes")
    p.add_argument(
        "--dask",
        default=None,
        metavar="ADDRESS",
        help="run on a Dask scheduler at ADDRESS ('local' starts a LocalCluster)",
    )
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")


def build_parser() -> argparse.ArgumentParser:
    """The ``rtrack`` argument parser with all its subcommands."""
    parser = argparse.ArgumentParser(
        prog="rtrack", description="Failure-aware multi-robot target tracking."
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    parser.add_argument("-v", "--verbose", action="count", default=0, help="more logging")
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("validate", help="check scenario files, report every problem")
    p.add_argument("scenario", nargs="+", help="scenario files or shipped scenario names")
    p.set_defaults(func=cmd_validate)

    p = sub.add_parser("run", help="run one episode and write tables and figures")
    p.add_argument("scenario", help="a scenario file or a shipped scenario name (sensing-temp)")
    p.add_argument("--seed", type=int, default=None, help="episode seed (default: the file's)")
    p.add_argument("--out", default=None, help="run folder (default: runs/NAME-POLICY-seedS)")
    p.add_argument(
        "--policy",
        default=None,
        help="failure_aware (the paper), vanilla, sog (Mayya et al. baseline, reconstructed), a "
        "name an installed package registers, or package.module:Class (default: the file's)",
    )
    p.add_argument("--steps", type=int, default=None, help="override the number of steps")
    p.add_argument("--no-figures", action="store_true")
    p.add_argument(
        "--overwrite",
        action="store_true",
        help="write into an --out folder holding other files: the run's files are replaced, "
        "the others kept",
    )
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_run)

    p = sub.add_parser(
        "reproduce",
        help="run the paper's experiments (docs/model.md §8), resumable, and write report.md",
    )
    p.add_argument("names", nargs="*", default=["all"], help="experiment names, or all")
    p.add_argument("--out", default="results", help="sweep folder (default: results)")
    p.add_argument(
        "--seeds", type=int, default=None, help="seeds per cell (default: per experiment)"
    )
    p.add_argument("--quick", action="store_true", help="CI size: fewer seeds and cells")
    _add_sweep_options(p)
    p.set_defaults(func=cmd_reproduce, argv=[])

    p = sub.add_parser(
        "compare",
        help="compare policies over seeds on scenarios, resumable, and write report.md",
        description="Run every policy on every scenario for each seed (stored runs are reused), "
        "then write OUT/report.md: mean and 95%% confidence interval per metric, paired win "
        "counts, bands, box plots and snapshots (docs/compare.md).",
    )
    p.add_argument("scenario", nargs="+", help="scenario files or shipped scenario names")
    p.add_argument(
        "--policies",
        default="failure_aware,vanilla",
        help="comma-separated: failure_aware, vanilla, sog, a registered name or "
        "package.module:Class (default: failure_aware,vanilla)",
    )
    p.add_argument(
        "--seeds",
        default="5",
        help="N for seeds 1..N, A-B for seeds A..B, or a,b,c (default: 5)",
    )
    p.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="PATH=VALUE",
        help="override a scenario field by dotted path, e.g. policy.failure_aware.eps1=0.05 "
        "(repeatable; applied to every scenario)",
    )
    p.add_argument(
        "--zone-free",
        nargs="?",
        const="failure_aware",
        default=None,
        metavar="POLICY",
        help="also run every scenario with its zones removed, same seeds, with POLICY (default: "
        "failure_aware), and report each policy's last-third ratio: mean trace over the final "
        "third of the episode divided by the zone-free run's",
    )
    p.add_argument(
        "--by-zone-kind",
        action="store_true",
        help="report the first policy's win rates against each other one over the scenarios, "
        "split by whether a scenario has a comm zone, with Wilson 95%% intervals",
    )
    p.add_argument("--out", default="comparison", help="output folder (default: comparison)")
    _add_sweep_options(p)
    p.set_defaults(func=cmd_compare, argv=None)

    p = sub.add_parser(
        "generate",
        help="write generated scenarios of the paper's family as YAML files "
        "(docs/generalization.md)",
    )
    p.add_argument(
        "--seed", type=int, default=None, help="generator seed (default: the benchmark's, 2024)"
    )
    p.add_argument("-n", type=int, default=60, help="how many scenarios (default: 60)")
    p.add_argument(
        "--adversarial",
        action="store_true",
        help="wrap some targets of each scenario in evasive or lure motions (the same "
        "scenarios otherwise)",
    )
    p.add_argument(
        "--beyond",
        action="store_true",
        help="give the zones of each scenario the world's features beyond the paper, each "
        "drawn per zone: moving (an orbit, a drift or a sweep around where the team meets it), "
        "multimodal (kind [sensing, comm]), degrading (announced or silent) or, a permanent "
        "comm zone, spreading (with a radio range); at least one per scenario; the same "
        "scenarios otherwise (docs/beyond.md)",
    )
    p.add_argument("--out", default="generated", help="folder (default: generated)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_generate)

    p = sub.add_parser(
        "animate", help="write a GIF and an MP4 (system ffmpeg or imageio-ffmpeg) of a run folder"
    )
    p.add_argument("run_dir")
    p.add_argument("--out", default=None, help="GIF path (default: RUN_DIR/figures/animation.gif)")
    p.add_argument("--frames", type=int, default=60)
    p.add_argument("--fps", type=int, default=10)
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_animate)
    _add_ros2_parsers(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``rtrack``: parse ``argv`` (default: the command line), set up logging and run
    the subcommand; returns its exit status (130 after Ctrl-C, 143 after SIGTERM, finished runs
    kept)."""
    args = build_parser().parse_args(argv)
    if getattr(args, "func", None) is cmd_compare:
        args.argv = argv
    if getattr(args, "func", None) is cmd_reproduce:
        given = list(sys.argv[1:] if argv is None else argv)
        args.argv = given[given.index("reproduce") + 1 :]
    level = logging.WARNING - 10 * min(args.verbose, 2)
    handler = logging.StreamHandler()
    handler.setFormatter(_ShownFormatter("%(levelname)s %(name)s: %(message)s"))
    logging.basicConfig(level=level, handlers=[handler])
    # libraries' warnings (e.g. joblib's "a worker stopped") are for developers: through
    # logging, shown with -v only
    logging.captureWarnings(True)
    logging.getLogger("py.warnings").setLevel(logging.WARNING if args.verbose else logging.ERROR)
    if args.verbose == 0:
        # Dask's scheduler and workers (child processes too) log at INFO by default
        os.environ.setdefault("DASK_LOGGING__DISTRIBUTED", "warning")
        logging.getLogger("distributed").setLevel(logging.WARNING)
    from resilient_tracking.runs.folders import FolderBusyError

    try:
        with interrupts.catching():
            try:
                code = int(args.func(args))
            except Exception:
                # a library that turned the Ctrl-C into its own error (Matplotlib's Agg:
                # "Invalid bounding box") still stands for the interrupt
                interrupts.check()
                raise
        if argv is None:  # the command itself: its shutdown must not end by a late Ctrl-C
            interrupts.ignore_while_exiting()
        return code
    except (KeyboardInterrupt, interrupts.Terminated) as stop:
        # compile jobs are stopped at exit (planning.compile_jobs); staging folders are removed
        interrupts.ignore_more()
        term = isinstance(stop, interrupts.Terminated)
        what = "terminated" if term else "interrupted"
        print(f"\n{what}: finished runs are kept; run the command again to go on", file=sys.stderr)
        if argv is None:  # the command itself, not a call from Python
            interrupts.exit_now(143 if term else 130)
        return 143 if term else 130
    except FolderBusyError as err:
        print(f"error: {shown(err)}", file=sys.stderr)
        return 1
    except OSError as err:  # a file we could not write or read; the message names it
        print(f"error: {shown(err)}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
