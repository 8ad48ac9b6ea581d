"""Compile jobs this process owns (docs/reliability.md §9), and the libraries they build.

A job is one :mod:`~.compile_supervisor` process running the compiler on one source file.
:class:`CompiledFunctions` follows it (ready, failed, stopped) and loads the finished library's
functions. Jobs still running are stopped when this process exits (:func:`stop_all`, registered
with :mod:`atexit` and called on SIGINT/SIGTERM); if this process dies, each supervisor notices
and stops its own.
"""

from __future__ import annotations

import atexit
import logging
import os
import subprocess
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO

import casadi as ca

from resilient_tracking.planning import codegen_status as status
from resilient_tracking.planning import compile_supervisor
from resilient_tracking.planning.library_cache import prune_cache

log = logging.getLogger(__name__)

#: Compile jobs of this process still running (stopped at exit).
_RUNNING: list[CompiledFunctions] = []


@dataclass(eq=False)
class CompiledFunctions:
    """Functions (by key) compiled into one shared library, possibly still being built."""

    names: dict[str, str]
    library: Path
    process: subprocess.Popen[bytes] | None = None
    failed: bool = False
    stderr: IO[bytes] | None = None
    _loaded: dict[str, ca.Function] = field(default_factory=dict)

    def ready(self) -> bool:
        """True once the library exists (reaping a finished compile job)."""
        if self.failed:
            return False
        if self.process is not None:
            code = self.process.poll()
            if code is None:
                return False
            self._finish(code)
        return self.library.exists()

    def wait(self) -> bool:
        """Block until the compile job is done; True if the library is usable."""
        if self.process is not None:
            self._finish(self.process.wait())
        return self.ready()

    def stop(self) -> None:
        """Stop the compile job: its supervisor kills the compiler and removes its files."""
        process = self.process
        if process is None:
            return
        if process.poll() is None:
            process.terminate()
            try:
                process.wait(10)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()
        self.failed = True
        self._finish(None)

    def _finish(self, code: int | None) -> None:
        self.process = None
        if self in _RUNNING:
            _RUNNING.remove(self)
        err = ""
        if self.stderr is not None:
            self.stderr.seek(0)
            err = self.stderr.read()[-2000:].decode(errors="replace")
            self.stderr.close()
            self.stderr = None
        if code is None:
            return
        if code != 0:
            self.failed = True
            last = " | ".join(line for line in err.splitlines() if line.strip())[-300:]
            log.warning("compiling %s failed (exit %d): %s", self.library.name, code, last)
            status.record_failure(f"compiling {self.library.name} failed (exit {code})")
            return
        prune_cache(self.library.parent, keep=self.library)

    def load(self) -> dict[str, ca.Function]:
        """The compiled functions by key, loaded from the library on first use (call only once
        :meth:`ready`)."""
        if not self._loaded:
            self._loaded = {
                key: ca.external(name, str(self.library)) for key, name in self.names.items()
            }
        return self._loaded

    def external(self, key: str, options: dict) -> ca.Function:
        """The compiled function ``key`` loaded anew with CasADi ``options``."""
        return ca.external(self.names[key], str(self.library), options)


def start_job(
    names: dict[str, str], library: Path, workdir: Path, command: list[str]
) -> CompiledFunctions:
    """Start a supervised compile of ``command`` in ``workdir`` (a folder under the cache
    directory, removed when the job ends) that builds ``library``; the job is stopped at exit."""
    directory = library.parent
    stderr = tempfile.TemporaryFile(dir=directory)  # noqa: SIM115 - closed by the job
    process = subprocess.Popen(
        [
            sys.executable,
            "-I",
            str(compile_supervisor.__file__),
            str(os.getpid()),
            str(workdir),
            str(directory / "slots"),
            str(max(os.cpu_count() or 1, 1)),
            str(library),
            *command,
        ],
        stdin=subprocess.DEVNULL,
        stdout=subprocess.DEVNULL,
        stderr=stderr,
    )
    job = CompiledFunctions(names, library, process, stderr=stderr)
    _RUNNING.append(job)
    return job


def stop_all() -> None:
    """Stop every compile job this process started that is still running."""
    for job in list(_RUNNING):
        job.stop()


atexit.register(stop_all)
