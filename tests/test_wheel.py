"""A plain (non-editable) install works from any directory: the wheel carries the scenarios and
the generalization suite.

The ``installed`` fixture (``conftest.py``) builds the wheel without build isolation and installs
it with ``--no-deps`` into a fresh virtualenv whose dependencies come from this environment (a
``.pth`` line, so nothing is downloaded); this runs ``rtrack reproduce`` and ``rtrack compare``
from an empty temporary directory.
"""

from __future__ import annotations

import os

import pytest

from helpers import run_checked as _run

pytestmark = [pytest.mark.wheel, pytest.mark.slow]


def test_wheel_runs_reproduce_and_compare_from_an_empty_directory(installed, tmp_path):
    empty = tmp_path / "empty"
    empty.mkdir()
    env = {**os.environ, "MPLBACKEND": "Agg", "PYTHONPATH": ""}
    where = _run(
        [str(installed / "python"), "-c", "import resilient_tracking as r; print(r.__file__)"],
        cwd=empty,
        env=env,
    ).stdout
    assert str(installed.parent) in where, f"imported from {where}, not from the wheel"
    suite_size = _run(
        [
            str(installed / "python"),
            "-c",
            "from resilient_tracking.experiments.generator import stored_suite as s; "
            "print(len(s()))",
        ],
        cwd=empty,
        env=env,
    ).stdout
    assert suite_size.strip() == "60"  # the generalization suite is package data
    rtrack = str(installed / "rtrack")
    _run(
        [rtrack, "reproduce", "sensing-temp", "--quick", "--out", "R", "--jobs", "2", "-q"],
        cwd=empty,
        env=env,
    )
    assert "claims hold" in (empty / "R" / "report.md").read_text()
    _run(
        [
            rtrack,
            "compare",
            "sensing-temp",
            "--policies",
            "failure_aware,vanilla",
            "--seeds",
            "2",
            "--out",
            "C",
            "--jobs",
            "2",
            "-q",
        ],
        cwd=empty,
        env=env,
    )
    assert "## sensing-temp" in (empty / "C" / "report.md").read_text()
