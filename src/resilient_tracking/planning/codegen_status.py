"""What this process knows of its compiled code (docs/reliability.md §11): whether its cache was
found unusable (compiled code is then off, and why), and each failure of the compiled path
(a compile that failed, a library that does not load, an error in the cache code), in order.

A run reads :func:`failures_since` the mark it took at its start: a run during which the
compiled path failed is marked so in its manifest (``compiled_code.failures``), and a later
sweep runs it again rather than reusing it. The state is kept per cache setting (the
environment variables that name the cache), so a process that changes them (a test) starts
afresh.
"""

from __future__ import annotations

import logging
import os

log = logging.getLogger(__name__)

#: Why compiled code is off, by cache setting (None: checked, usable).
_OFF: dict[tuple[str | None, ...], str | None] = {}
#: Failures of the compiled path in this process, in order.
_FAILURES: list[str] = []

_SETTING = ("RTRACK_CODEGEN", "RTRACK_CACHE_DIR", "XDG_CACHE_HOME", "HOME", "CC")


def _setting() -> tuple[str | None, ...]:
    return tuple(os.environ.get(name) for name in _SETTING)


def checked() -> bool:
    """Whether the cache of the current setting was checked in this process."""
    return _setting() in _OFF


def off_reason() -> str | None:
    """Why compiled code is off for the current setting (None: on, or not checked yet)."""
    return _OFF.get(_setting())


def set_checked(reason: str | None, quiet: bool = False) -> None:
    """Record the check of the current setting: ``reason`` turns compiled code off (with one
    warning naming it, unless ``quiet``: another process gave it), None keeps it on."""
    _OFF[_setting()] = reason
    if reason is not None and not quiet:
        log.warning("compiled code off, running without it (same results, slower): %s", reason)


def record_failure(what: str) -> None:
    """Record a failure of the compiled path (one line; the caller logs its own warning)."""
    _FAILURES.append(what)


def mark() -> int:
    """A mark of the failures so far, for :func:`failures_since`."""
    return len(_FAILURES)


def failures_since(mark_: int) -> list[str]:
    """The failures recorded after ``mark_`` (see :func:`mark`)."""
    return list(_FAILURES[mark_:])
