"""Refactors change no result: run tables equal, bit for bit, those recorded before them.

The fingerprints in ``tests/data/golden_tables.json`` were written by
``python tools/table_hashes.py --write`` on the commit before the planning package was split.
A change that is meant to alter results must re-record them and say why in its commit.
They are taken with OpenBLAS's kernels and NumPy's SIMD level pinned (``PINNED_ENV`` of the
tool), since those differ between CPUs and round differently.
"""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location("table_hashes", ROOT / "tools" / "table_hashes.py")
assert _spec is not None and _spec.loader is not None
table_hashes = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(table_hashes)

GOLDEN = json.loads(table_hashes.GOLDEN.read_text())


@pytest.fixture(scope="module")
def found() -> dict[str, dict[str, str]]:
    """Every run's fingerprints, from one process with the BLAS kernels pinned (the tool's
    ``PINNED_ENV``: this process loaded NumPy long ago)."""
    done = subprocess.run(
        [sys.executable, str(ROOT / "tools" / "table_hashes.py"), "--json"],
        env={**os.environ, **table_hashes.PINNED_ENV},
        capture_output=True,
        text=True,
        timeout=1200,
        check=False,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    return dict(json.loads(done.stdout.splitlines()[-1]))


@pytest.mark.parametrize("run", table_hashes.RUNS, ids=lambda r: f"{r[0]}/{r[1]}")
def test_tables_equal_recorded(run: tuple[str, str], found: dict[str, dict[str, str]]) -> None:
    key = f"{run[0]}/{run[1]}"
    assert found[key] == GOLDEN[key]
