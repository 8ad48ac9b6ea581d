"""The files a sweep's report writes into its folder, and which of them rtrack wrote, so a
report never replaces a person's own file (docs/reliability.md §8).

``rtrack reproduce`` and ``rtrack compare`` write ``report.md``, summaries (``summary.csv``...)
and figure folders beside the stored runs. ``OUT/.rtrack-report-files.json`` records each file
rtrack wrote there with its SHA-256 and each figure folder it made. A file named by a report is
rtrack's, and may be replaced, when the record lists it with its present checksum (or lists it
as being written: a write that was interrupted); a figure folder when the record lists it. A
folder written before the record existed is recognised by its report's first line. Anything
else is the person's: :func:`check` refuses, naming it, before a sweep runs anything.
"""

from __future__ import annotations

import json
import logging
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from resilient_tracking.checksums import sha256_of
from resilient_tracking.runs.folders import write_text_atomic

log = logging.getLogger(__name__)

RECORD = ".rtrack-report-files.json"
#: First lines of the reports rtrack writes (a folder from before the record is recognised by it).
HEADINGS = ("# Reproduction report", "# Policy comparison")


@dataclass(frozen=True)
class ReportFiles:
    """What a report writes into its folder, relative to it (``/``-separated)."""

    files: tuple[str, ...]
    #: folders whose every file the report writes (figures)
    folders: tuple[str, ...] = ()


def _read_record(out: Path) -> dict[str, Any] | None:
    """The record of ``out``; None if there is none or it cannot be read."""
    try:
        data = json.loads((out / RECORD).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(data, dict):
        return None
    files, folders = data.get("files"), data.get("folders")
    if not isinstance(files, dict) or not isinstance(folders, list):
        return None
    return data


def _written_before_record(out: Path) -> bool:
    """Whether ``out`` holds a report of an rtrack version that kept no record."""
    try:
        with (out / "report.md").open(encoding="utf-8") as report:
            return report.readline().rstrip("\n") in HEADINGS
    except (OSError, UnicodeDecodeError):
        return False


def not_ours(out: Path, wanted: ReportFiles) -> list[Path]:
    """The paths among ``wanted`` (files, or files in its folders) that exist in ``out`` and
    that rtrack did not write there."""
    record = _read_record(out)
    if record is None and _written_before_record(out):
        return []
    files: dict[str, Any] = record["files"] if record else {}
    folders: list[str] = record["folders"] if record else []
    found: list[Path] = []
    for name in wanted.files:
        path = out / name
        if (path.exists() or path.is_symlink()) and not _is_ours(path, files.get(name, "")):
            found.append(path)
    for name in wanted.folders:
        path = out / name
        blocked = _blocked_parent(out, path)
        if blocked is not None:  # a file, or a link that would lead the figures elsewhere
            found.append(blocked)
            continue
        if name in folders and path.is_dir() and not path.is_symlink():
            continue
        if path.is_dir() and not path.is_symlink():
            found.extend(sorted(p for p in path.rglob("*") if not p.is_dir())[:1])
        elif path.exists() or path.is_symlink():
            found.append(path)
    return found


def _blocked_parent(out: Path, path: Path) -> Path | None:
    """The first folder between ``out`` and ``path`` that exists as something other than a
    folder, or as a symbolic link (``None`` if there is none)."""
    for parent in reversed(path.relative_to(out).parents[:-1]):
        here = out / parent
        if here.is_symlink() or (here.exists() and not here.is_dir()):
            return here
    return None


def _is_ours(path: Path, recorded: str | None) -> bool:
    """Whether the file ``path`` is as rtrack wrote it: ``recorded`` is its checksum, or None
    while rtrack was writing it (``""``: not recorded)."""
    if path.is_symlink() or not path.is_file():
        return False
    return recorded is None or (recorded != "" and recorded == _digest(path))


def _digest(path: Path) -> str | None:
    try:
        return sha256_of(path)
    except OSError:
        return None


def check(out: Path, wanted: ReportFiles) -> None:
    """Refuse with ``FileExistsError`` naming the first file of ``wanted`` in ``out`` that
    rtrack did not write (nothing is replaced)."""
    found = not_ours(out, wanted)
    if found:
        raise FileExistsError(
            f"{found[0]}: exists and was not written by rtrack (or was changed since); move it "
            "away or choose another --out folder (nothing was replaced)"
        )


def claim(out: Path, wanted: ReportFiles) -> None:
    """:func:`check`, then record ``wanted`` as being written by rtrack (so a write that is
    interrupted leaves files a rerun may replace)."""
    check(out, wanted)
    record = _read_record(out) or {"files": {}, "folders": []}
    for name in wanted.files:
        record["files"].setdefault(name, None)
    record["folders"] = sorted({*record["folders"], *wanted.folders})
    _write_record(out, record)


def seal(out: Path, wanted: ReportFiles) -> None:
    """Record the checksum of every file of ``wanted`` now in ``out`` (call after writing)."""
    record = _read_record(out) or {"files": {}, "folders": []}
    for name in wanted.files:
        path = out / name
        if path.is_file():
            record["files"][name] = _digest(path)
        else:
            record["files"].pop(name, None)
    _write_record(out, record)


def _write_record(out: Path, record: dict[str, Any]) -> None:
    out.mkdir(parents=True, exist_ok=True)
    write_text_atomic(out / RECORD, json.dumps(record, indent=1, sort_keys=True) + "\n")
    log.debug("recorded the report files of %s", out)
