"""The on-disk cache of compiled libraries: where it is, which libraries are intact, and keeping
it small (docs/reliability.md §9).

Libraries live under ``$RTRACK_CACHE_DIR`` (default ``~/.cache/resilient_tracking/codegen``),
each ``NAME.so`` with its SHA-256 in ``NAME.so.sha256``. A library is loaded into this process
only once it is known intact: its checksum matches or, without a checksum file, its ELF headers
fit the file and a throwaway child process loads it (:func:`damage_of`). The cache is kept under
``$RTRACK_CACHE_MAX_MB`` (default 2048) by deleting the least recently used libraries; a
library's modification time is its last use. Compile jobs work in ``build-PID-…`` folders
beside the libraries, removed by their supervisor or, if their owner died, by
:func:`clean_dead_builds`. Before a run, :func:`unusable` says why a cache cannot be used
(docs/reliability.md §11).
"""

from __future__ import annotations

import contextlib
import logging
import os
import shutil
import struct
import subprocess
import sys
import tempfile
from pathlib import Path

from resilient_tracking.checksums import sha256_of
from resilient_tracking.planning import codegen_settings

log = logging.getLogger(__name__)

#: Prefix of a compile job's folder under the cache directory (then the owner's pid).
BUILD_PREFIX = "build-"
#: How long a child process may take to load a library being checked (s).
LOAD_CHECK_SECONDS = 60.0


class NoCacheFolder(RuntimeError):
    """No folder for the cache can be named: no ``RTRACK_CACHE_DIR`` or ``XDG_CACHE_HOME``, and
    the home folder is unknown (no ``HOME``, and the user has no entry in the password file)."""


def cache_dir() -> Path:
    """Where compiled libraries are cached: ``$RTRACK_CACHE_DIR``, else ``$XDG_CACHE_HOME`` (an
    absolute path; default ``~/.cache``) ``/resilient_tracking/codegen``. :class:`NoCacheFolder`
    when none of them is known; ``SettingError`` for a ``RTRACK_CACHE_DIR`` not allowed."""
    root = codegen_settings.cache_root()
    if root:
        return Path(root)
    base = os.environ.get("XDG_CACHE_HOME", "")
    if not os.path.isabs(base):  # the XDG specification: a relative path is ignored
        try:
            base = str(Path.home() / ".cache")
        except RuntimeError:
            raise NoCacheFolder(
                "no folder for its cache: the home folder is unknown (no HOME, no user "
                "entry); set RTRACK_CACHE_DIR"
            ) from None
    return Path(base) / "resilient_tracking" / "codegen"


def cache_limit_bytes() -> int:
    """The cache size limit: ``$RTRACK_CACHE_MAX_MB`` megabytes (default 2048;
    ``SettingError`` for a value not allowed, see :mod:`~.codegen_settings`)."""
    return int(codegen_settings.cache_max_mb() * 1e6)


def unusable(directory: Path) -> str | None:
    """Why the cache in ``directory`` cannot be used, or None: it must be a folder (with its
    ``slots/`` and ``index/``, created if missing) this process can create files in; every
    library a file, every index entry and checksum file a file of UTF-8 text. Checked once
    before a run (0.1 s for 6000 entries); an entry another process removes meanwhile is
    skipped."""
    try:
        for folder in (directory, directory / "slots", directory / "index"):
            folder.mkdir(parents=True, exist_ok=True)
        handle, probe = tempfile.mkstemp(dir=directory, prefix=".probe-")
        os.close(handle)
        os.unlink(probe)
        for folder, text in ((directory, False), (directory / "index", True)):
            with os.scandir(folder) as listing:
                for entry in listing:
                    damage = _entry_damage(entry, text)
                    if damage is not None:
                        return f"cache entry {entry.path}: {damage} (remove it)"
    except OSError as err:
        return f"cache folder {err.filename or directory}: {err.strerror or err}"
    return None


def _entry_damage(entry: os.DirEntry[str], index: bool) -> str | None:
    """Why a cache entry (an index entry if ``index``, else anything in the cache folder)
    cannot be used, or None."""
    name = entry.name
    if name.startswith(".") or not (index or name.endswith((".so", ".so.sha256"))):
        return None
    try:
        if not entry.is_file():
            return "not a file"
        if index or name.endswith(".sha256"):
            with open(entry.path, "rb") as handle:
                handle.read().decode("utf-8")
    except FileNotFoundError:  # removed by another process meanwhile
        return None
    except UnicodeDecodeError:
        return "not UTF-8 text"
    return None


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
            if sidecar.read_text(encoding="utf-8").strip() != sha256_of(library):
                return "checksum does not match"
            return None
        damage = elf_damage(library)
    except OSError as err:
        return f"cannot read ({err.strerror})"
    except UnicodeDecodeError:
        return "its checksum file is not text"
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
