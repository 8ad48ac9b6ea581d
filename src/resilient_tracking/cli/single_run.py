"""``rtrack validate``, ``run`` and ``animate``: one scenario, one episode, one run folder."""

from __future__ import annotations

import argparse
import contextlib
import logging
import sys
from pathlib import Path

from tqdm import tqdm

from resilient_tracking import interrupts
from resilient_tracking.cli.common import (
    MAX_FPS,
    MAX_FRAMES,
    advance,
    bad_seed,
    load_or_report,
    out_of_range,
    policy_problem,
    prepare_compiled_code,
    shown,
    unusable_name,
)
from resilient_tracking.runs.folders import folder_name
from resilient_tracking.scenario import Scenario, ScenarioError


def cmd_validate(args: argparse.Namespace) -> int:
    """``rtrack validate``: check each scenario file or shipped name and print a one-line summary of
    the valid ones; exit status 1 if any is invalid (the problems are printed, each with its
    field)."""
    status = 0
    for path in args.scenario:
        scenario = load_or_report(path)
        if scenario is None:
            status = 1
        else:
            print(
                f"{shown(path)}: ok ({len(scenario.robots)} robots, "
                f"{len(scenario.targets)} targets, {len(scenario.zones)} zones, "
                f"{scenario.steps} steps)"
            )
    return status


def cmd_run(args: argparse.Namespace) -> int:
    """``rtrack run``: run one episode and write its run folder (tables, manifest and, unless
    ``--no-figures``, figures); exit status 0 when written, 1 for bad input or a refused ``--out``,
    2 when the run failed (nothing is written)."""
    scenario = load_or_report(args.scenario, args.team, args.set)
    if scenario is None:
        return 1
    why = policy_problem(args.policy)
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
    if bad_seed(args.seed):
        return 1

    from resilient_tracking.runs.folders import check_out_folder, folder_lock

    policy = args.policy or scenario.policy.name
    seed = scenario.seed if args.seed is None else args.seed
    if unusable_name("--out", args.out):
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
    from resilient_tracking.experiments.summary import scores_line
    from resilient_tracking.runs.reading import run_data
    from resilient_tracking.runs.records import write_run
    from resilient_tracking.sim.episode import run_episode
    from resilient_tracking.viz import make_run_figures

    figures: list[Path] = []

    def finish(folder: Path) -> None:
        if not args.no_figures:
            figures.extend(make_run_figures(folder))

    prepare_compiled_code()
    try:
        with tqdm(
            total=scenario.steps,
            desc=shown(f"{scenario.name} [{policy}]"),
            unit="step",
            disable=args.quiet,
        ) as bar:
            result = run_episode(
                scenario,
                policy=policy,
                seed=seed,
                progress=lambda n: advance(bar, n),
                bound=args.bound,
            )
        write_run(result, out, finish=finish, overwrite=args.overwrite)
    except Exception as err:  # report, never a traceback; nothing is left half-written
        interrupts.check()
        logging.getLogger("resilient_tracking.cli").debug("run failed", exc_info=True)
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
        f"wrote {shown(out)}: {len(team)} steps, {scores_line(run_data(result))}, "
        f"{attacks} attacks, {len(figures)} figures, {result.manifest['wall_time_s']:.2f} s"
    )
    invalid = events[events["event"] == "invalid_decision"] if len(events) else events
    if len(invalid):
        first = invalid.iloc[0]
        print(
            f"warning: {len(invalid)} invalid decision(s) of the policy: {shown(first['detail'])} "
            f"(first at step {first['step']}, robot {first['robot']}); the team contained "
            "them: a robot with a wrong control held position, events or plans it could not "
            "record were dropped (events.parquet, event invalid_decision)",
            file=sys.stderr,
        )
    return 0


def cmd_animate(args: argparse.Namespace) -> int:
    """``rtrack animate``: write a GIF of a run folder, and an MP4 when ffmpeg is found."""
    from resilient_tracking.viz.animate import animate_run, ffmpeg_path

    if out_of_range("--frames", args.frames, 2, MAX_FRAMES):
        return 1
    if out_of_range("--fps", args.fps, 1, MAX_FPS):
        return 1
    if unusable_name("run folder", args.run_dir) or unusable_name("--out", args.out):
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


def cmd_teams(args: argparse.Namespace) -> int:
    """``rtrack teams``: every named team, its summary and the settings it fixes."""
    from resilient_tracking.scenario.teams import team_listing

    print(team_listing())
    return 0
