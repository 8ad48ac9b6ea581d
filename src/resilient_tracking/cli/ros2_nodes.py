"""``rtrack node`` and ``world``: the team and its world over ROS 2 (DDS)."""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from tqdm import tqdm

from resilient_tracking.cli.common import (
    bad_seed,
    load_or_report,
    out_of_range,
    policy_problem,
    shown,
    unusable_name,
)
from resilient_tracking.runs.folders import folder_name, holds_working_folder
from resilient_tracking.scenario import Scenario


def node_setup(args: argparse.Namespace) -> tuple[Scenario, int, object] | None:
    """Scenario, seed and node settings of ``rtrack node``/``world``; None after an error."""
    try:
        from resilient_tracking.ros2 import require_extra

        require_extra()
    except ImportError as err:
        print(f"error: {shown(err)}", file=sys.stderr)
        return None
    from resilient_tracking.ros2.topics import NodeSettings

    scenario = load_or_report(args.scenario, getattr(args, "team", None))
    if scenario is None:
        return None
    if bad_seed(args.seed):
        return None
    for name in ("pose_timeout", "observation_timeout", "give_up", "startup_timeout"):
        value = getattr(args, name)
        if not (0 < value < math.inf):  # NaN fails too
            print(f"error: --{name.replace('_', '-')}: must be positive", file=sys.stderr)
            return None
    if out_of_range("--altitude", args.altitude, 0.0, 1000.0):  # NaN too
        return None
    budget = getattr(args, "plan_budget", None)  # None: the settings' default
    if out_of_range("--plan-budget", budget, 0.0, 1.0):
        return None
    if out_of_range("--domain", args.domain, 0, 232):  # the DDS domain ids ROS 2 allows
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
    its run folder; exit status 0 when every step ran, 3 when it stopped early, 1 for bad input
    or when nothing to track with arrived within ``--startup-timeout`` (nothing written)."""
    setup = node_setup(args)
    if setup is None:
        return 1
    scenario, seed, settings = setup
    from resilient_tracking.ros2.bag import BagRecorder
    from resilient_tracking.ros2.tracker_node import StartupTimeout, TrackerNode
    from resilient_tracking.runs.records import is_run_folder, write_run

    why = policy_problem(args.policy)
    if why is not None:
        print(f"error: --policy: {shown(why)}", file=sys.stderr)
        return 1
    policy = args.policy or scenario.policy.name
    if unusable_name("--out", args.out):
        return 1
    out = Path(args.out or f"runs/{folder_name(f'{scenario.name}-{policy}')}-seed{seed}-ros2")
    if out.is_symlink():
        print(f"error: --out: {shown(out)} is a symbolic link; give a folder", file=sys.stderr)
        return 1
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
    except StartupTimeout as err:
        print(f"error: --startup-timeout: {shown(err)}", file=sys.stderr)
        return 1
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
    setup = node_setup(args)
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
