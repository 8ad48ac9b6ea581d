"""The on-disk cache of compiled libraries: where it is, which libraries are intact, and keeping
it small (docs/reliability.md §9).

Libraries live under ``$RTRACK_CACHE_DIR`` (default ``~/.cache/resilient_tracking/codegen``),
each ``NAME.so`` with its SHA-256 in ``NAME.so.sha256``. A library is loaded into this process
only once it is known intact: its checksum matches or, without a checksum file, its ELF headers
fit the file and a throwaway child process loads it (:func:`damage_of`). The cache is kept under
``$RTRACK_CACHE_MAX_MB`` (default 2048) by deleting the least recently used libraries; a
library's modification time is its last use. Compile jobs work in ``build-PID-…`` folders
beside the libraries, removed by their supervisor or, if their owner died, by
:func:`clean_dead_builds`.
"""

from __future__ import annotations

import contextlib
import logging
import os
import shutil
import struct
import subprocess
import sys
from pathlib import Path

from resilient_tracking.checksums import sha256_of

log = logging.getLogger(__name__)

#: Libraries kept in the cache beyond which the least recently used are deleted (MB).
DEFAULT_CACHE_MAX_MB = 2048.0
#: Prefix of a compile job's folder under the cache directory (then the owner's pid).
BUILD_PREFIX = "build-"
#: How long a child process may take to load a library being checked (s).
LOAD_CHECK_SECONDS = 60.0


def cache_dir() -> Path:
    """Where compiled libraries are cached: ``$RTRACK_CACHE_DIR``, else ``$XDG_CACHE_HOME`` (default
    ``~/.cache``) ``/resilient_tracking/codegen``."""
    root = os.environ.get("RTRACK_CACHE_DIR")
    if root:
        return Path(root)
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "resilient_tracking" / "codegen"


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
    modification time is its last use (:func:`mark_used`)."""
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
        remove_library(path)
        total -= size
        removed += 1
    if removed:
        log.info("codegen cache: removed %d least recently used libraries", removed)
    return removed


def mark_used(library: Path) -> None:
    """Record a library's use now (its modification time), for the least-recently-used pruning."""
    with contextlib.suppress(OSError):
        os.utime(library)


def remove_library(path: Path) -> None:
    """Delete a library and its checksum file, whichever exist."""
    for p in (path, Path(f"{path}.sha256")):
        with contextlib.suppress(FileNotFoundError):
            p.unlink()


def damage_of(library: Path, names: dict[str, str]) -> str | None:
    """Why a cached library cannot be used, or None; never loads it into this process.

    With a checksum file (``NAME.so.sha256``) the library must match it. Without one (a file
    from an older version, or a checksum deleted by hand) it must be a whole ELF file
    (:func:`elf_damage`: a truncated library would kill the process that maps it with SIGBUS)
    and a child process must load it and find ``names``; its checksum is then recorded."""
    sidecar = Path(f"{library}.sha256")
    try:
        if sidecar.exists():
            if sidecar.read_text().strip() != sha256_of(library):
                return "checksum does not match"
            return None
        damage = elf_damage(library)
    except OSError as err:
        return f"cannot read ({err.strerror})"
    if damage is None:
        damage = load_damage(library, names)
    if damage is None:
        with contextlib.suppress(OSError):
            sidecar.write_text(sha256_of(library) + "\n")
    return damage


#: ELF header fields after ``e_ident`` (type … shstrndx), 32- and 64-bit.
_ELF_HEADER = {1: "HHIIIIIHHHHHH", 2: "HHIQQQIHHHHHH"}
#: Program header: (format, index of p_offset, index of p_filesz), 32- and 64-bit.
_ELF_SEGMENT = {1: ("IIIIIIII", 1, 4), 2: ("IIQQQQQQ", 2, 5)}
_ET_DYN = 3
#: What the child process of :func:`load_damage` runs: load the library, look up each name.
_LOAD_SCRIPT = (
    "import ctypes, sys\nlib = ctypes.CDLL(sys.argv[1])\nfor n in sys.argv[2:]: getattr(lib, n)"
)


def elf_damage(library: Path) -> str | None:
    """Why ``library`` is not a whole ELF shared library, or None: its program and section
    header tables, and every segment, lie within the file (the section headers come last, so
    any truncation is caught). ``OSError`` if it cannot be read."""
    size = library.stat().st_size
    with library.open("rb") as handle:
        head = handle.read(64)
        if len(head) < 16 or head[:4] != b"\x7fELF" or head[4] not in _ELF_HEADER:
            return "not an ELF library"
        bits, order = head[4], "<" if head[5] == 1 else ">"
        header = struct.Struct(order + _ELF_HEADER[bits])
        if len(head) < 16 + header.size:
            return "not an ELF library"
        kind, _, _, _, phoff, shoff, _, _, phentsize, phnum, shentsize, shnum, _ = (
            header.unpack_from(head, 16)
        )
        if kind != _ET_DYN:
            return "not a shared library"
        needed = max(phoff + phnum * phentsize, shoff + shnum * shentsize)
        segment, at_offset, at_size = _ELF_SEGMENT[bits]
        entry = struct.Struct(order + segment)
        if phentsize >= entry.size and phoff + phnum * phentsize <= size:
            handle.seek(phoff)
            table = handle.read(phnum * phentsize)
            for k in range(phnum):
                fields = entry.unpack_from(table, k * phentsize)
                needed = max(needed, fields[at_offset] + fields[at_size])
    if needed > size:
        return f"truncated: {size} bytes, its ELF headers need {needed}"
    return None


def load_damage(library: Path, names: dict[str, str]) -> str | None:
    """Why a child process cannot load ``library`` and find the symbols ``names``, or None."""
    try:
        done = subprocess.run(
            [sys.executable, "-I", "-S", "-c", _LOAD_SCRIPT, str(library), *names.values()],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            timeout=LOAD_CHECK_SECONDS,
            check=False,
        )
    except subprocess.TimeoutExpired:
        return f"loading it took over {LOAD_CHECK_SECONDS:g} s"
    except OSError as err:
        return f"cannot check it ({err.strerror})"
    if done.returncode < 0:
        return f"loading it kills a process (signal {-done.returncode})"
    if done.returncode != 0:
        return "does not load"
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
