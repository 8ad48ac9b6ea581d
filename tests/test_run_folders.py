"""Run folders (docs/reliability.md §8): checksums, the folder lock, stale staging folders,
and never deleting what this tool did not write."""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest

from resilient_tracking.runs import folders
from resilient_tracking.runs.records import EpisodeResult, write_run
from resilient_tracking.runs.schema import ALL_TABLES, TABLES


def declared_table(name: str, rows: int) -> pd.DataFrame:
    """``rows`` rows of every declared column of table ``name`` (zeros, ``False``, ``"x"``)."""
    fill = {"int64": 0, "float64": 0.5, "bool": False, "str": "x"}
    table = TABLES[name]
    return pd.DataFrame({c.name: [fill[c.dtype]] * rows for c in table.columns})


def tiny_result(rows: int = 3) -> EpisodeResult:
    tables = {name: declared_table(name, rows) for name in ALL_TABLES}
    return EpisodeResult(tables, {"policy": "vanilla", "seed": 42})


def test_the_manifest_records_a_checksum_of_every_table_and_of_itself(tmp_path):
    out = write_run(tiny_result(), tmp_path / "run")
    manifest = json.loads((out / "manifest.json").read_text())
    assert sorted(manifest["files"]) == sorted(f"{t}.parquet" for t in ALL_TABLES)
    for name, digest in manifest["files"].items():
        assert folders.sha256_of(out / name) == digest
    assert manifest["manifest_sha256"] == folders.manifest_digest(manifest)
    assert folders.verify(out) is None


def test_a_truncated_table_is_detected(tmp_path):
    out = write_run(tiny_result(), tmp_path / "run")
    team = out / "team.parquet"
    team.write_bytes(team.read_bytes()[:100])
    assert folders.verify(out) == f"{team}: damaged (checksum does not match the manifest)"


def test_an_edited_manifest_is_detected(tmp_path):
    out = write_run(tiny_result(), tmp_path / "run")
    path = out / "manifest.json"
    path.write_text(path.read_text().replace('"seed": 42', '"seed": 7'))
    assert "edited after the run" in str(folders.verify(out))


def test_a_broken_manifest_is_named(tmp_path):
    out = write_run(tiny_result(), tmp_path / "run")
    (out / "manifest.json").write_text('{"seed": "\x01"}')
    reason = folders.verify(out)
    assert reason is not None and reason.startswith(f"{out / 'manifest.json'}: not valid JSON")


def test_a_folder_of_someone_else_is_refused_and_kept(tmp_path):
    out = tmp_path / "work"
    out.mkdir()
    (out / "thesis.tex").write_text("keep")
    with pytest.raises(FileExistsError, match=r"thesis\.tex.*--overwrite"):
        write_run(tiny_result(), out)
    assert [p.name for p in out.iterdir()] == ["thesis.tex"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["work"]


def test_overwrite_writes_beside_the_users_files_and_keeps_them(tmp_path):
    out = tmp_path / "work"
    (out / "sub").mkdir(parents=True)
    (out / "thesis.tex").write_text("keep")
    (out / "sub" / "data.csv").write_text("1")
    write_run(tiny_result(4), out, overwrite=True)
    assert (out / "thesis.tex").read_text() == "keep"
    assert (out / "sub" / "data.csv").read_text() == "1"
    assert len(pd.read_parquet(out / "team.parquet")) == 4
    assert folders.verify(out) is None
    # the run's files are ours now; the user's are still foreign
    assert folders.foreign_entries(out) == ["sub/", "thesis.tex"]


def test_a_folder_of_only_our_files_is_replaced_whole(tmp_path):
    out = write_run(tiny_result(3), tmp_path / "run")
    (out / "figures").mkdir()
    (out / "figures" / "animation.gif").write_bytes(b"GIF89a")  # written by rtrack animate
    write_run(tiny_result(5), out)
    assert not (out / "figures").exists()
    assert len(pd.read_parquet(out / "team.parquet")) == 5


def test_a_file_not_a_folder_is_refused(tmp_path):
    out = tmp_path / "file"
    out.write_text("x")
    with pytest.raises(FileExistsError, match="not a folder"):
        write_run(tiny_result(), out)
    assert out.read_text() == "x"


@pytest.mark.parametrize("run_there_first", [False, True])
def test_the_current_folder_is_refused_before_the_episode_leaving_nothing(
    tmp_path, monkeypatch, capsys, run_there_first
):
    from resilient_tracking.cli import main

    here = tmp_path / "here"
    here.mkdir()
    if run_there_first:
        write_run(tiny_result(), here)
    before = sorted(p.name for p in tmp_path.rglob("*"))
    monkeypatch.chdir(here)
    for out in (".", "..", str(here)):
        code = main(["run", "sensing-temp", "--steps", "3", "--out", out, "-q", "--overwrite"])
        err = capsys.readouterr().err
        assert code == 1 and err.count("\n") == 1 and "is the current folder" in err, err
        code = main(["node", "sensing-temp", "--out", out])  # refused before the node runs
        err = capsys.readouterr().err
        assert code == 1 and err.count("\n") == 1 and err.startswith("error: --out:"), err
    assert sorted(p.name for p in tmp_path.rglob("*")) == before
    with pytest.raises(FileExistsError, match="current folder"):
        write_run(tiny_result(), Path("."))


def test_stale_staging_folders_of_killed_writes_are_removed_and_nothing_else(tmp_path):
    stale = tmp_path / ".run.abcd1234.partial"
    stale.mkdir()
    (stale / "team.parquet").write_bytes(b"half")
    old = tmp_path / ".run.abcd1234.old"
    old.mkdir()
    users = [tmp_path / ".run.mine", tmp_path / ".other.abcd1234.partial", tmp_path / "run.partial"]
    for path in users:
        path.mkdir()
    write_run(tiny_result(), tmp_path / "run")
    assert not stale.exists() and not old.exists()
    assert all(p.exists() for p in users)


def test_a_folder_locked_by_another_process_is_refused(tmp_path):
    out = tmp_path / "run"
    holder = subprocess.Popen(
        [
            sys.executable,
            "-c",
            "import sys, time; from resilient_tracking.runs.folders import folder_lock\n"
            f"with folder_lock({str(out)!r}):\n"
            "    print('held', flush=True); time.sleep(60)\n",
        ],
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert holder.stdout is not None and holder.stdout.readline().strip() == "held"
        with pytest.raises(folders.FolderBusyError, match="another rtrack process"):
            write_run(tiny_result(), out)
        assert not out.exists()
    finally:
        holder.kill()
        holder.wait(10)
    # the kernel released the dead holder's lock: the next write goes through
    deadline = time.monotonic() + 10
    write_run(tiny_result(), out)
    assert time.monotonic() < deadline and folders.verify(out) is None
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]  # the lock file is gone


def test_the_lock_is_reentrant_within_a_process(tmp_path):
    out = tmp_path / "run"
    with folders.folder_lock(out):
        write_run(tiny_result(), out)
    assert not Path(tmp_path / ".run.lock").exists()


def test_folder_names_from_labels_are_portable():
    assert folders.folder_name("ours-risky") == "ours-risky"
    assert folders.folder_name("pkg.module:Class") == "pkg.module_Class"
    assert folders.folder_name("a/b\\c d") == "a_b_c_d"
    assert folders.folder_name("") == "_"
