"""Refactors change no result: run tables equal, bit for bit, those recorded before them.

The fingerprints in ``tests/data/golden_tables.json`` were written by
``python -m resilient_tracking.sim.fingerprints --write`` (``tools/table_hashes.py --write``).
A change that is meant to alter results must re-record them and say why in its commit.
They are taken with OpenBLAS's kernels and NumPy's SIMD level pinned (``PINNED_ENV``), since
those differ between CPUs and round differently.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from resilient_tracking.kernels import PINNED_ENV
from resilient_tracking.sim import fingerprints

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[1]
GOLDEN = json.loads((ROOT / fingerprints.GOLDEN).read_text())


@pytest.fixture(scope="module")
def found() -> dict[str, dict[str, str]]:
    """Every run's fingerprints, from one process with the BLAS kernels pinned
    (``PINNED_ENV``: this process loaded NumPy long ago)."""
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            fingerprints.MODULE,
            "--json",
            "--golden",
            str(ROOT / fingerprints.GOLDEN),
        ],
        env={**os.environ, **PINNED_ENV},
        capture_output=True,
        text=True,
        timeout=1200,
        check=False,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    return dict(json.loads(done.stdout.splitlines()[-1]))


@pytest.mark.parametrize("run", fingerprints.RUNS, ids=lambda r: f"{r[0]}/{r[1]}")
def test_tables_equal_recorded(run: tuple[str, str], found: dict[str, dict[str, str]]) -> None:
    key = f"{run[0]}/{run[1]}"
    assert found[key] == GOLDEN[key]


def test_a_changed_table_changes_its_fingerprint() -> None:
    import pandas as pd

    table = pd.DataFrame({"step": [0, 1], "x": [0.5, 1.5]})
    same = fingerprints.table_hash(table.copy())
    assert fingerprints.table_hash(table) == same
    assert fingerprints.table_hash(table.assign(x=[0.5, 1.25])) != same
    assert fingerprints.table_hash(table.astype({"step": "int32"})) != same
