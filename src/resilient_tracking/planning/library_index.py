"""Finding a cached library without generating its C source first.

A library is named by a hash of its functions' C source, and generating that source costs about
0.5 s at 10×10 in a few long CasADi calls that hold the interpreter (a running control loop
stalls behind them). A caller that can name what defines its functions passes that as a *key*:
an index entry (``index/HASH``, the hash of the key, the label and :func:`source_version`) then
names the library. A stale or missing entry only costs the generation.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import os
import sys
from pathlib import Path

import casadi as ca

from resilient_tracking.planning.library_cache import damage_of, mark_used


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


def _entry(directory: Path, label: str, key: str) -> Path:
    text = "\0".join((label, key, source_version()))
    return directory / "index" / hashlib.sha256(text.encode()).hexdigest()[:24]


def indexed_library(directory: Path, label: str, key: str, names: dict[str, str]) -> Path | None:
    """The intact cached library the index names for ``key`` (marked as used now), or None."""
    try:
        library = directory / _entry(directory, label, key).read_text(encoding="utf-8").strip()
    except (OSError, ValueError):  # missing, not a file, not text: only costs a generation
        return None
    if library.parent != directory or not library.exists() or damage_of(library, names):
        return None
    mark_used(library)
    return library


def record(directory: Path, label: str, key: str, library: Path) -> None:
    """Have the index name ``library`` for ``key`` (best effort: a failure only costs a later
    generation)."""
    entry = _entry(directory, label, key)
    with contextlib.suppress(OSError):
        entry.parent.mkdir(exist_ok=True)
        spare = entry.with_name(f".{entry.name}.{os.getpid()}")
        spare.write_text(library.name + "\n")
        os.replace(spare, entry)
