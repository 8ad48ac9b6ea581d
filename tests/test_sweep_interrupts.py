"""Ctrl-C during a sweep (docs/reliability.md §10): an interrupt inside a solve stops the episode
instead of counting as a failed solve, a run during which one came is never stored, and a
stored run is reused only if it records that it finished uninterrupted."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from helpers import shipped
from resilient_tracking import interrupts
from resilient_tracking.experiments.catalog import Experiment, Variant, tasks
from resilient_tracking.experiments.sweep import is_done, run_dir, run_sweep
from resilient_tracking.runs import folders
from resilient_tracking.runs.schema import REPRODUCIBLE
from resilient_tracking.sim.episode import run_episode

ROOT = Path(__file__).resolve().parent.parent
TINY = Experiment(
    "tiny", "sensing-temp", (Variant("vanilla", "vanilla"),), seeds=2, description="short"
)


def tiny_tasks():
    return [replace(t, scenario=t.scenario.with_overrides(steps=6)) for t in tasks(TINY)]


class FailsOnce:
    """A fault hook raising ``error`` at the ``at``-th solver attempt."""

    def __init__(self, error: Exception, at: int = 3):
        self.error, self.at, self.calls = error, at, 0

    def __call__(self, rung, solution, stats):
        self.calls += 1
        if self.calls == self.at:
            raise self.error
        return solution, stats


def test_a_keyboard_interrupt_turned_into_a_solver_error_stops_the_episode():
    # CasADi reports a KeyboardInterrupt raised inside a solve as a RuntimeError naming it
    hook = FailsOnce(
        RuntimeError("Error in Function::call for 'solver' [Sqpmethod]:\n.../KeyboardInterrupt")
    )
    scenario = shipped("sensing-temp").with_overrides(steps=20)
    with pytest.raises(KeyboardInterrupt):
        run_episode(scenario, seed=1, fault_hook=hook)
    assert hook.calls == hook.at  # stopped at once, no further attempt of the ladder


def test_a_solver_error_after_a_received_signal_stops_the_episode(monkeypatch):
    monkeypatch.setattr(interrupts, "_RECEIVED", [signal.SIGTERM])
    hook = FailsOnce(RuntimeError("some solver failure"))
    scenario = shipped("sensing-temp").with_overrides(steps=20)
    with pytest.raises(interrupts.Terminated):
        run_episode(scenario, seed=1, fault_hook=hook)


def test_an_ordinary_solver_error_is_still_a_fallback():
    hook = FailsOnce(RuntimeError("some solver failure"))
    scenario = shipped("sensing-temp").with_overrides(steps=20)
    result = run_episode(scenario, seed=1, fault_hook=hook)
    events = result["events"]
    assert (events["event"] == "solver_fallback").any()


def test_a_sweep_stores_no_run_once_a_signal_came(monkeypatch, tmp_path):
    monkeypatch.setattr(interrupts, "_RECEIVED", [signal.SIGINT])
    with pytest.raises(KeyboardInterrupt):
        run_sweep(tiny_tasks(), tmp_path)
    assert not list((tmp_path / "runs").glob("*/*/*/manifest.json"))


def reseal(folder: Path, **changes) -> None:
    manifest = folders.read_manifest(folder)
    for key, value in changes.items():
        if value is None:
            manifest.pop(key, None)
        else:
            manifest[key] = value
    (folder / "manifest.json").write_text(json.dumps(folders.seal(manifest, folder)))


def test_a_stored_run_without_an_uninterrupted_record_is_redone(tmp_path):
    todo = tiny_tasks()
    run_sweep(todo, tmp_path)
    assert all(folders.read_manifest(run_dir(tmp_path, t))["interrupted"] is False for t in todo)
    reseal(run_dir(tmp_path, todo[0]), interrupted=None)  # as stored by an older version
    reseal(run_dir(tmp_path, todo[1]), interrupted=True)
    assert not is_done(tmp_path, todo[0]) and not is_done(tmp_path, todo[1])
    assert [t.run_id for t in run_sweep(todo, tmp_path)] == [t.run_id for t in todo]
    assert all(is_done(tmp_path, t) for t in todo)


SWEEP = ("reproduce", "sensing-temp", "--seeds", "2", "-q")


def sweep(out: Path, jobs: int) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, "-m", "resilient_tracking.cli", *SWEEP, "--jobs", str(jobs)]
        + ["--out", out.name],
        cwd=out.parent,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,  # its own group: Ctrl-C as a terminal sends it, workers too
    )


def stored_runs(out: Path) -> dict[str, Path]:
    return {
        str(m.parent.relative_to(out)): m.parent for m in (out / "runs").glob("*/*/*/manifest.json")
    }


def wait_for(condition, seconds: float) -> bool:
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(0.05)
    return False


@pytest.mark.slow
def test_ctrl_c_at_varied_moments_exits_130_and_stores_only_uninterrupted_runs(tmp_path):
    clean = tmp_path / "clean"
    proc = sweep(clean, jobs=1)
    assert proc.wait(timeout=600) == 0, proc.stderr.read() if proc.stderr else ""
    expected = stored_runs(clean)
    assert len(expected) == 4

    rng = np.random.default_rng(3)
    compared = 0
    for k, delay in enumerate(rng.uniform(0.0, 6.0, size=6)):
        out = tmp_path / f"interrupted-{k}"
        proc = sweep(out, jobs=2 if k == 5 else 1)
        try:  # the lock is taken once the command runs (its handlers installed)
            assert wait_for(lambda out=out: (tmp_path / f".{out.name}.lock").exists(), 120)
            time.sleep(delay)
            os.killpg(proc.pid, signal.SIGINT)
            _, err = proc.communicate(timeout=120)
        finally:
            if proc.poll() is None:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.communicate(timeout=30)
        if proc.returncode == 0:
            continue  # the sweep ended before the signal
        assert proc.returncode == 130, err
        assert "Traceback" not in err and "KeyboardInterrupt" not in err, err
        for run_id, folder in stored_runs(out).items():
            assert folders.read_manifest(folder)["interrupted"] is False
            for name in REPRODUCIBLE:
                pd.testing.assert_frame_equal(
                    pd.read_parquet(folder / f"{name}.parquet"),
                    pd.read_parquet(expected[run_id] / f"{name}.parquet"),
                )
            compared += 1
    assert compared > 0  # some tries stored runs before the signal


def test_ctrl_c_after_the_command_finished_does_not_end_the_process_by_the_signal(tmp_path):
    # the interpreter's shutdown resets Python's SIGINT handler to the default action; a Ctrl-C
    # then would kill the finished command with no message (exit -2 instead of its own code)
    script = (
        "import os, signal, sys\n"
        "from resilient_tracking.cli import main\n"
        "code = main()\n"
        "os.kill(os.getpid(), signal.SIGINT)\n"
        "sys.exit(code)\n"
    )
    scenario = ROOT / "src" / "resilient_tracking" / "builtin_scenarios" / "sensing-temp.yaml"
    proc = subprocess.run(
        [sys.executable, "-c", script, "validate", str(scenario)],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    assert "KeyboardInterrupt" not in proc.stderr


#: A library that turns the Ctrl-C raised inside it into its own error, as Matplotlib's Agg
#: renderer does ("Invalid bounding box") when the signal lands while it converts arguments.
SWALLOWING_LIBRARY = """
import os, signal, sys, time
import resilient_tracking.cli as cli
import resilient_tracking.cli.single_run as single_run
import resilient_tracking.sim.episode as episode

def swallowing(*args, **kwargs):
    try:
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(5)
    except KeyboardInterrupt:
        raise ValueError("Invalid bounding box") from None
    return 0

single_run.cmd_validate = swallowing
episode.run_episode = swallowing
sys.exit(cli.main())
"""


@pytest.mark.parametrize("command", ["validate", "run"])
def test_ctrl_c_turned_into_a_library_error_exits_130_without_a_traceback(tmp_path, command):
    scenario = ROOT / "src" / "resilient_tracking" / "builtin_scenarios" / "sensing-temp.yaml"
    argv = [command, str(scenario)] + (["--out", str(tmp_path / "run")] if command == "run" else [])
    proc = subprocess.run(
        [sys.executable, "-c", SWALLOWING_LIBRARY, *argv],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 130, proc.stderr
    assert "Traceback" not in proc.stderr and "Invalid bounding box" not in proc.stderr
    assert "interrupted" in proc.stderr
