"""The ``rtrack`` argument parser: every command with its options and help texts."""

from __future__ import annotations

import argparse
import os

import resilient_tracking.cli.experiments as experiments
import resilient_tracking.cli.ros2_nodes as ros2_nodes
import resilient_tracking.cli.single_run as single_run
from resilient_tracking import __version__
from resilient_tracking.cli.common import add_team_option


def _add_ros2_parsers(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """``rtrack node`` and ``rtrack world``: the team and its world over ROS 2 (DDS)."""
    for verb, func, help_text in (
        (
            "node",
            ros2_nodes.cmd_node,
            "run the team as a ROS 2-compatible tracker node (docs/robots.md)",
        ),
        ("world", ros2_nodes.cmd_world, "publish a simulated or motion-capture world over ROS 2"),
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
        p.add_argument(
            "--pose-timeout",
            type=float,
            default=0.5,
            help="a robot with no pose for this long holds; running free, the node drops "
            "messages stamped this far from its clock, s",
        )
        p.add_argument("--observation-timeout", type=float, default=1.0, help="hold after, s")
        p.add_argument("--give-up", type=float, default=30.0, help="stop after silence, s")
        p.add_argument(
            "--startup-timeout",
            type=float,
            default=60.0,
            help="node: stop (exit 1) when no observation or no pose of some robot came within "
            "this; world in lock-step or mocap: wait for the tracker or poses this long, s",
        )
        p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
        p.set_defaults(func=func)
        if verb == "node":
            add_team_option(p)
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
    p.set_defaults(func=single_run.cmd_validate)

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
    add_team_option(p)
    p.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="PATH=VALUE",
        help="override a scenario field by dotted path, e.g. guards.lure.enabled=true "
        "(repeatable; applied after --team)",
    )
    p.add_argument("--steps", type=int, default=None, help="override the number of steps")
    p.add_argument(
        "--bound",
        action="store_true",
        help="also compute the posterior Cramér–Rao bound of the target positions along the run "
        "(table bound.parquet) and report efficiency = bound / MSE (docs/model.md §8)",
    )
    p.add_argument("--no-figures", action="store_true")
    p.add_argument(
        "--overwrite",
        action="store_true",
        help="write into an --out folder holding other files: the run's files are replaced, "
        "the others kept",
    )
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=single_run.cmd_run)

    p = sub.add_parser(
        "reproduce",
        help="run the paper's experiments (docs/model.md §8), resumable, and write report.md",
    )
    p.add_argument("names", nargs="*", default=["all"], help="experiment names, or all")
    p.add_argument("--out", default="results", help="sweep folder (default: results)")
    p.add_argument(
        "--seeds", type=int, default=None, help="seeds per cell (default: per experiment)"
    )
    p.add_argument(
        "--first-seed",
        type=int,
        default=1,
        help="the first seed of each cell (default: 1); e.g. 101 checks the claims on seeds "
        "none of the settings was chosen on",
    )
    p.add_argument("--quick", action="store_true", help="CI size: fewer seeds and cells")
    add_team_option(p, "the failure-aware arms that run the default team")
    p.add_argument(
        "--policy",
        default=None,
        help="a policy runs the failure-aware arms in the planner's place, so that the claims "
        "judge it: a registered name, package.module:Class or onnx:PATH (default: the planner)",
    )
    _add_sweep_options(p)
    p.set_defaults(func=experiments.cmd_reproduce, argv=[])

    p = sub.add_parser(
        "compare",
        help="compare policies over seeds on scenarios, resumable, and write report.md",
        description="Run every policy on every scenario for each seed (stored runs are reused), "
        "then write OUT/report.md: mean and 95%% confidence interval per metric (MSE and NLL "
        "first), paired win counts, bands, box plots and snapshots (docs/compare.md).",
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
        help="report the first policy's scenarios won, tied and lost against each other one "
        "in MSE and NLL, split by whether a scenario has a comm zone (needs two or more seeds)",
    )
    p.add_argument(
        "--bound",
        action="store_true",
        help="also compute the posterior Cramér–Rao bound of the target positions along each run "
        "(table bound.parquet) and report efficiency = bound / MSE (docs/model.md §8)",
    )

    add_team_option(p, "every scenario")
    p.add_argument("--out", default="comparison", help="output folder (default: comparison)")
    _add_sweep_options(p)
    p.set_defaults(func=experiments.cmd_compare, argv=None)

    p = sub.add_parser(
        "teams", help="list the named teams: name, one line, the settings each fixes"
    )
    p.set_defaults(func=single_run.cmd_teams)

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
    p.set_defaults(func=experiments.cmd_generate)

    p = sub.add_parser(
        "animate", help="write a GIF and an MP4 (system ffmpeg or imageio-ffmpeg) of a run folder"
    )
    p.add_argument("run_dir")
    p.add_argument("--out", default=None, help="GIF path (default: RUN_DIR/figures/animation.gif)")
    p.add_argument("--frames", type=int, default=60)
    p.add_argument("--fps", type=int, default=10)
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=single_run.cmd_animate)
    _add_ros2_parsers(sub)
    return parser
