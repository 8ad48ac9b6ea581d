"""The compiled-code cache cannot change results (docs/reliability.md §11): a cache that cannot be
used is found before the run, with one warning, and the run equals one with ``RTRACK_CODEGEN=0``
bit for bit; a setting not allowed is refused in one line; a run during which the compiled
path failed keeps its results, is marked in its manifest and is redone by a later sweep."""

from __future__ import annotations

import json
import logging
import os
import pwd
import re
from pathlib import Path

import pandas as pd
import pytest

from helpers import shipped
from resilient_tracking.cli.entry import main
from resilient_tracking.experiments.sweep import is_done, run_dir, run_sweep, run_task_in_worker
from resilient_tracking.planning import (
    codegen,
    codegen_status,
    compile_jobs,
    library_cache,
    nlp_cache,
)
from resilient_tracking.planning.cache import LruCache
from resilient_tracking.runs import folders
from resilient_tracking.runs.schema import REPRODUCIBLE
from resilient_tracking.sim.episode import run_episode
from test_stored_runs import tiny_tasks

STEPS = 25


@pytest.fixture
def fresh(tmp_path, monkeypatch):
    """A process as at its start: no symbolic problem (so no compile job) shared yet, nothing
    known of the cache, its own cache folder; compile jobs stopped after."""
    monkeypatch.setattr(nlp_cache, "_NLPS", LruCache(nlp_cache.NLP_BUDGET, weigh=lambda n: 1.0))
    monkeypatch.setattr(codegen_status, "_OFF", {})
    monkeypatch.setattr(codegen_status, "_FAILURES", [])
    for name in ("RTRACK_CODEGEN", "RTRACK_CACHE_MAX_MB", "XDG_CACHE_HOME"):
        monkeypatch.delenv(name, raising=False)
    cache = tmp_path / "cache"
    monkeypatch.setenv("RTRACK_CACHE_DIR", str(cache))
    yield cache
    compile_jobs.stop_all()


def episode(steps: int = STEPS, **env: str):
    """An episode of the shipped sensing-temp (with ``env`` set for its duration)."""
    with pytest.MonkeyPatch.context() as patch:
        for name, value in env.items():
            patch.setenv(name, value)
        return run_episode(shipped("sensing-temp").with_overrides(steps=steps))


def assert_same_tables(one, two):
    for table in REPRODUCIBLE:
        pd.testing.assert_frame_equal(one[table], two[table], check_exact=True)


def warnings_of(caplog) -> list[str]:
    return [r.getMessage() for r in caplog.records if r.levelno >= logging.WARNING]


def without_compiled_code(monkeypatch):
    """The run with compiled code switched off, as a person does it (``RTRACK_CODEGEN=0``)."""
    monkeypatch.setattr(codegen_status, "_FAILURES", [])
    return episode(RTRACK_CODEGEN="0")


def test_without_a_home_folder_the_run_equals_one_without_compiled_code(fresh, monkeypatch, caplog):
    """No HOME and a user with no entry in the password file: ``Path.home()`` raises."""
    monkeypatch.delenv("RTRACK_CACHE_DIR")
    monkeypatch.delenv("HOME", raising=False)

    def no_entry(uid):
        raise KeyError(f"getpwuid(): uid not found: {uid}")

    monkeypatch.setattr(pwd, "getpwuid", no_entry)
    with pytest.raises(RuntimeError):
        Path.home()
    with caplog.at_level(logging.WARNING):
        homeless = episode()
    warned = warnings_of(caplog)
    assert len(warned) == 1 and "home folder is unknown" in warned[0], warned
    assert "RTRACK_CACHE_DIR" in warned[0]
    assert homeless.manifest["compiled_code"] == {"on": False, "failures": []}
    events = homeless["events"]
    assert not (events["event"] == "solver_fallback").any()
    assert_same_tables(homeless, without_compiled_code(monkeypatch))


def _bad_index(cache: Path) -> None:
    for entry in (cache / "index").iterdir():
        entry.write_bytes(b"\xff\xfe not text")


def _libraries_are_folders(cache: Path) -> None:
    for entry in (cache / "index").iterdir():
        (cache / entry.read_text().strip()).mkdir()


@pytest.mark.skipif(not codegen.enabled(), reason="needs a C compiler and RTRACK_CODEGEN on")
@pytest.mark.parametrize(
    "damage, named",
    [(_bad_index, "not UTF-8 text"), (_libraries_are_folders, "not a file")],
    ids=["index-not-text", "library-a-folder"],
)
def test_an_unreadable_cache_entry_turns_compiled_code_off_before_the_run(
    fresh, monkeypatch, caplog, damage, named
):
    """The index entries of the problems this episode meets (written as their compile jobs
    start), made unreadable: found before the run, which equals one without compiled code."""
    episode(steps=1)
    compile_jobs.stop_all()
    assert list((fresh / "index").iterdir())
    damage(fresh)
    monkeypatch.setattr(codegen_status, "_OFF", {})  # a new process
    monkeypatch.setattr(codegen_status, "_FAILURES", [])
    monkeypatch.setattr(nlp_cache, "_NLPS", LruCache(nlp_cache.NLP_BUDGET, weigh=lambda n: 1.0))
    with caplog.at_level(logging.WARNING):
        damaged = episode()
    warned = warnings_of(caplog)
    assert len(warned) == 1 and named in warned[0] and str(fresh) in warned[0], warned
    assert damaged.manifest["compiled_code"] == {"on": False, "failures": []}
    assert_same_tables(damaged, without_compiled_code(monkeypatch))


@pytest.mark.parametrize(
    "make, named",
    [
        (
            lambda c: (c / "index").mkdir(parents=True) or (c / "index" / "e").write_bytes(b"\xff"),
            "not UTF-8 text",
        ),
        (lambda c: c.mkdir() or (c / "a.so.sha256").write_bytes(b"\xc3\x28"), "not UTF-8 text"),
        (lambda c: (c / "a.so").mkdir(parents=True), "not a file"),
        (lambda c: (c / "a.so.sha256").mkdir(parents=True), "not a file"),
        (lambda c: (c / "index").mkdir(parents=True) or (c / "index" / "e").mkdir(), "not a file"),
        (lambda c: c.mkdir() or (c / "slots").write_text("x"), "slots"),
        (lambda c: c.parent.mkdir(exist_ok=True) or c.write_text("x"), "cache folder"),
    ],
    ids=[
        "index-entry-not-text",
        "checksum-not-text",
        "library-a-folder",
        "checksum-a-folder",
        "index-entry-a-folder",
        "slots-a-file",
        "cache-a-file",
    ],
)
def test_a_cache_that_cannot_be_used_is_named(tmp_path, make, named):
    cache = tmp_path / "cache"
    make(cache)
    reason = library_cache.unusable(cache)
    assert reason is not None and named in reason and str(cache) in reason, reason
    assert "\n" not in reason


def test_a_usable_cache_passes_and_other_files_are_left_alone(tmp_path):
    cache = tmp_path / "cache"
    assert library_cache.unusable(cache) is None  # created
    (cache / "a.so").write_bytes(b"\x7fELF\xff")  # a damaged library: found when used
    (cache / "a.so.sha256").write_text("0\n")
    (cache / "notes").mkdir()
    (cache / "index" / ".e.123").write_bytes(b"\xff")  # an entry being written
    assert library_cache.unusable(cache) is None


@pytest.mark.parametrize(
    "name, value, allowed",
    [
        ("RTRACK_CACHE_MAX_MB", "nan", "from 0 to"),
        ("RTRACK_CACHE_MAX_MB", "inf", "from 0 to"),
        ("RTRACK_CACHE_MAX_MB", "1e400", "from 0 to"),
        ("RTRACK_CACHE_MAX_MB", "-1", "from 0 to"),
        ("RTRACK_CACHE_MAX_MB", "lots", "from 0 to"),
        ("RTRACK_CODEGEN", "maybe", "expected one of"),
        ("RTRACK_CACHE_DIR", "~/cache", "absolute path"),
    ],
)
def test_a_setting_not_allowed_is_refused_in_one_line_before_anything_runs(
    fresh, tmp_path, monkeypatch, capsys, name, value, allowed
):
    monkeypatch.setenv(name, value)
    out = tmp_path / "out"
    code = main(["run", "sensing-temp", "--steps", "2", "--out", str(out), "-q", "--no-figures"])
    err = capsys.readouterr().err
    assert code == 1
    assert err.count("\n") == 1 and err.startswith(f"error: {name}=") and allowed in err, err
    assert "Traceback" not in err and not out.exists()
    with pytest.raises(ValueError, match=name):  # a library call is refused too
        episode(steps=1)


def test_a_failure_of_the_compiled_path_during_a_run_keeps_its_results_and_marks_it(
    fresh, monkeypatch, caplog
):
    """The cache code raising once the run has started (a setting changed, a file replaced by
    another process): solvers stay on the virtual machine, one warning, the manifest says so."""

    def broken(*args, **kwargs):
        raise OSError(28, "No space left on device")

    codegen.prepare()  # before the run: the cache is usable
    monkeypatch.setattr(codegen, "compile_functions", broken)
    with caplog.at_level(logging.WARNING):
        failed = episode()
    warned = warnings_of(caplog)
    assert len(warned) == 1 and "No space left on device" in warned[0], warned
    assert not (failed["events"]["event"] == "solver_fallback").any()
    record = failed.manifest["compiled_code"]
    assert record["on"] is True and len(record["failures"]) == 1
    assert "No space left on device" in record["failures"][0]
    again = episode()  # off for the rest of the process, no failure of its own
    assert again.manifest["compiled_code"] == {"on": False, "failures": []}
    assert_same_tables(failed, without_compiled_code(monkeypatch))


def test_a_stored_run_whose_compiled_code_failed_is_run_again(tmp_path, caplog):
    todo = tiny_tasks()
    run_sweep(todo, tmp_path)
    folder = run_dir(tmp_path, todo[0])
    manifest = folders.read_manifest(folder)
    assert manifest["compiled_code"]["failures"] == []
    manifest["compiled_code"] = {"on": True, "failures": ["compiling x.so failed (exit 1)"]}
    (folder / "manifest.json").write_text(json.dumps(folders.seal(manifest, folder)))
    assert folders.verify(folder) is None  # intact: only its record of the failure counts
    assert not is_done(tmp_path, todo[0]) and is_done(tmp_path, todo[1])
    with caplog.at_level(logging.INFO):
        ran = run_sweep(todo, tmp_path)
    assert [t.run_id for t in ran] == [todo[0].run_id]
    assert any("compiled code failed" in r.getMessage() for r in caplog.records)
    assert folders.read_manifest(folder)["compiled_code"]["failures"] == []


def test_the_environment_check_reads_every_rtrack_variable_the_package_reads():
    """A new ``RTRACK_*`` variable must be checked in ``codegen_settings`` too."""
    package = Path(codegen.__file__).resolve().parents[1]
    read = {
        name
        for path in package.rglob("*.py")
        for name in re.findall(r"[\"'](RTRACK_[A-Z0-9_]+)[\"']", path.read_text())
    }
    settings = (package / "planning" / "codegen_settings.py").read_text()
    assert read == {"RTRACK_CODEGEN", "RTRACK_CACHE_DIR", "RTRACK_CACHE_MAX_MB"}, read
    assert all(f'"{name}"' in settings for name in read)


def test_a_compile_job_that_raises_when_it_finishes_leaves_the_solver_on_the_virtual_machine(
    fresh, caplog
):
    """Pruning the cache after a compile (``RTRACK_CACHE_MAX_MB`` changed during the run, say)
    raising as a solver is created: the solve goes on, on the virtual machine."""
    from helpers import inputs, structure_of
    from resilient_tracking.planning.league_problem import LeagueProblem

    class Finishing:
        library = fresh / "x.so"

        def ready(self):
            raise ValueError("RTRACK_CACHE_MAX_MB='nan': expected a number")

    codegen.prepare()
    q = inputs()
    problem = LeagueProblem(structure_of(q))
    key, _, _ = problem.compile_label("ipopt")
    problem.symbolic("ipopt").jobs[key] = Finishing()
    with caplog.at_level(logging.WARNING):
        solution, stats = problem.solve(q)
    assert stats["success"] and not problem.compiled("ipopt")
    assert len(warnings_of(caplog)) == 1 and not codegen.enabled()
    assert codegen_status.failures_since(0) == [
        "finishing x.so: ValueError: RTRACK_CACHE_MAX_MB='nan': expected a number"
    ]


def test_a_sweep_worker_follows_its_parent_without_a_warning_of_its_own(fresh, caplog):
    """The parent of a sweep found the cache unusable (and warned): its workers, handed the
    reason, run without compiled code and say nothing."""
    task = tiny_tasks()[0]
    with caplog.at_level(logging.WARNING):
        _, result = run_task_in_worker(task, os.getpid(), "cache folder /x: File exists")
    assert warnings_of(caplog) == []
    assert result.manifest["compiled_code"] == {"on": False, "failures": []}
