"""Ctrl-C and SIGTERM as exceptions, so a command stops cleanly (docs/reliability.md §10).

:func:`catching` turns SIGINT into ``KeyboardInterrupt`` and SIGTERM into :class:`Terminated`
while a command runs, so ``finally`` blocks and ``atexit`` handlers (compile jobs, staging
folders) run as for any exception. CasADi turns a ``KeyboardInterrupt`` raised inside a solve
into a ``RuntimeError``; code that catches a solver's or a builder's exceptions passes each to
:func:`reraise`, so an interrupt is never taken for a failed solve. :func:`check` raises the
signal again at the next safe point (a step of the episode, before a sweep stores a run).
"""

from __future__ import annotations

import contextlib
import logging
import os
import signal
import sys
from collections.abc import Iterator

#: Signals received while :func:`catching` is active.
_RECEIVED: list[int] = []
_SIGNALS = (signal.SIGINT, signal.SIGTERM)


class Terminated(BaseException):
    """SIGTERM, raised like Ctrl-C so cleanup runs."""


def _raise(signum: int) -> None:
    raise Terminated() if signum == signal.SIGTERM else KeyboardInterrupt()


def _on_signal(signum: int, frame: object) -> None:
    _RECEIVED.append(signum)
    _raise(signum)


def check() -> None:
    """Raise again a signal received earlier (one a library may have swallowed)."""
    if _RECEIVED:
        _raise(_RECEIVED[0])


def received() -> bool:
    """Whether SIGINT or SIGTERM came while :func:`catching` was active."""
    return bool(_RECEIVED)


def is_interrupt(err: BaseException) -> bool:
    """Whether ``err`` stands for Ctrl-C or SIGTERM: one came while :func:`catching` was active,
    or an extension module turned the ``KeyboardInterrupt`` raised inside it into another
    exception whose message names it (CasADi: ``RuntimeError: ... KeyboardInterrupt``)."""
    return received() or isinstance(err, KeyboardInterrupt) or "KeyboardInterrupt" in str(err)


def reraise(err: BaseException) -> None:
    """Raise the interrupt ``err`` stands for (see :func:`is_interrupt`); else return, and the
    caller handles ``err`` as the failure it is."""
    if is_interrupt(err):
        check()
        raise KeyboardInterrupt() from err


@contextlib.contextmanager
def deaf_children() -> Iterator[None]:
    """Ignore SIGINT while worker processes are started (call from the main thread).

    A process inherits an ignored signal, so the workers never see the Ctrl-C a terminal sends
    to the whole group (one arriving while a worker imports prints a traceback); the parent
    gets it and stops them. A Ctrl-C in that moment, the time to start the processes, is lost.
    """
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def ignore_more() -> None:
    """Ignore further SIGINT/SIGTERM: a second Ctrl-C must not break the cleanup."""
    for sig in _SIGNALS:
        signal.signal(sig, signal.SIG_IGN)


def ignore_while_exiting() -> None:
    """Ignore SIGINT once a command has finished: the interpreter's shutdown resets Python's own
    handler to the default action, so a Ctrl-C in that moment would end the process by the
    signal (with no message) although everything was done and stored."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


@contextlib.contextmanager
def catching() -> Iterator[None]:
    """Install the handlers; restore the previous ones afterwards unless a signal came."""
    _RECEIVED.clear()
    previous = {sig: signal.signal(sig, _on_signal) for sig in _SIGNALS}
    try:
        yield
    finally:
        if not _RECEIVED:
            for sig, handler in previous.items():
                signal.signal(sig, handler)


def exit_now(code: int) -> None:
    """Exit with ``code`` once cleanup is done. A Ctrl-C that arrived while an extension module
    ran Python code is remembered by the interpreter, which would otherwise end the process by
    SIGINT instead of with ``code``."""
    compile_jobs = sys.modules.get("resilient_tracking.planning.compile_jobs")
    if compile_jobs is not None:
        compile_jobs.stop_all()
    logging.shutdown()
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)
