"""The entry point of ``rtrack``: logging, the chosen command, and the exit status of a stop."""

from __future__ import annotations

import logging
import os
import sys

import resilient_tracking.cli.experiments as experiments
from resilient_tracking import interrupts
from resilient_tracking.cli.common import ShownFormatter, settings_refused, shown
from resilient_tracking.cli.parser import build_parser
from resilient_tracking.plugin_guard import PluginError, contained


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``rtrack``: parse ``argv`` (default: the command line), set up logging and run
    the subcommand; returns its exit status (130 after Ctrl-C, 143 after SIGTERM, finished runs
    kept; 1 when a plug-in exited, with one line naming it)."""
    args = build_parser().parse_args(argv)
    if getattr(args, "func", None) is experiments.cmd_compare:
        args.argv = argv
    if getattr(args, "func", None) is experiments.cmd_reproduce:
        given = list(sys.argv[1:] if argv is None else argv)
        args.argv = given[given.index("reproduce") + 1 :]
    level = logging.WARNING - 10 * min(args.verbose, 2)
    handler = logging.StreamHandler()
    handler.setFormatter(ShownFormatter("%(levelname)s %(name)s: %(message)s"))
    logging.basicConfig(level=level, handlers=[handler])
    # libraries' warnings (e.g. joblib's "a worker stopped") are for developers: through
    # logging, shown with -v only
    logging.captureWarnings(True)
    logging.getLogger("py.warnings").setLevel(logging.WARNING if args.verbose else logging.ERROR)
    if args.verbose == 0:
        # Dask's scheduler and workers (child processes too) log at INFO by default
        os.environ.setdefault("DASK_LOGGING__DISTRIBUTED", "warning")
        logging.getLogger("distributed").setLevel(logging.WARNING)
    if settings_refused():
        return 1
    from resilient_tracking.runs.folders import FolderBusyError

    try:
        with interrupts.catching():
            try:
                # a plug-in that exits or raises past ``except Exception`` where no command
                # expects it (a validator of its Spec, say) is named, never a silent exit
                with contained(f"during rtrack {args.command}"):
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
    except PluginError as err:
        print(f"error: {shown(err)}", file=sys.stderr)
        return 1
    except FolderBusyError as err:
        print(f"error: {shown(err)}", file=sys.stderr)
        return 1
    except OSError as err:  # a file we could not write or read; the message names it
        print(f"error: {shown(err)}", file=sys.stderr)
        return 1
