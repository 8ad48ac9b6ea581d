"""A plain (non-editable) install works from any directory: the wheel carries the scenarios.

Builds the wheel without build isolation, installs it with ``--no-deps`` into a fresh virtualenv
whose dependencies come from this environment (a ``.pth`` line, so nothing is downloaded), then
runs ``rtrack reproduce`` and ``rtrack compare`` from an empty temporary directory.
"""

from __future__ import annotations

import os
import site
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

pytestmark = pytest.mark.wheel


def _run(cmd: list[str], cwd: Path, env: dict[str, str] | None = None, timeout: float = 600):
    done = subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)
    assert done.returncode == 0, f"{cmd} failed:\n{done.stdout}\n{done.stderr}"
    return done


@pytest.fixture(scope="module")
def installed(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The ``bin`` folder of a fresh virtualenv holding only the built wheel."""
    base = tmp_path_factory.mktemp("wheel")
    dist = base / "dist"
    _run(
        [
            sys.executable,
            "-m",
            "pip",
            "wheel",
            "--no-deps",
            "--no-build-isolation",
            "-q",
            "-w",
            str(dist),
            str(ROOT),
        ],
        cwd=base,
    )
    (wheel,) = dist.glob("resilient_tracking-*.whl")
    with zipfile.ZipFile(wheel) as z:
        names = z.namelist()
    assert "resilient_tracking/scenarios/sensing-temp.yaml" in names
    venv = base / "venv"
    _run([sys.executable, "-m", "venv", str(venv)], cwd=base)
    bin_dir = venv / "bin"
    # Dependencies from this environment, but never this checkout's editable install (.pth
    # files are not processed in a folder added this way).
    (site_packages,) = (venv / "lib").glob("python*/site-packages")
    (site_packages / "_deps.pth").write_text("\n".join(site.getsitepackages()) + "\n")
    _run(
        [
            str(bin_dir / "python"),
            "-m",
            "pip",
            "install",
            "-q",
            "--no-deps",
            "--no-index",
            str(wheel),
        ],
        cwd=base,
    )
    return bin_dir


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
