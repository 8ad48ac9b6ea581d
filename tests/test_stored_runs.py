"""Stored runs you can trust, and stopping cleanly (docs/reliability.md §8, §10): damaged or
edited stored runs are redone, workers die with their parent, Ctrl-C exits 130 keeping
finished runs."""

from __future__ import annotations

import json
import logging
import os
import signal
import subprocess
import sys
import time
from dataclasses import replace
from pathlib import Path

import pandas as pd
import pytest

from resilient_tracking.experiments.catalog import Experiment, Variant, tasks
from resilient_tracking.experiments.sweep import is_done, run_dir, run_sweep
from resilient_tracking.runs import folders
from resilient_tracking.runs.schema import REPRODUCIBLE, TABLES

ROOT = Path(__file__).resolve().parent.parent
TINY = Experiment(
    "tiny", "sensing-temp", (Variant("vanilla", "vanilla"),), seeds=2, description="short"
)


def tiny_tasks():
    return [replace(t, scenario=t.scenario.with_overrides(steps=6)) for t in tasks(TINY)]


def test_a_truncated_stored_table_is_redone_with_a_warning(tmp_path, caplog):
    todo = tiny_tasks()
    run_sweep(todo, tmp_path)
    team = run_dir(tmp_path, todo[0]) / "team.parquet"
    before = pd.read_parquet(team)
    team.write_bytes(team.read_bytes()[:50])
    with caplog.at_level(logging.WARNING):
        ran = run_sweep(todo, tmp_path)
    assert [t.run_id for t in ran] == [todo[0].run_id]
    assert any(
        str(team) in r.getMessage() and "running that stored run again" in r.getMessage()
        for r in caplog.records
    )
    pd.testing.assert_frame_equal(pd.read_parquet(team), before)


def test_a_stored_run_with_untyped_events_is_reported_old_and_redone(tmp_path, caplog):
    todo = tiny_tasks()
    run_sweep(todo, tmp_path)
    folder = run_dir(tmp_path, todo[0])
    events = folder / "events.parquet"
    old = pd.read_parquet(events)[["step", "robot", "event", "detail"]]
    old.to_parquet(events, index=False)  # as written before events had typed columns
    manifest = folders.seal(folders.read_manifest(folder), folder)
    (folder / "manifest.json").write_text(json.dumps(manifest))
    reason = folders.verify(folder)
    assert reason is not None and reason.startswith(f"{events}: an old run")
    assert "kind" in reason
    with caplog.at_level(logging.WARNING):
        ran = run_sweep(todo, tmp_path)
    assert [t.run_id for t in ran] == [todo[0].run_id]
    assert any("an old run" in r.getMessage() for r in caplog.records)
    assert set(TABLES["events"].names) <= set(pd.read_parquet(events).columns)
    assert folders.verify(folder) is None


def test_an_edited_stored_manifest_is_redone(tmp_path, caplog):
    todo = tiny_tasks()
    run_sweep(todo, tmp_path)
    manifest = run_dir(tmp_path, todo[1]) / "manifest.json"
    data = json.loads(manifest.read_text())
    data["seed"] = 42
    manifest.write_text(json.dumps(data))
    assert not is_done(tmp_path, todo[1]) and is_done(tmp_path, todo[0])
    assert [t.run_id for t in run_sweep(todo, tmp_path)] == [todo[1].run_id]
    assert json.loads(manifest.read_text())["seed"] == todo[1].seed


def rtrack(*argv: str, cwd: Path) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, "-m", "resilient_tracking.cli", *argv],
        cwd=cwd,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,  # its own group: signals as a terminal sends them
    )


def children_of(pid: int) -> set[int]:
    found = set()
    for name in os.listdir("/proc"):
        if name.isdigit():
            try:
                stat = Path(f"/proc/{name}/stat").read_text()
            except OSError:
                continue
            if int(stat.rsplit(")", 1)[1].split()[1]) == pid:
                found.add(int(name))
    return found


def alive(pid: int) -> bool:
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat.rsplit(")", 1)[1].split()[0] != "Z"


def wait_for(condition, seconds: float) -> bool:
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(0.2)
    return condition()


def finished_runs(out: Path) -> list[Path]:
    """Manifests of run folders renamed into place (a staging folder's name starts with a dot,
    which pathlib's ``*`` matches too)."""
    return list(out.glob("runs/*/*/seed-*/manifest.json"))


def stop_group(proc: subprocess.Popen[str]) -> None:
    if proc.poll() is None:
        os.killpg(proc.pid, signal.SIGKILL)
    proc.communicate(timeout=30)


@pytest.mark.slow
def test_ctrl_c_during_run_exits_130_without_traceback_or_leftovers(tmp_path):
    proc = rtrack("run", "sensing-temp", "--steps", "50000", "--out", "out", "-q", cwd=tmp_path)
    try:
        assert wait_for(lambda: (tmp_path / ".out.lock").exists(), 60)
        time.sleep(1.0)
        os.killpg(proc.pid, signal.SIGINT)
        _, err = proc.communicate(timeout=60)
    finally:
        stop_group(proc)
    assert proc.returncode == 130, err
    assert "interrupted" in err and "Traceback" not in err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
def test_ctrl_c_and_a_killed_parent_leave_no_worker_and_keep_finished_runs(tmp_path):
    argv = ("reproduce", "sensing-temp", "comm-temp", "--quick", "--jobs", "2", "-q")
    proc = rtrack(*argv, "--out", "res", cwd=tmp_path)
    try:
        assert wait_for(lambda: finished_runs(tmp_path / "res"), 120)
        workers = children_of(proc.pid)
        os.killpg(proc.pid, signal.SIGINT)
        _, err = proc.communicate(timeout=60)
        assert proc.returncode == 130, err
        assert "Traceback" not in err
        assert wait_for(lambda: not any(alive(w) for w in workers), 15)
    finally:
        stop_group(proc)
    stored = finished_runs(tmp_path / "res")
    assert stored
    for manifest in stored:
        for name in REPRODUCIBLE:
            pd.read_parquet(manifest.parent / f"{name}.parquet")

    # SIGKILL of the parent alone: its workers notice and exit
    proc = rtrack(*argv, "--out", "res2", cwd=tmp_path)
    try:
        assert wait_for(lambda: len(children_of(proc.pid)) >= 2, 60)
        time.sleep(2.0)  # the workers have started their episodes
        workers = children_of(proc.pid)
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(30)
        assert wait_for(lambda: not any(alive(w) for w in workers), 15)
    finally:
        stop_group(proc)


def test_lock_files_of_killed_run_writes_are_removed_by_the_next_sweep(tmp_path):
    todo = tiny_tasks()
    stale = run_dir(tmp_path, todo[0]).parent / f".{run_dir(tmp_path, todo[0]).name}.lock"
    stale.parent.mkdir(parents=True)
    stale.write_text("12345\n")  # left by a write killed with SIGKILL
    mine = stale.parent / "notes.lock.txt"
    mine.write_text("keep")
    run_sweep(todo, tmp_path)
    assert not stale.exists() and mine.exists()
    assert not list((tmp_path / "runs").glob("*/*/.*"))


def test_run_nees_tool_averages_each_variants_stored_runs(tmp_path, capsys):
    import importlib.util

    spec = importlib.util.spec_from_file_location("run_nees", ROOT / "tools" / "run_nees.py")
    assert spec is not None and spec.loader is not None
    tool = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(tool)

    todo = tiny_tasks()
    run_sweep(todo, tmp_path)
    variant = run_dir(tmp_path, todo[0]).parent
    expected = []
    for run in sorted(variant.glob("seed-*")):
        t = pd.read_parquet(run / "targets.parquet")
        expected.append(((t.x - t.est_x) ** 2 / t.var_x + (t.y - t.est_y) ** 2 / t.var_y).mean())
    assert tool.main([str(variant.parent), variant.name]) == 0
    row = [
        line
        for line in capsys.readouterr().out.splitlines()
        if line.startswith(f"| {variant.name} ")
    ]
    assert row == [row[0]] and f"| {sum(expected) / len(expected):.2f} |" in row[0]
    assert tool.main([str(variant.parent), "no-such-scenario"]) == 1
