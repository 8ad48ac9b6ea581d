"""Shared fixtures (helpers shared between test files are in ``helpers.py``)."""

from __future__ import annotations

import contextlib
import fcntl
import os
from collections.abc import Iterator
from pathlib import Path

import pytest
from hypothesis import HealthCheck, settings

from helpers import SCENARIOS

#: Hypothesis profiles for tests that do not fix their own number of examples (the hostile-input
#: properties): "ci" by default, "thorough" for the campaign in docs/reliability.md.
_SLOW_OK = [HealthCheck.too_slow, HealthCheck.data_too_large]
settings.register_profile("ci", max_examples=60, deadline=None, suppress_health_check=_SLOW_OK)
settings.register_profile(
    "thorough", max_examples=2000, deadline=None, suppress_health_check=_SLOW_OK
)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))


@pytest.fixture
def scenario_dir() -> Path:
    return SCENARIOS


@pytest.fixture(scope="session")
def installed(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The ``bin`` folder of a fresh virtualenv holding only the built wheel (built once per
    session; tests marked ``wheel`` use it)."""
    import site
    import sys
    import zipfile

    from helpers import run_checked

    root = Path(__file__).resolve().parents[1]
    base = tmp_path_factory.mktemp("wheel")
    dist = base / "dist"
    with _building_in(root):
        run_checked(
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
                str(root),
            ],
            cwd=base,
        )
    (wheel,) = dist.glob("resilient_tracking-*.whl")
    with zipfile.ZipFile(wheel) as z:
        names = z.namelist()
    assert "resilient_tracking/builtin_scenarios/sensing-temp.yaml" in names
    # compile jobs run this program by its file
    assert "resilient_tracking/planning/compile_supervisor.py" in names
    venv = base / "venv"
    run_checked([sys.executable, "-m", "venv", str(venv)], cwd=base)
    bin_dir = venv / "bin"
    # Dependencies from this environment, but never this checkout's editable install (.pth
    # files are not processed in a folder added this way).
    (site_packages,) = (venv / "lib").glob("python*/site-packages")
    (site_packages / "_deps.pth").write_text("\n".join(site.getsitepackages()) + "\n")
    run_checked(
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


@contextlib.contextmanager
def _building_in(root: Path) -> Iterator[None]:
    """Hold the checkout's build lock: setuptools builds in the source tree (``build/``,
    ``*.egg-info``), so test processes running side by side must not build at once."""
    lock = root / "build" / ".tests.lock"
    lock.parent.mkdir(exist_ok=True)
    with lock.open("w") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)
