"""Run manifests record the numeric kernels, which decide a table's last bits (model §9)."""

from __future__ import annotations

import json
import os
import platform
import shlex
import subprocess
import sys

import numpy as np
import pytest

from helpers import SCENARIOS
from resilient_tracking.cli import main
from resilient_tracking.experiments import report
from resilient_tracking.kernels import PINNED_ENV, numeric_kernels, pinned, pinned_prefix

QUERY = "from resilient_tracking.kernels import numeric_kernels as k; print(k()['blas_core'])"


def test_the_kernels_are_named():
    kernels = numeric_kernels()
    assert kernels["blas"] != "unknown"
    if str(kernels["blas"]).startswith("openblas"):  # NumPy's wheels; it names its kernels
        assert kernels["blas_core"] != "unknown"
    assert isinstance(kernels["simd"], list)


@pytest.mark.skipif(platform.machine() != "x86_64", reason="x86-64 OpenBLAS core names")
def test_the_recorded_core_is_the_one_running():
    """Forcing OpenBLAS's kernels before NumPy loads shows in what is recorded."""
    env = {**os.environ, "OPENBLAS_CORETYPE": "Sandybridge"}
    done = subprocess.run(
        [sys.executable, "-c", QUERY], env=env, capture_output=True, text=True, timeout=60
    )
    assert done.stdout.strip() == "Sandybridge", done.stderr


def test_a_run_manifest_records_the_kernels(tmp_path):
    out = tmp_path / "run"
    args = ["run", str(SCENARIOS / "sensing-temp.yaml"), "--steps", "3", "--out", str(out)]
    assert main([*args, "--no-figures", "-q"]) == 0
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["kernels"] == json.loads(json.dumps(numeric_kernels()))


def test_the_pinned_prefix_names_the_pin_only_when_this_process_has_it(monkeypatch):
    for key in PINNED_ENV:
        monkeypatch.delenv(key, raising=False)
    assert not pinned() and pinned_prefix() == ""
    monkeypatch.setenv("OPENBLAS_CORETYPE", "Haswell")  # half the pin is not the pin
    assert pinned_prefix() == ""
    for key, value in PINNED_ENV.items():
        monkeypatch.setenv(key, value)
    assert pinned()
    # the prefix runs a command the same way when pasted into a shell
    assert shlex.split(pinned_prefix() + "rtrack") == [
        *(f"{key}={value}" for key, value in PINNED_ENV.items()),
        "rtrack",
    ]


def test_the_report_names_the_numeric_stack_it_was_made_with():
    stack = report._numeric_stack()
    assert stack.startswith(f"NumPy {np.__version__} (")
    assert f"{numeric_kernels()['blas_core']} kernels" in stack
