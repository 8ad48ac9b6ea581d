"""Compiled C code for the league NLP's functions, cached on disk by a hash of what defines them.

CasADi evaluates SX functions in a virtual machine; the same functions generated as C and
compiled with ``gcc`` evaluate 10–30× faster (docs/performance.md). The generated code performs
the same floating-point operations in the same order, and is compiled without fast-math, so
results are bit-for-bit those of the virtual machine (tested).

Compilation runs in the background: a problem starts on the virtual machine and switches to
the compiled functions once the library is ready, so a large structure's first use never waits
a minute for the compiler. Libraries are cached under ``$RTRACK_CACHE_DIR`` (default
``~/.cache/resilient_tracking/codegen``), named by a hash of the functions' C source (so any
change to the problem or to CasADi gives a new name). Set ``RTRACK_CODEGEN=0`` to disable;
without ``gcc`` it is disabled automatically.

Each compile is a *job* this process owns (docs/reliability.md §9): a small supervisor process
runs the compiler in a process group of its own, with its source and temporary files in a
folder under the cache directory, and

- waits for one of ``os.cpu_count()`` compile slots (``flock`` on files in the cache directory,
  shared by every process), so compiles never outnumber the cores;
- kills the compiler's whole group and removes its folder when this process exits, is
  stopped (SIGINT/SIGTERM, :func:`stop_all` at exit) or dies (the supervisor polls its parent);
- renames the finished library into the cache, with a ``.sha256`` beside it. A cached library
  whose checksum does not match, or that does not load, is removed and rebuilt once, with one
  warning line.

The cache is kept under ``$RTRACK_CACHE_MAX_MB`` (default 2048) by deleting the least recently
used libraries after each build.

Finding a cached library by its source's hash means generating the source first: about 0.5 s
at 10×10 in a few long CasADi calls that hold the interpreter (a running control loop stalls
behind them). A caller that can name what defines its functions passes that as ``key``: an
index (``index/HASH``, the hash of the key, the label and :func:`source_version`) then leads to
the library without generating anything. A stale or missing entry only costs the generation.
"""

from __future__ import annotations

import atexit
import contextlib
import functools
import hashlib
import logging
import os
import shutil
import subprocess
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO

import casadi as ca

log = logging.getLogger(__name__)

#: Source files above this size are compiled with -O1 (much faster to compile, a bit slower).
LARGE_SOURCE_BYTES = 1_000_000


def enabled() -> bool:
    """Whether compiled code is used: ``RTRACK_CODEGEN`` not ``0`` and a C compiler found."""
    if os.environ.get("RTRACK_CODEGEN", "1").strip().lower() in ("0", "false", "no", "off"):
        return False
    return compiler() is not None


def compiler() -> str | None:
    """Path of the C compiler (``$CC``, default ``gcc``), or None when none is found."""
    return shutil.which(os.environ.get("CC", "gcc"))


def cache_dir() -> Path:
    """Where compiled libraries are cached: ``$RTRACK_CACHE_DIR``, else ``$XDG_CACHE_HOME`` (default
    ``~/.cache``) ``/resilient_tracking/codegen``."""
    root = os.environ.get("RTRACK_CACHE_DIR")
    if root:
        return Path(root)
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "resilient_tracking" / "codegen"


#: Libraries kept in the cache beyond which the least recently used are deleted (MB).
DEFAULT_CACHE_MAX_MB = 2048.0
#: Prefix of a compile job's folder under the cache directory (then the owner's pid).
BUILD_PREFIX = "build-"

# The supervisor of one compile job, run as ``python -I -c``: argv is the parent's pid, the
# job's folder, the slots folder, the number of slots, the library's final path, then the
# compiler command. It takes a compile slot, runs the compiler as its child (the subreaper of
# the compiler's own children), and on the parent's death or SIGTERM/SIGINT kills them all. It
# always removes the job's folder; on success it renames the library (and its .sha256) into place.
_SUPERVISOR = r"""
import ctypes, fcntl, hashlib, os, shutil, signal, subprocess, sys, time
parent, work, slots, library = int(sys.argv[1]), sys.argv[2], sys.argv[3], sys.argv[5]
n_slots, command = int(sys.argv[4]), sys.argv[6:]
stop = []
for sig in (signal.SIGTERM, signal.SIGINT):
    signal.signal(sig, lambda *_: stop.append(1))
try:
    ctypes.CDLL(None).prctl(36, 1, 0, 0, 0)  # PR_SET_CHILD_SUBREAPER: orphans of gcc come here
except (OSError, AttributeError):
    pass

def stopped():
    return bool(stop) or os.getppid() != parent

def descendants():
    kids = {}
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

def kill_tree(child):
    for _ in range(50):
        pids = set(descendants()) | ({child.pid} if child.poll() is None else set())
        if not pids:
            return
        for pid in pids:
            try:
                os.kill(pid, signal.SIGKILL)
            except OSError:
                pass
        time.sleep(0.02)
        try:
            while os.waitpid(-1, os.WNOHANG)[0]:
                pass
        except ChildProcessError:
            pass

code = 1
try:
    slot = None
    while slot is None and not stopped():
        for i in range(n_slots):
            fd = os.open(os.path.join(slots, f"slot-{i}"), os.O_RDWR | os.O_CREAT, 0o644)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                slot = fd
                break
            except OSError:
                os.close(fd)
        else:
            time.sleep(0.2)
    if slot is not None:
        env = dict(os.environ, TMPDIR=work)  # the compiler's own temporary files too
        child = subprocess.Popen(command, stdin=subprocess.DEVNULL, env=env)
        while True:
            try:
                code = child.wait(timeout=0.2)
                break
            except subprocess.TimeoutExpired:
                if stopped():
                    kill_tree(child)
                    code = 1
                    break
    if code == 0 and not stopped():
        built = os.path.join(work, "out.so")
        with open(built, "rb") as f:
            digest = hashlib.sha256(f.read()).hexdigest()
        with open(os.path.join(work, "out.sha256"), "w") as f:
            f.write(digest + "\n")
        os.replace(os.path.join(work, "out.sha256"), library + ".sha256")
        os.replace(built, library)
    elif code == 0:
        code = 1
finally:
    shutil.rmtree(work, ignore_errors=True)
sys.exit(code)
"""

#: Compile jobs of this process still running (stopped at exit).
_RUNNING: list[CompiledFunctions] = []
#: Libraries found damaged and rebuilt in this process (rebuilt once only).
_REBUILT: set[str] = set()


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


def stop_all() -> None:
    """Stop every compile job this process started that is still running."""
    for job in list(_RUNNING):
        job.stop()


atexit.register(stop_all)


def cache_limit_bytes() -> int:
    """The cache size limit: ``$RTRACK_CACHE_MAX_MB`` megabytes (default 2048)."""
    text = os.environ.get("RTRACK_CACHE_MAX_MB", "").strip()
    try:
        megabytes = float(text) if text else DEFAULT_CACHE_MAX_MB
    except ValueError:
        log.warning(
            "RTRACK_CACHE_MAX_MB=%r is not a number; using %g", text[:40], DEFAULT_CACHE_MAX_MB
        )
        megabytes = DEFAULT_CACHE_MAX_MB
    return int(max(megabytes, 0.0) * 1e6)


def prune_cache(directory: Path, keep: Path | None = None, limit: int | None = None) -> int:
    """Delete the least recently used libraries until the cache fits ``limit`` bytes; returns
    how many were deleted. ``keep`` (the library just built) is never deleted. A library's
    modification time is its last use (:func:`compile_functions` touches it)."""
    limit = cache_limit_bytes() if limit is None else limit
    entries = []
    for path in directory.glob("*.so"):
        with contextlib.suppress(OSError):
            info = path.stat()
            entries.append((info.st_mtime, info.st_size, path))
    total = sum(size for _, size, _ in entries)
    removed = 0
    for _, size, path in sorted(entries):
        if total <= limit:
            break
        if path == keep:
            continue
        _remove_library(path)
        total -= size
        removed += 1
    if removed:
        log.info("codegen cache: removed %d least recently used libraries", removed)
    return removed


def _remove_library(path: Path) -> None:
    for p in (path, Path(f"{path}.sha256")):
        with contextlib.suppress(FileNotFoundError):
            p.unlink()


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with path.open("rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def damage_of(library: Path, names: dict[str, str]) -> str | None:
    """Why a cached library cannot be used, or None: its checksum (``NAME.so.sha256``) does
    not match, or, without one, it does not load."""
    sidecar = Path(f"{library}.sha256")
    try:
        if sidecar.exists():
            if sidecar.read_text().strip() != _sha256(library):
                return "checksum does not match"
            return None
    except OSError as err:
        return f"cannot read ({err.strerror})"
    try:
        ca.external(next(iter(names.values())), str(library))
    except RuntimeError:
        return "does not load"
    with contextlib.suppress(OSError):
        sidecar.write_text(_sha256(library) + "\n")
    return None


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def clean_dead_builds(directory: Path) -> int:
    """Remove job folders whose owner process is gone (it was killed with its supervisor)."""
    removed = 0
    for folder in directory.glob(f"{BUILD_PREFIX}*"):
        owner = folder.name[len(BUILD_PREFIX) :].split("-", 1)[0]
        if folder.is_dir() and owner.isdigit() and not _alive(int(owner)):
            shutil.rmtree(folder, ignore_errors=True)
            removed += 1
    return removed


@functools.cache
def source_version() -> str:
    """A hash of this package's Python sources and of CasADi's version: with a caller's key,
    what the generated code is a function of."""
    root = Path(__file__).resolve().parents[1]
    digest = hashlib.sha256(ca.CasadiMeta.version().encode())
    for path in sorted(root.rglob("*.py")):
        digest.update(path.relative_to(root).as_posix().encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()[:20]


def module_digest(obj: object) -> str | None:
    """A hash of the source file defining ``obj`` (a plug-in sensor model, say, whose code is
    outside this package and so outside :func:`source_version`); None when it has none."""
    module = sys.modules.get(getattr(obj, "__module__", ""))
    try:
        data = Path(getattr(module, "__file__", "") or "").read_bytes()
    except OSError:
        return None
    return hashlib.sha256(data).hexdigest()[:20]


def _index_entry(directory: Path, label: str, key: str) -> Path:
    text = "\0".join((label, key, source_version()))
    return directory / "index" / hashlib.sha256(text.encode()).hexdigest()[:24]


def _indexed(
    directory: Path, label: str, key: str, names: dict[str, str]
) -> CompiledFunctions | None:
    """The intact cached library the index names for ``key``, or None."""
    try:
        library = directory / _index_entry(directory, label, key).read_text().strip()
    except OSError:
        return None
    if library.parent != directory or not library.exists() or damage_of(library, names):
        return None
    with contextlib.suppress(OSError):
        os.utime(library)  # its last use, for the least-recently-used pruning
    return CompiledFunctions(names, library)


def _index(directory: Path, label: str, key: str, library: Path) -> None:
    entry = _index_entry(directory, label, key)
    with contextlib.suppress(OSError):
        entry.parent.mkdir(exist_ok=True)
        spare = entry.with_name(f".{entry.name}.{os.getpid()}")
        spare.write_text(library.name + "\n")
        os.replace(spare, entry)


def compile_functions(
    functions: dict[str, ca.Function], label: str, key: str | None = None
) -> CompiledFunctions | None:
    """Start compiling ``functions`` (or find them in the cache); None if codegen is off.

    ``key``, if given, must determine ``functions`` together with this package's sources (for
    example the problem's structure and options): the cached library is then found through
    the index without generating code."""
    if not enabled():
        return None
    names = {name: f"{label}_{name}" for name in functions}
    directory = cache_dir()
    if key is not None:
        found = _indexed(directory, label, key, names)
        if found is not None:
            return found
    try:
        (directory / "slots").mkdir(parents=True, exist_ok=True)
        clean_dead_builds(directory)
        workdir = Path(tempfile.mkdtemp(dir=directory, prefix=f"{BUILD_PREFIX}{os.getpid()}-"))
    except OSError as err:
        log.warning("codegen cache %s unusable: %s", directory, err)
        return None
    try:
        generator = ca.CodeGenerator(f"{label}.c", {"with_header": False})
        for name, f in functions.items():
            inputs = f.sx_in()
            generator.add(
                ca.Function(names[name], inputs, f.call(inputs), f.name_in(), f.name_out())
            )
        generator.generate(str(workdir) + os.sep)
        source = workdir / f"{label}.c"
        digest = hashlib.sha256(source.read_bytes()).hexdigest()[:20]
    except Exception as err:  # code generation is an optimisation: never fail a solve on it
        log.warning("code generation for %s failed: %s", label, err)
        shutil.rmtree(workdir, ignore_errors=True)
        return None
    library = directory / f"{label}_{digest}.so"
    if key is not None:
        _index(directory, label, key, library)
    if library.exists():
        damage = damage_of(library, names)
        if damage is None:
            shutil.rmtree(workdir, ignore_errors=True)
            with contextlib.suppress(OSError):
                os.utime(library)  # its last use, for the least-recently-used pruning
            return CompiledFunctions(names, library)
        _remove_library(library)
        if library.name in _REBUILT:
            log.warning("cached %s is damaged again (%s); not using compiled code", library, damage)
            shutil.rmtree(workdir, ignore_errors=True)
            return None
        _REBUILT.add(library.name)
        log.warning("cached %s is damaged (%s); removed, rebuilding it", library, damage)
    level = "-O1" if source.stat().st_size > LARGE_SOURCE_BYTES else "-O2"
    command = [
        str(compiler()),
        "-shared",
        "-fPIC",
        level,
        "-o",
        str(workdir / "out.so"),
        str(source),
    ]
    log.info("compiling %s in the background (%s)", library.name, level)
    stderr = tempfile.TemporaryFile(dir=directory)  # noqa: SIM115 - closed by the job
    process = subprocess.Popen(
        [
            sys.executable,
            "-I",
            "-c",
            _SUPERVISOR,
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
