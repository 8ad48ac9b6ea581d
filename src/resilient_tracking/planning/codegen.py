"""Compiled C code for the league NLP's functions, cached on disk by a hash of what defines them.

CasADi evaluates SX functions in a virtual machine; the same functions generated as C and
compiled with ``gcc`` evaluate 10–30× faster (docs/performance.md). The generated code performs
the same floating-point operations in the same order, and is compiled without fast-math, so
results are bit-for-bit those of the virtual machine (tested).

Compilation runs in a background ``gcc`` process: a problem starts on the virtual machine and
switches to the compiled functions once the library is ready, so a large structure's first
use never waits a minute for the compiler. Libraries are cached under
``$RTRACK_CACHE_DIR`` (default ``~/.cache/resilient_tracking/codegen``), named by a hash of
the functions' C source (so any change to the problem or to CasADi gives a new name). Set
``RTRACK_CODEGEN=0`` to disable; without ``gcc`` it is disabled automatically.
"""

from __future__ import annotations

import hashlib
import logging
import os
import shlex
import shutil
import subprocess
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

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
    return shutil.which(os.environ.get("CC", "gcc"))


def cache_dir() -> Path:
    root = os.environ.get("RTRACK_CACHE_DIR")
    if root:
        return Path(root)
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "resilient_tracking" / "codegen"


@dataclass
class CompiledFunctions:
    """Functions (by key) compiled into one shared library, possibly still being built."""

    names: dict[str, str]
    library: Path
    process: subprocess.Popen[bytes] | None = None
    workdir: Path | None = None
    failed: bool = False
    _loaded: dict[str, ca.Function] = field(default_factory=dict)

    def ready(self) -> bool:
        """True once the library exists (reaping a finished compiler process)."""
        if self.failed:
            return False
        if self.process is not None:
            code = self.process.poll()
            if code is None:
                return False
            self._finish(code)
        return self.library.exists()

    def wait(self) -> bool:
        """Block until the compiler is done; True if the library is usable."""
        if self.process is not None:
            self._finish(self.process.wait())
        return self.ready()

    def _finish(self, code: int) -> None:
        process, self.process = self.process, None
        err = process.stderr.read().decode(errors="replace") if process and process.stderr else ""
        if process and process.stderr:
            process.stderr.close()
        if code != 0:
            self.failed = True
            log.warning("compiling %s failed (%d): %s", self.library.name, code, err[-500:])
        if self.workdir is not None:
            shutil.rmtree(self.workdir, ignore_errors=True)
            self.workdir = None

    def load(self) -> dict[str, ca.Function]:
        if not self._loaded:
            self._loaded = {
                key: ca.external(name, str(self.library)) for key, name in self.names.items()
            }
        return self._loaded

    def external(self, key: str, options: dict) -> ca.Function:
        """The compiled function ``key`` loaded anew with CasADi ``options``."""
        return ca.external(self.names[key], str(self.library), options)


def compile_functions(functions: dict[str, ca.Function], label: str) -> CompiledFunctions | None:
    """Start compiling ``functions`` (or find them in the cache); None if codegen is off."""
    if not enabled():
        return None
    names = {key: f"{label}_{key}" for key in functions}
    workdir = Path(tempfile.mkdtemp(prefix="rtrack-codegen-"))
    try:
        generator = ca.CodeGenerator(f"{label}.c", {"with_header": False})
        for key, f in functions.items():
            inputs = f.sx_in()
            generator.add(
                ca.Function(names[key], inputs, f.call(inputs), f.name_in(), f.name_out())
            )
        generator.generate(str(workdir) + os.sep)
        source = workdir / f"{label}.c"
        digest = hashlib.sha256(source.read_bytes()).hexdigest()[:20]
    except Exception as err:  # code generation is an optimisation: never fail a solve on it
        log.warning("code generation for %s failed: %s", label, err)
        shutil.rmtree(workdir, ignore_errors=True)
        return None
    directory = cache_dir()
    library = directory / f"{label}_{digest}.so"
    if library.exists():
        shutil.rmtree(workdir, ignore_errors=True)
        return CompiledFunctions(names, library)
    try:
        directory.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        log.warning("codegen cache %s unusable: %s", directory, err)
        shutil.rmtree(workdir, ignore_errors=True)
        return None
    level = "-O1" if source.stat().st_size > LARGE_SOURCE_BYTES else "-O2"
    partial = directory / f".{library.name}.{os.getpid()}.tmp"
    # compile to a private name, then rename: parallel processes never load a partial file
    cc, partial_q, library_q = (shlex.quote(str(a)) for a in (compiler(), partial, library))
    command = (
        f"{cc} -shared -fPIC {level} -o {partial_q} {shlex.quote(str(source))} "
        f"&& mv -f {partial_q} {library_q}"
    )
    log.info("compiling %s in the background (%s)", library.name, level)
    process = subprocess.Popen(
        ["sh", "-c", command], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE
    )
    return CompiledFunctions(names, library, process, workdir)
