"""The manifest of a run folder: what ran, with which versions, how long it took."""

from __future__ import annotations

import functools
import hashlib
import platform
from pathlib import Path
from typing import Any

import casadi
import numpy as np

from resilient_tracking.kernels import numeric_kernels
from resilient_tracking.scenario import Scenario
from resilient_tracking.version import __version__


def episode_manifest(
    scenario: Scenario,
    seed: int,
    policy_name: str,
    steps: int,
    wall: float,
    compiled_code: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """The manifest fields of one episode (``manifest.json`` adds the files' checksums).

    ``compiled_code``: ``{"on": whether compiled code was on as the episode started (a
    planner's ``codegen`` option may still keep it off), "failures": what failed of the
    compiled path during it}`` (docs/reliability.md §11); a sweep never reuses a run with
    failures (:func:`compiled_code_failed`)."""
    return {
        "scenario": scenario.model_dump(mode="json"),
        "seed": seed,
        "policy": policy_name,
        "version": __version__,
        "code": code_digest(),
        "casadi": casadi.CasadiMeta.version(),
        "numpy": np.__version__,
        "kernels": numeric_kernels(),
        "python": platform.python_version(),
        "steps": steps,
        "wall_time_s": round(wall, 3),
        **({} if compiled_code is None else {"compiled_code": compiled_code}),
    }


def compiled_code_failed(manifest: dict[str, Any]) -> bool:
    """Whether a run's manifest records a failure of the compiled path during the run."""
    record = manifest.get("compiled_code")
    return isinstance(record, dict) and bool(record.get("failures"))


def source_digest(root: Path) -> str:
    """SHA-256 (its first 16 hex digits) of the Python sources under ``root``, by relative path
    and content."""
    digest = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        digest.update(path.relative_to(root).as_posix().encode() + b"\0")
        digest.update(path.read_bytes() + b"\0")
    return digest.hexdigest()[:16]


@functools.cache
def code_digest() -> str:
    """:func:`source_digest` of this package, once per process: a stored run made by other code
    is another run, even with the same scenario, policy and seed (its package version may not
    have changed)."""
    return source_digest(Path(__file__).resolve().parents[1])
