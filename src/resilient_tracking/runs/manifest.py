"""The manifest of a run folder: what ran, with which versions, how long it took."""

from __future__ import annotations

import platform
from typing import Any

import casadi
import numpy as np

from resilient_tracking import __version__
from resilient_tracking.scenario import Scenario
from resilient_tracking.sim.kernels import numeric_kernels


def episode_manifest(
    scenario: Scenario, seed: int, policy_name: str, steps: int, wall: float
) -> dict[str, Any]:
    """The manifest fields of one episode (``manifest.json`` adds the files' checksums)."""
    return {
        "scenario": scenario.model_dump(mode="json"),
        "seed": seed,
        "policy": policy_name,
        "version": __version__,
        "casadi": casadi.CasadiMeta.version(),
        "numpy": np.__version__,
        "kernels": numeric_kernels(),
        "python": platform.python_version(),
        "steps": steps,
        "wall_time_s": round(wall, 3),
    }
