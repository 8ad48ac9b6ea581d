"""The supervisor of one compile job (docs/reliability.md §9), a program of its own.

:mod:`~.compile_jobs` runs it as ``python -I compile_supervisor.py PARENT WORK SLOTS N LIBRARY
COMMAND...`` (by its file, so that it imports the standard library only and starts fast; ``python
-m resilient_tracking.planning.compile_supervisor`` runs the same). It

- waits for one of ``N`` compile slots (``flock`` on ``SLOTS/slot-i``, shared by every process);
- runs ``COMMAND`` (the compiler) as its child with ``TMPDIR=WORK``, and is the subreaper of
  the compiler's own children;
- kills them all when the process ``PARENT`` dies or on SIGTERM/SIGINT;
- always removes the job's folder ``WORK``; on success renames ``WORK/out.so`` to ``LIBRARY``,
  with its SHA-256 in ``LIBRARY.sha256`` (renamed first).

Its exit status is the compiler's, or 1 when it was stopped.
"""

from __future__ import annotations

import contextlib
import ctypes
import fcntl
import hashlib
import os
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Callable

#: ``prctl`` option: orphaned descendants (the compiler's own children) are reparented here.
PR_SET_CHILD_SUBREAPER = 36
#: How often the supervisor looks for a free slot, a finished compiler or a stop (s).
POLL_SECONDS = 0.2
#: Rounds of killing the compiler's process tree, and the pause between them (s).
KILL_ROUNDS = 50
KILL_PAUSE_SECONDS = 0.02


def become_subreaper() -> None:
    """Have orphans of the compiler's children reparented to this process (Linux only)."""
    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL(None).prctl(PR_SET_CHILD_SUBREAPER, 1, 0, 0, 0)


def descendants() -> list[int]:
    """Process ids of every descendant of this process (read from ``/proc``)."""
    kids: dict[int, list[int]] = {}
    for name in os.listdir("/proc") if os.path.isdir("/proc") else ():
        if name.isdigit():
            try:
                with open(f"/proc/{name}/stat") as f:
                    ppid = int(f.read().rsplit(")", 1)[1].split()[1])
                kids.setdefault(ppid, []).append(int(name))
            except (OSError, IndexError, ValueError):
                pass
    out, todo = [], [os.getpid()]
    while todo:
        for pid in kids.get(todo.pop(), []):
            out.append(pid)
            todo.append(pid)
    return out


def kill_tree(child: subprocess.Popen[bytes]) -> None:
    """SIGKILL ``child`` and every descendant, reaping them, until none is left."""
    for _ in range(KILL_ROUNDS):
        pids = set(descendants()) | ({child.pid} if child.poll() is None else set())
        if not pids:
            return
        for pid in pids:
            with contextlib.suppress(OSError):
                os.kill(pid, signal.SIGKILL)
        time.sleep(KILL_PAUSE_SECONDS)
        try:
            while os.waitpid(-1, os.WNOHANG)[0]:
                pass
        except ChildProcessError:
            pass


def take_slot(slots: str, n_slots: int, stopped: Callable[[], bool]) -> int | None:
    """A locked slot file's descriptor (held until this process exits), or None if stopped
    while waiting for one."""
    while not stopped():
        for i in range(n_slots):
            fd = os.open(os.path.join(slots, f"slot-{i}"), os.O_RDWR | os.O_CREAT, 0o644)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                return fd
            except OSError:
                os.close(fd)
        time.sleep(POLL_SECONDS)
    return None


def run_compiler(command: list[str], work: str, stopped: Callable[[], bool]) -> int:
    """Run ``command`` to its end, or kill its whole tree when stopped (status 1 then)."""
    env = dict(os.environ, TMPDIR=work)  # the compiler's own temporary files too
    child = subprocess.Popen(command, stdin=subprocess.DEVNULL, env=env)
    while True:
        try:
            return child.wait(timeout=POLL_SECONDS)
        except subprocess.TimeoutExpired:
            if stopped():
                kill_tree(child)
                return 1


def publish(work: str, library: str) -> None:
    """Move the built ``WORK/out.so`` to ``library``, its checksum file first."""
    built = os.path.join(work, "out.so")
    with open(built, "rb") as f:
        digest = hashlib.sha256(f.read()).hexdigest()
    with open(os.path.join(work, "out.sha256"), "w") as f:
        f.write(digest + "\n")
    os.replace(os.path.join(work, "out.sha256"), library + ".sha256")
    os.replace(built, library)


def main(argv: list[str]) -> int:
    """Supervise one compile: ``argv`` is ``PARENT WORK SLOTS N LIBRARY COMMAND...``."""
    parent, work, slots, library = int(argv[0]), argv[1], argv[2], argv[4]
    n_slots, command = int(argv[3]), argv[5:]
    stop: list[int] = []
    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, lambda *_: stop.append(1))
    become_subreaper()

    def stopped() -> bool:
        return bool(stop) or os.getppid() != parent

    code = 1
    try:
        slot = take_slot(slots, n_slots, stopped)
        if slot is not None:
            code = run_compiler(command, work, stopped)
        if code == 0 and not stopped():
            publish(work, library)
        elif code == 0:
            code = 1
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return code


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
