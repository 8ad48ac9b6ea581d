"""Shared helpers: machine description, percentiles, tables, result files."""

from __future__ import annotations

import json
import os
import platform
import subprocess
import sys
from pathlib import Path
from typing import Any

import casadi
import numpy as np
import numpy.typing as npt

from resilient_tracking import builtin_scenarios
from resilient_tracking.experiments.catalog import SIX
from resilient_tracking.kernels import numeric_kernels

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
IMAGES = ROOT / "docs" / "images"
SCENARIOS = builtin_scenarios.folder()
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


def run_in_tree(source: str | None, module: str, function: str, *args: Any) -> Any:
    """``module.function(*args)`` (``args`` and its result JSON) in a fresh process whose
    ``resilient_tracking`` is imported from the source tree ``source`` (the folder holding
    it; ``None``: the installed one), the benchmarks from this checkout."""
    env = dict(os.environ)
    if source is not None:
        env["PYTHONPATH"] = str(Path(source).resolve())
    code = (
        f"import sys, json, importlib; sys.path.insert(1, {str(ROOT)!r}); "
        f"f = getattr(importlib.import_module({module!r}), {function!r}); "
        "print(json.dumps(f(*json.loads(sys.argv[1]))))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code, json.dumps(args)],
        env=env,
        check=True,
        capture_output=True,
        text=True,
    )
    return json.loads(out.stdout.strip().splitlines()[-1])
