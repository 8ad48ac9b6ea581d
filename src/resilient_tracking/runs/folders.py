"""Run folders on disk: what this tool wrote, a lock per folder, and leftovers of killed writes.

Rules (docs/reliability.md §8):

- a run folder's ``manifest.json`` lists every file the run wrote with its SHA-256
  (``files``) and carries a checksum of the manifest itself (``manifest_sha256``), so a stored
  run whose tables were damaged or whose manifest was edited is recognised (:func:`verify`);
- a stored run whose tables lack columns of the declaration
  (:data:`~resilient_tracking.runs.schema.TABLES`) was written by an older version: it is
  reported as old by :func:`verify` (and run again by a sweep);
- a run folder is never the current folder or one above it (it is renamed into place);
- a folder is replaced whole only when everything in it was written by this tool; anything
  else in it (a user's ``notes.txt``) makes the write refuse, unless ``overwrite`` is given, and
  then the run's files are written beside the user's, which are never deleted
  (:func:`foreign_entries`);
- one process at a time writes a folder: :func:`folder_lock` holds an exclusive ``flock`` on
  a hidden ``.NAME.lock`` beside it (released by the kernel if the process dies);
- staging folders of writes that were killed (``.NAME.XXXXXXXX.partial``/``.old``) are removed
  by the next write of that folder, under its lock (:func:`clean_stale`).
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import hashlib
import json
import os
import re
import shutil
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from resilient_tracking import interrupts
from resilient_tracking.checksums import sha256_of
from resilient_tracking.runs.schema import TABLE_FILES, TABLES

MANIFEST = "manifest.json"
FIGURES = "figures"
#: Files that commands other than ``run`` may add to a run folder (``rtrack animate``).
LATER_FILES = ("figures/animation.gif", "figures/animation.mp4")


class FolderBusyError(RuntimeError):
    """Another process is writing the same folder."""


#: Characters a folder name built from a label keeps; any other becomes ``_``.
_UNPORTABLE = re.compile(r"[^A-Za-z0-9._-]")


def folder_name(label: str) -> str:
    """``label`` as one portable folder name: a policy named by its class,
    ``pkg.module:Class``, becomes ``pkg.module_Class`` (a colon is not allowed in a Windows
    path, and a slash would nest folders)."""
    return _UNPORTABLE.sub("_", label) or "_"


def files_of(folder: Path) -> list[str]:
    """Relative paths (``/``-separated) of every file under ``folder``, sorted."""
    return sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*") if p.is_file())


def manifest_digest(manifest: dict[str, Any]) -> str:
    """SHA-256 of the manifest's canonical JSON, without its own checksum field."""
    body = {k: v for k, v in manifest.items() if k != "manifest_sha256"}
    text = json.dumps(body, sort_keys=True, default=str, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


def seal(manifest: dict[str, Any], folder: Path) -> dict[str, Any]:
    """``manifest`` plus the checksums of every file in ``folder`` and of itself."""
    sealed = {k: v for k, v in manifest.items() if k not in ("files", "manifest_sha256")}
    sealed["files"] = {
        name: sha256_of(folder / name) for name in files_of(folder) if name != MANIFEST
    }
    # round-trip through JSON so the digest is of what a reader will see
    sealed = json.loads(json.dumps(sealed, default=str))
    sealed["manifest_sha256"] = manifest_digest(sealed)
    return sealed


def read_manifest(folder: Path) -> dict[str, Any]:
    """The manifest of ``folder``; ``ValueError`` naming the file if it is not a JSON object."""
    path = folder / MANIFEST
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except UnicodeDecodeError as err:
        raise ValueError(f"{path}: not UTF-8 text ({err.reason})") from None
    except json.JSONDecodeError as err:
        raise ValueError(f"{path}: not valid JSON ({err.msg} at line {err.lineno})") from None
    if not isinstance(data, dict):
        raise ValueError(f"{path}: expected a JSON object, got {type(data).__name__}")
    return data


def verify(folder: Path, tables_only: bool = True) -> str | None:
    """Why the stored run in ``folder`` cannot be trusted, or None if it can.

    Checks that the manifest is intact (its checksum), that each table (every listed file
    if not ``tables_only``) has the recorded SHA-256, and that every table has the declared
    columns (else the run is old: written before a column was added). A folder written before
    checksums were recorded is checked by reading each table's parquet footer.
    """
    damage = _verify_files(folder, tables_only)
    return damage if damage is not None else old_tables(folder)


def old_tables(folder: Path) -> str | None:
    """Why the tables in ``folder`` are not those this version writes (declared columns
    missing: a run written by an older version), or None when they are."""
    import pyarrow.parquet as pq

    for table in TABLES.values():
        path = folder / table.file
        if table.optional and not path.exists():
            continue
        try:
            present = set(pq.read_schema(path).names)
        except Exception as err:  # any reader error means the table cannot be used
            interrupts.check()
            return f"{path}: unreadable ({type(err).__name__})"
        missing = [c for c in table.names if c not in present]
        if missing:
            return (
                f"{path}: an old run, written before the {table.name} table had the columns "
                f"{', '.join(missing)}"
            )
    return None


def _verify_files(folder: Path, tables_only: bool) -> str | None:
    try:
        manifest = read_manifest(folder)
    except (OSError, ValueError) as err:
        return str(err)
    files = manifest.get("files")
    if not isinstance(files, dict):
        return _verify_legacy(folder)
    if manifest.get("manifest_sha256") != manifest_digest(manifest):
        return f"{folder / MANIFEST}: edited after the run (its checksum does not match)"
    for name, digest in files.items():
        if tables_only and not name.endswith(".parquet"):
            continue
        path = folder / name
        try:
            if sha256_of(path) != digest:
                return f"{path}: damaged (checksum does not match the manifest)"
        except OSError as err:
            return f"{path}: cannot read ({err.strerror})"
    return None


def _verify_legacy(folder: Path) -> str | None:
    import pyarrow.parquet as pq

    for name in TABLE_FILES:
        path = folder / name
        try:
            pq.read_metadata(path)
        except Exception as err:  # any reader error means the table cannot be used
            interrupts.check()
            return f"{path}: unreadable ({type(err).__name__})"
    return None


def _ours(folder: Path) -> set[str]:
    """Relative paths of the files this tool wrote into the run folder ``folder``."""
    ours = {MANIFEST, *LATER_FILES}
    try:
        files = read_manifest(folder).get("files")
    except (OSError, ValueError):
        return ours | set(TABLE_FILES)  # a run folder whose manifest broke
    if isinstance(files, dict):
        return ours | {str(name) for name in files}
    # written before files were listed: the tables and the figures
    figures = {f"{FIGURES}/{p.name}" for p in (folder / FIGURES).glob("*.png")}
    return ours | set(TABLE_FILES) | figures


def foreign_entries(folder: Path) -> list[str]:
    """What in ``folder`` this tool did not write (``name`` for files, ``name/`` for folders).

    An empty folder has none; a folder without a manifest is all foreign.
    """
    if not folder.is_dir():
        return []
    entries = sorted(folder.iterdir())
    if not (folder / MANIFEST).is_file():
        return [e.name + ("/" if e.is_dir() else "") for e in entries]
    ours = _ours(folder)
    foreign: list[str] = []
    for entry in entries:
        if entry.is_dir() and not entry.is_symlink():
            inside = [f"{entry.name}/{rel}" for rel in files_of(entry)]
            if any(rel in ours for rel in inside):
                foreign.extend(rel for rel in inside if rel not in ours)
            else:  # a folder holding nothing of ours, or empty
                foreign.append(entry.name + "/")
        elif entry.name not in ours:
            foreign.append(entry.name)
    return foreign


def holds_working_folder(out: Path) -> bool:
    """Whether ``out`` is the current folder or one above it (``.``, ``..``)."""
    try:
        here, target = Path.cwd().resolve(), out.resolve()
    except OSError:  # the current folder was removed: it is not ``out``
        return False
    return target == here or target in here.parents


def check_out_folder(out: Path, overwrite: bool = False) -> list[str]:
    """The foreign entries of ``out`` (see :func:`foreign_entries`), after refusing with
    ``FileExistsError`` a symbolic link (a run folder is renamed into place, which would replace
    the link itself), a path that is not a folder, the current folder or one above it (which
    the folder a process works in cannot be), or foreign entries without ``overwrite``."""
    if out.is_symlink():
        raise FileExistsError(
            f"{out}: is a symbolic link; a run folder is renamed into place, which would "
            "replace the link: give the folder it points to, or a new folder"
        )
    if out.exists() and not out.is_dir():
        raise FileExistsError(f"{out}: exists and is not a folder")
    if holds_working_folder(out):
        raise FileExistsError(
            f"{out}: is the current folder or holds it; a run folder is written beside its "
            "place and renamed into it, which cannot be done to the folder you are in: give a "
            "new folder, e.g. --out run1"
        )
    foreign = foreign_entries(out)
    if foreign and not overwrite:
        more = f" and {len(foreign) - 5} more" if len(foreign) > 5 else ""
        raise FileExistsError(
            f"{out}: not a run folder of rtrack: it holds files rtrack did not write "
            f"({', '.join(foreign[:5])}{more}); choose another folder, or pass --overwrite to "
            "write the run beside them (they are never deleted)"
        )
    return foreign


def _lock_path(folder: Path) -> Path:
    return folder.parent / f".{folder.name}.lock"


_HELD: dict[Path, list[int]] = {}  # resolved lock path -> [fd, depth] (re-entrant per process)


@contextlib.contextmanager
def folder_lock(folder: str | Path) -> Iterator[None]:
    """Hold the write lock of ``folder``; :class:`FolderBusyError` if another process holds it.

    Re-entrant within a process. The lock file is removed on release.
    """
    folder = Path(folder)
    folder.parent.mkdir(parents=True, exist_ok=True)
    path = _lock_path(folder.resolve())
    if path in _HELD:
        _HELD[path][1] += 1
        try:
            yield
        finally:
            _HELD[path][1] -= 1
        return
    fd = _acquire(path, folder)
    _HELD[path] = [fd, 1]
    try:
        yield
    finally:
        del _HELD[path]
        with contextlib.suppress(OSError):
            os.unlink(path)
        os.close(fd)


def _acquire(path: Path, folder: Path) -> int:
    while True:
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as err:
            os.close(fd)
            if err.errno in (errno.EAGAIN, errno.EACCES):
                raise FolderBusyError(
                    f"{folder}: another rtrack process is writing this folder; wait for it or "
                    "choose another folder"
                ) from None
            raise
        try:
            same = os.fstat(fd).st_ino == os.stat(path).st_ino
        except FileNotFoundError:
            same = False
        if same:  # not unlinked by a releasing holder between our open and flock
            os.write(fd, f"{os.getpid()}\n".encode())
            return fd
        os.close(fd)


def stale_pattern(name: str) -> re.Pattern[str]:
    """Names of the staging folders ``write_run`` creates beside a folder called ``name``."""
    return re.compile(rf"^\.{re.escape(name)}\.[A-Za-z0-9_]{{8}}\.(partial|old)$")


def clean_stale(folder: Path) -> int:
    """Remove staging folders of killed writes of ``folder``; call with its lock held."""
    if not folder.parent.is_dir():
        return 0
    pattern = stale_pattern(folder.name)
    removed = 0
    for entry in folder.parent.iterdir():
        if pattern.match(entry.name) and entry.is_dir() and not entry.is_symlink():
            shutil.rmtree(entry, ignore_errors=True)
            removed += 1
    return removed


def merge_into(staging: Path, out: Path) -> None:
    """Move every file of ``staging`` into ``out``, replacing same-named files only."""
    for rel in files_of(staging):
        target = out / rel
        target.parent.mkdir(parents=True, exist_ok=True)
        os.replace(staging / rel, target)
    shutil.rmtree(staging, ignore_errors=True)


def write_text_atomic(path: Path, text: str) -> Path:
    """Write ``path`` whole or not at all (a hidden temporary file renamed into place)."""
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(text)
    os.replace(tmp, path)
    return path
