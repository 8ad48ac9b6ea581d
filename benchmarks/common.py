"""Shared helpers: machine description, percentiles, tables, result files."""

from __future__ import annotations

import json
import os
import platform
from pathlib import Path
from typing import Any

import casadi
import numpy as np
import numpy.typing as npt

from resilient_tracking import scenarios
from resilient_tracking.experiments.catalog import SIX
from resilient_tracking.sim.kernels import numeric_kernels

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
IMAGES = ROOT / "docs" / "images"
SCENARIOS = scenarios.folder()
SHIPPED = SIX  # the paper's six scenarios


def machine() -> dict[str, Any]:
    """What the numbers were measured on."""
    cpu = platform.processor() or "unknown"
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    load = os.getloadavg() if hasattr(os, "getloadavg") else (float("nan"),) * 3
    return {
        "cpu": cpu,
        "cores": os.cpu_count(),
        "load_average_1m": round(load[0], 2),
        "python": platform.python_version(),
        "casadi": casadi.CasadiMeta.version(),
        "numpy": np.__version__,
        "kernels": numeric_kernels(),
        "platform": platform.platform(),
    }


def summary_ms(values_ms: npt.ArrayLike) -> dict[str, float]:
    v = np.asarray(values_ms, dtype=float)
    if not len(v):
        return {k: float("nan") for k in ("median", "p90", "p99", "max", "mean")}
    return {
        "median": float(np.median(v)),
        "p90": float(np.percentile(v, 90)),
        "p99": float(np.percentile(v, 99)),
        "max": float(v.max()),
        "mean": float(v.mean()),
    }


def table(rows: list[list[Any]], header: list[str]) -> str:
    """A Markdown table (also readable as plain text)."""

    def cell(x: Any) -> str:
        if isinstance(x, float):
            if not np.isfinite(x):
                return "–"
            return f"{x:.3g}" if abs(x) < 1000 else f"{x:.0f}"
        return str(x)

    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(cell(c) for c in row) + " |" for row in rows]
    return "\n".join(lines)


def save(name: str, data: dict[str, Any]) -> Path:
    RESULTS.mkdir(parents=True, exist_ok=True)
    path = RESULTS / f"{name}.json"
    path.write_text(json.dumps(data, indent=1, default=_plain) + "\n")
    return path


def _plain(value: Any) -> Any:
    """JSON for what ``json`` does not know: NumPy numbers and arrays, and classes (such as a
    structure's sensor model) by name."""
    if isinstance(value, type):
        return value.__name__
    if isinstance(value, np.ndarray):
        return value.tolist()
    return float(value)
