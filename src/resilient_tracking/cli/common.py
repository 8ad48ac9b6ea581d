"""What every ``rtrack`` command shares: option bounds, argument checks, safe printing."""

from __future__ import annotations

import argparse
import logging
import os
import sys
from collections.abc import Sequence

from tqdm import tqdm

from resilient_tracking import interrupts
from resilient_tracking.scenario import Scenario, ScenarioError

#: Bounds of the counting options: beyond them a typo would start hours of work or exhaust memory.
MAX_SEEDS = 1000
MAX_FRAMES = 2000
MAX_FPS = 120


def max_jobs() -> int:
    """More worker processes than four per core only adds memory (about 200 MB each)."""
    return 4 * (os.cpu_count() or 1)


def out_of_range(name: str, value: float | None, low: float, high: float) -> bool:
    """Print an error and return True when ``value`` is given and not in ``[low, high]``
    (NaN is in no range)."""
    if value is None or low <= value <= high:
        return False
    print(f"error: {name}: must be between {low:g} and {high:g} (got {value})", file=sys.stderr)
    return True


def bad_seed(seed: int | None) -> bool:
    """Print an error and return True when ``--seed`` is given and is not a seed a scenario
    takes: 0 to :data:`~resilient_tracking.spec.MAX_SEED` (its ``seed`` field's bounds)."""
    from resilient_tracking.spec import MAX_SEED

    if seed is None or 0 <= seed <= MAX_SEED:
        return False
    print(
        f"error: --seed: must be between 0 and {MAX_SEED}, the largest seed a scenario "
        f"takes (got {seed})",
        file=sys.stderr,
    )
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


def unusable_name(option: str, path: str | None) -> bool:
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


def settings_refused() -> bool:
    """Print an error and return True when an environment variable rtrack reads
    (``RTRACK_CODEGEN``, ``RTRACK_CACHE_DIR``, ``RTRACK_CACHE_MAX_MB``) holds a value not
    allowed; the line names it and what is allowed. Checked before any command runs."""
    from resilient_tracking.planning.codegen_settings import SettingError, check

    try:
        check()
    except SettingError as err:
        print(f"error: {shown(err)}", file=sys.stderr)
        return True
    return False


def prepare_compiled_code() -> None:
    """Before a command's runs (and its progress bar): decide whether compiled code is used,
    so that a cache that cannot be used is reported in one warning line of its own."""
    from resilient_tracking.planning import codegen

    codegen.prepare()


class ShownFormatter(logging.Formatter):
    """Log lines made safe for the terminal (:func:`shown`), as every other printed text."""

    def format(self, record: logging.LogRecord) -> str:
        """The record's log line, escaped as :func:`shown` escapes a text of several lines."""
        return shown(super().format(record), lines=True)


def advance(bar: tqdm, n: int) -> None:
    """Advance a progress bar, first stopping if Ctrl-C or SIGTERM came."""
    interrupts.check()
    bar.update(n)


def load_or_report(
    path: str, team: str | None = None, overrides: Sequence[str] = ()
) -> Scenario | None:
    """A scenario given by file path or shipped name, run by ``team`` when given and changed
    by ``--set`` ``overrides`` (``dotted.path=value``), or None after printing why not."""
    from resilient_tracking import builtin_scenarios
    from resilient_tracking.experiments.comparison import parse_override
    from resilient_tracking.scenario.overrides import overridden

    try:
        scenario = builtin_scenarios.load(path)
        if team is not None:
            scenario = scenario.with_team(team)
        changes = dict(parse_override(text) for text in overrides)
        return overridden(scenario, changes, f"{scenario.name} (with --set)")
    except ScenarioError as err:
        print(f"error: {shown(err, lines=True)}", file=sys.stderr)
    except ValueError as err:
        print(f"error: {shown(err)}", file=sys.stderr)
    return None


def add_team_option(p: argparse.ArgumentParser, what: str = "the scenario") -> None:
    """``--team NAME``: a named team runs ``what`` (``rtrack teams`` lists them)."""
    from resilient_tracking.scenario.teams import TEAMS

    p.add_argument(
        "--team",
        choices=list(TEAMS),
        default=None,
        help=f"a named team runs {what}; its settings fill in what the file leaves unsaid "
        "(default: the file's team; rtrack teams lists them)",
    )


def policy_problem(name: str | None) -> str | None:
    """Why ``--policy name`` cannot be used (``None``: it can, or no name was given)."""
    if name is None:
        return None
    from resilient_tracking.policies import POLICIES

    return POLICIES.problem(name)
