"""The labels of ``rtrack compare``'s scenarios: one per argument, unique, one safe folder name.

A label names a scenario's section of the report, its runs (``OUT/runs/<label>/…``) and its
figures (``OUT/<label>/figures``). It is the argument's file name without a ``.yaml`` or
``.yml`` suffix (in any case), or the shipped scenario's name, made one portable folder name:
characters other than letters, digits, ``.``, ``_`` and ``-`` become ``_``, and so do leading
dots (``..`` is ``__``), so no label leaves ``--out`` or hides. Labels that would name the same
folder (compared without case, as some file systems do), or a file of the report itself
(``runs``, ``report.md``…), are told apart in the order given: the first keeps its name, the
others get ``-2``, ``-3``… (a number no other label has). The report gives each section's
argument beside its label.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import PurePath

from resilient_tracking.runs.folders import folder_name

#: Suffixes of a scenario file, compared without case.
SUFFIXES = (".yaml", ".yml")
#: Names directly in ``--out`` that a label must not take: the runs and the report's files.
RESERVED = ("runs", "report.md", "runs.csv", "summary.csv", "win_rates.csv")
#: Longest label: a folder name has room for the ``-N`` of a collision.
MAX_LABEL = 200


def natural_label(arg: str) -> str:
    """The argument's own name: its file name without a scenario suffix (any case)."""
    name = PurePath(arg).name or str(arg)
    for suffix in SUFFIXES:
        if name.lower().endswith(suffix) and len(name) > len(suffix):
            return name[: -len(suffix)]
    return name


def safe_label(name: str) -> str:
    """``name`` as one folder name that cannot leave its parent or hide in it."""
    safe = folder_name(name)
    stripped = safe.lstrip(".")
    return ("_" * (len(safe) - len(stripped)) + stripped)[:MAX_LABEL]


def scenario_labels(args: Sequence[str]) -> list[str]:
    """One label per argument, in order: unique without case, none a reserved name (module
    docstring)."""
    bases = [safe_label(natural_label(a)) for a in args]
    taken = {name.casefold() for name in RESERVED}
    wanted = {b.casefold() for b in bases}
    labels: list[str] = []
    for base in bases:
        label = base
        if label.casefold() in taken:
            n = 2
            while (label := f"{base}-{n}").casefold() in taken | wanted:
                n += 1
        taken.add(label.casefold())
        labels.append(label)
    return labels
