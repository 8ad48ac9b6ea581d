"""The on-disk cache of compiled libraries: where it is, which libraries are intact, and keeping
it small (docs/reliability.md §9).

Libraries live under ``$RTRACK_CACHE_DIR`` (default ``~/.cache/resilient_tracking/codegen``),
each ``NAME.so`` with its SHA-256 in ``NAME.so.sha256``. The cache is kept under
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
from pathlib import Path

import casadi as ca

from resilient_tracking.checksums import sha256_of

log = logging.getLogger(__name__)

#: Libraries kept in the cache beyond which the least recently used are deleted (MB).
DEFAULT_CACHE_MAX_MB = 2048.0
#: Prefix of a compile job's folder under the cache directory (then the owner's pid).
BUILD_PREFIX = "build-"


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
    """Why a cached library cannot be used, or None: its checksum (``NAME.so.sha256``) does
    not match, or, without one, it does not load."""
    sidecar = Path(f"{library}.sha256")
    try:
        if sidecar.exists():
            if sidecar.read_text().strip() != sha256_of(library):
                return "checksum does not match"
            return None
    except OSError as err:
        return f"cannot read ({err.strerror})"
    try:
        ca.external(next(iter(names.values())), str(library))
    except RuntimeError:
        return "does not load"
    with contextlib.suppress(OSError):
        sidecar.write_text(sha256_of(library) + "\n")
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
