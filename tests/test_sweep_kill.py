"""An interrupted sweep loses nothing it finished and ends equal to an uninterrupted one.

`rtrack reproduce` is killed with SIGKILL at random moments, then re-run to completion; no
run folder may ever be half-written, and the final tables must equal those of a sweep that
was never interrupted.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from resilient_tracking.runs.schema import REPRODUCIBLE

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parent.parent
SWEEP = ["reproduce", "sensing-temp", "comm-temp", "--quick", "--jobs", "2", "-q"]


def reproduce(out: Path) -> subprocess.Popen[bytes]:
    return subprocess.Popen(
        [sys.executable, "-m", "resilient_tracking.cli", *SWEEP, "--out", str(out)],
        cwd=ROOT,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        start_new_session=True,  # so the kill reaches joblib's workers too
    )


def stored_runs(out: Path) -> dict[str, Path]:
    return {
        str(m.parent.relative_to(out)): m.parent for m in (out / "runs").glob("*/*/*/manifest.json")
    }


def assert_whole(run: Path) -> None:
    """A stored run folder has every table, each readable."""
    for name in REPRODUCIBLE:
        pd.read_parquet(run / f"{name}.parquet")


def test_sigkill_at_random_moments_then_resume_equals_an_uninterrupted_sweep(tmp_path):
    rng = np.random.default_rng(7)
    killed = tmp_path / "killed"
    seen_counts = []
    for delay in rng.uniform(2.0, 12.0, size=3):
        proc = reproduce(killed)
        time.sleep(delay)
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
        runs = stored_runs(killed)
        for run in runs.values():
            assert_whole(run)
        seen_counts.append(len(runs))
    assert seen_counts == sorted(seen_counts)  # nothing finished is ever lost
    proc = reproduce(killed)
    assert proc.wait(timeout=600) == 0, proc.stderr.read().decode() if proc.stderr else ""
    assert not list((killed / "runs").glob("*/*/.*"))  # no staging folder left

    clean = tmp_path / "clean"
    assert reproduce(clean).wait(timeout=600) == 0
    a, b = stored_runs(killed), stored_runs(clean)
    assert sorted(a) == sorted(b) and len(a) == 8
    for run_id in a:
        for name in REPRODUCIBLE:
            pd.testing.assert_frame_equal(
                pd.read_parquet(a[run_id] / f"{name}.parquet"),
                pd.read_parquet(b[run_id] / f"{name}.parquet"),
            )
    assert (killed / "report.md").read_text().count("✅") == (
        clean / "report.md"
    ).read_text().count("✅")
