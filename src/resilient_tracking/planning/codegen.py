"""Compiled C code for the league NLP's functions, cached on disk by a hash of what defines them.

CasADi evaluates SX functions in a virtual machine; the same functions generated as C and
compiled with ``gcc`` evaluate 10–30× faster (docs/performance.md). The generated code performs
the same floating-point operations in the same order, and is compiled without fast-math, so
results are bit-for-bit those of the virtual machine (tested).

Compilation runs in the background: a problem starts on the virtual machine and switches to
the compiled functions once the library is ready, so a large structure's first use never waits
a minute for the compiler. Set ``RTRACK_CODEGEN=0`` to disable; without ``gcc`` it is disabled
automatically.

:func:`compile_functions` is the way in; the parts it uses, one job each:

- :mod:`~.library_cache` — the cache folder (``$RTRACK_CACHE_DIR``), checksums of the cached
  libraries, pruning to ``$RTRACK_CACHE_MAX_MB``;
- :mod:`~.library_index` — finding a library by a caller's key without generating code;
- :mod:`~.compile_jobs` — the compile jobs this process owns and the libraries they build;
- :mod:`~.compile_supervisor` — the program that supervises one compile (slots, killing the
  compiler's process tree, publishing the library).

A cached library whose checksum does not match or, without a checksum, that is not a whole ELF
file or does not load in a child process, is removed and rebuilt once, with one warning line; a
damaged library is never loaded into this process.
"""

from __future__ import annotations

import hashlib
import logging
import os
import shutil
import tempfile
from pathlib import Path

import casadi as ca

from resilient_tracking import interrupts
from resilient_tracking.planning import codegen_settings, library_cache, library_index
from resilient_tracking.planning import codegen_status as status
from resilient_tracking.planning.compile_jobs import CompiledFunctions, start_job
from resilient_tracking.planning.library_cache import (
    BUILD_PREFIX,
    cache_dir,
    clean_dead_builds,
    damage_of,
    mark_used,
    remove_library,
)

log = logging.getLogger(__name__)

#: Source files above this size are compiled with -O1 (much faster to compile, a bit slower).
LARGE_SOURCE_BYTES = 1_000_000

#: Libraries found damaged and rebuilt in this process (rebuilt once only).
_REBUILT: set[str] = set()


def enabled() -> bool:
    """Whether compiled code is used: ``RTRACK_CODEGEN`` not ``0``, a C compiler found, and the
    cache not found unusable (:func:`prepare`). ``SettingError`` for a variable not allowed."""
    if not codegen_settings.codegen_on() or status.off_reason() is not None:
        return False
    return compiler() is not None


def prepare() -> bool:
    """Before a run: check the environment's settings (``SettingError`` naming a variable not
    allowed) and, once per process and cache setting, that the cache can be used: without a
    folder for it (no home folder), or with an entry that cannot be read
    (:func:`~.library_cache.unusable`), compiled code is turned off with one warning naming
    the cause, and the run goes on as with ``RTRACK_CODEGEN=0``. Returns :func:`enabled`."""
    codegen_settings.check()
    on = enabled()
    if not on or status.checked():
        return on
    try:
        reason = library_cache.unusable(library_cache.cache_dir())
    except library_cache.NoCacheFolder as err:
        reason = str(err)
    status.set_checked(reason)
    return reason is None


def turn_off(err: Exception, doing: str) -> None:
    """The compiled path raised ``err`` while ``doing``: record the failure (the run is marked,
    :mod:`~.codegen_status`) and turn compiled code off for the rest of this process, with one
    warning; solvers go on, on the virtual machine."""
    what = f"{doing}: {type(err).__name__}: {err}"
    status.record_failure(what)
    if status.off_reason() is None:
        status.set_checked(what)


def compiler() -> str | None:
    """Path of the C compiler (``$CC``, default ``gcc``), or None when none is found."""
    return shutil.which(os.environ.get("CC", "gcc"))


def generate_source(functions: dict[str, ca.Function], names: dict[str, str], path: Path) -> None:
    """Write the C source of ``functions`` to ``path``, each under its name in ``names``."""
    generator = ca.CodeGenerator(path.name, {"with_header": False})
    for name, f in functions.items():
        inputs = f.sx_in()
        generator.add(ca.Function(names[name], inputs, f.call(inputs), f.name_in(), f.name_out()))
    generator.generate(str(path.parent) + os.sep)


def compile_functions(
    functions: dict[str, ca.Function], label: str, key: str | None = None
) -> CompiledFunctions | None:
    """Start compiling ``functions`` (or find them in the cache); None if codegen is off.

    ``key``, if given, must determine ``functions`` together with this package's sources (for
    example the problem's structure and options): the cached library is then found through
    the index (:mod:`~.library_index`) without generating code."""
    if not prepare():
        return None
    names = {name: f"{label}_{name}" for name in functions}
    directory = cache_dir()
    if key is not None:
        found = library_index.indexed_library(directory, label, key, names)
        if found is not None:
            return CompiledFunctions(names, found)
    try:
        (directory / "slots").mkdir(parents=True, exist_ok=True)
        clean_dead_builds(directory)
        workdir = Path(tempfile.mkdtemp(dir=directory, prefix=f"{BUILD_PREFIX}{os.getpid()}-"))
    except OSError as err:
        turn_off(err, f"preparing a compile in {directory}")
        return None
    source = workdir / f"{label}.c"
    try:
        generate_source(functions, names, source)
        digest = hashlib.sha256(source.read_bytes()).hexdigest()[:20]
    except Exception as err:  # code generation is an optimisation: never fail a solve on it
        interrupts.reraise(err)
        log.warning("code generation for %s failed: %s", label, err)
        status.record_failure(f"code generation for {label}: {type(err).__name__}: {err}")
        shutil.rmtree(workdir, ignore_errors=True)
        return None
    library = directory / f"{label}_{digest}.so"
    if key is not None:
        library_index.record(directory, label, key, library)
    if library.exists():
        damage = damage_of(library, names)
        if damage is None:
            shutil.rmtree(workdir, ignore_errors=True)
            mark_used(library)
            return CompiledFunctions(names, library)
        remove_library(library)
        if library.name in _REBUILT:
            log.warning("cached %s is damaged again (%s); not using compiled code", library, damage)
            status.record_failure(f"{library.name}: damaged again ({damage})")
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
    return start_job(names, library, workdir, command)
