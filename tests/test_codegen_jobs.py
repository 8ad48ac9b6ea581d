"""Compile jobs are owned by the process (docs/reliability.md §9): stopped at exit or when the
process dies, their files under the cache directory, at most one per core, damaged cached
libraries rebuilt once, and the cache pruned least recently used first."""

from __future__ import annotations

import logging
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import casadi as ca
import pytest

from resilient_tracking.planning import codegen, compile_jobs, library_cache, library_index

pytestmark = pytest.mark.skipif(
    not codegen.enabled(), reason="needs a C compiler and RTRACK_CODEGEN on"
)

MARKER = "rtrack-test-fake-compiler"


@pytest.fixture
def cache(tmp_path, monkeypatch):
    folder = tmp_path / "cache"
    monkeypatch.setenv("RTRACK_CACHE_DIR", str(folder))
    yield folder
    compile_jobs.stop_all()


@pytest.fixture
def slow_compiler(tmp_path, monkeypatch):
    """A 'compiler' that never finishes and has a child of its own, like gcc's cc1."""
    script = tmp_path / "slowcc"
    script.write_text(f"#!/bin/sh\n# {MARKER}\nsleep 300 &\nwait\n")
    script.chmod(0o755)
    monkeypatch.setenv("CC", str(script))
    return script


def functions(seed: int = 0) -> dict[str, ca.Function]:
    x = ca.SX.sym("x", 3)
    return {"f": ca.Function("f", [x], [ca.sin(x) * (seed + 1) + ca.dot(x, x)])}


def processes_in(folder: Path) -> list[int]:
    """Processes whose command line mentions ``folder``."""
    found = []
    for name in os.listdir("/proc"):
        if name.isdigit():
            try:
                cmdline = Path(f"/proc/{name}/cmdline").read_bytes().replace(b"\0", b" ")
            except OSError:
                continue
            if str(folder).encode() in cmdline and int(name) != os.getpid():
                found.append(int(name))
    return found


def wait_until(condition, seconds: float = 10.0) -> bool:
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(0.1)
    return condition()


def test_a_compile_job_runs_under_the_cache_directory_and_stop_all_ends_it(
    cache, slow_compiler, tmp_path
):
    job = codegen.compile_functions(functions(), "t")
    assert job is not None and job.process is not None
    builds = list(cache.glob("build-*"))
    assert len(builds) == 1 and (builds[0] / "t.c").exists()
    assert wait_until(lambda: len(processes_in(builds[0])) >= 2)  # the compiler and its child
    assert wait_until(lambda: any("sleep" in _cmd(p) for p in _children_of_tree(job)))
    compile_jobs.stop_all()
    assert wait_until(lambda: not processes_in(builds[0]) and not builds[0].exists())
    assert not processes_in(slow_compiler)
    assert job.failed and not job.ready()


def _cmd(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode()
    except OSError:
        return ""


def _children_of_tree(job: compile_jobs.CompiledFunctions) -> list[int]:
    assert job.process is not None
    root, tree = job.process.pid, []
    for name in os.listdir("/proc"):
        if name.isdigit():
            try:
                stat = Path(f"/proc/{name}/stat").read_text()
            except OSError:
                continue
            ppid = int(stat.rsplit(")", 1)[1].split()[1])
            if ppid == root or ppid in tree:
                tree.append(int(name))
    return tree


def test_killing_the_process_mid_compile_leaves_no_compiler_and_no_folder(
    cache, slow_compiler, tmp_path
):
    script = textwrap.dedent(
        """
        import casadi as ca, time
        from resilient_tracking.planning import codegen
        x = ca.SX.sym("x", 2)
        job = codegen.compile_functions({"f": ca.Function("f", [x], [ca.sin(x)])}, "killed")
        print("started", flush=True)
        time.sleep(120)
        """
    )
    child = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True)
    try:
        assert child.stdout is not None and child.stdout.readline().strip() == "started"
        builds = list(cache.glob(f"build-{child.pid}-*"))
        assert len(builds) == 1
        assert wait_until(lambda: len(processes_in(builds[0])) >= 2)
        child.send_signal(signal.SIGKILL)
        child.wait(10)
        assert wait_until(lambda: not processes_in(builds[0]) and not builds[0].exists(), 5)
        assert not processes_in(slow_compiler)
    finally:
        child.kill()
        child.wait(10)


def test_compiles_never_outnumber_the_cores(cache, slow_compiler):
    cores = os.cpu_count() or 1
    jobs = [codegen.compile_functions(functions(seed), f"p{seed}") for seed in range(cores + 1)]
    assert all(job is not None for job in jobs)
    assert wait_until(lambda: len(processes_in(slow_compiler)) >= cores)
    time.sleep(1.0)  # the extra job waits for a slot
    compilers = [
        p
        for p in processes_in(slow_compiler)
        if "sleep" not in _cmd(p) and "compile_supervisor" not in _cmd(p)
    ]
    assert len(compilers) == cores
    compile_jobs.stop_all()
    assert wait_until(lambda: not processes_in(slow_compiler))
    assert not list(cache.glob("build-*"))


def test_a_damaged_cached_library_is_rebuilt_once_with_one_warning(cache, caplog):
    job = codegen.compile_functions(functions(), "dmg")
    assert job is not None and job.wait()
    library = job.library
    assert Path(f"{library}.sha256").read_text().strip() == library_cache.sha256_of(library)
    library.write_bytes(library.read_bytes()[:200])  # truncated
    with caplog.at_level(logging.WARNING, logger=codegen.__name__):
        again = codegen.compile_functions(functions(), "dmg")
        assert again is not None and again.wait()
    warnings = [r for r in caplog.records if r.levelno >= logging.WARNING]
    assert len(warnings) == 1 and "damaged" in warnings[0].getMessage()
    assert "\n" not in warnings[0].getMessage()
    assert float(again.load()["f"]([1, 2, 3])[0]) == pytest.approx(14 + 0.8414709848)
    # damaged again in the same process: no second rebuild, the virtual machine is used
    replace_with(library, b"junk")  # a new file: the loaded one stays mapped
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger=codegen.__name__):
        assert codegen.compile_functions(functions(), "dmg") is None
    assert len(caplog.records) == 1 and "again" in caplog.records[0].getMessage()
    assert not library.exists()


def replace_with(path: Path, data: bytes) -> None:
    spare = path.with_suffix(".spare")
    spare.write_bytes(data)
    os.replace(spare, path)


def test_a_cached_library_without_checksum_is_load_tested(cache):
    job = codegen.compile_functions(functions(), "old")
    assert job is not None and job.wait()
    Path(f"{job.library}.sha256").unlink()
    assert library_cache.damage_of(job.library, job.names) is None
    assert Path(f"{job.library}.sha256").exists()  # recorded now
    Path(f"{job.library}.sha256").unlink()
    replace_with(job.library, b"\x7fELF truncated")
    assert library_cache.damage_of(job.library, job.names) == "not an ELF library"


def test_a_truncated_library_without_checksum_is_rebuilt_not_loaded(cache, caplog):
    """Mapping a truncated library kills the process with SIGBUS: it must be found damaged
    from its ELF headers, at any length, and rebuilt with one warning."""
    job = codegen.compile_functions(functions(), "cut", key="cut")
    assert job is not None and job.wait()
    whole = job.library.read_bytes()
    Path(f"{job.library}.sha256").unlink()
    for length in (0, 10, 63, 64, 200, len(whole) // 2, len(whole) - 1):
        replace_with(job.library, whole[:length])
        assert library_cache.damage_of(job.library, job.names) is not None, length
    assert not Path(f"{job.library}.sha256").exists()
    codegen._REBUILT.discard(job.library.name)
    with caplog.at_level(logging.WARNING, logger=codegen.__name__):
        again = codegen.compile_functions(functions(), "cut", key="cut")
        assert again is not None and again.wait()
    warnings = [r.getMessage() for r in caplog.records if r.levelno >= logging.WARNING]
    assert len(warnings) == 1 and "truncated" in warnings[0], warnings
    assert again.library.read_bytes() == whole
    assert float(again.load()["f"]([1, 2, 3])[0]) == pytest.approx(14 + 0.8414709848)


def test_a_library_that_crashes_when_loaded_is_checked_in_a_child_process(cache, tmp_path):
    """A whole ELF library that kills whoever loads it (here its constructor raises SIGBUS) is
    found damaged without this process loading it."""
    source = tmp_path / "boom.c"
    source.write_text(
        "#include <signal.h>\n"
        "__attribute__((constructor)) static void boom(void) { raise(SIGBUS); }\n"
        "int boom_f(void) { return 1; }\n"
    )
    library = tmp_path / "boom.so"
    subprocess.run(
        [codegen.compiler(), "-shared", "-fPIC", "-o", str(library), str(source)], check=True
    )
    assert library_cache.elf_damage(library) is None
    damage = library_cache.damage_of(library, {"f": "boom_f"})
    assert damage == f"loading it kills a process (signal {int(signal.SIGBUS)})"
    assert not Path(f"{library}.sha256").exists()


def test_the_cache_is_pruned_least_recently_used_first(tmp_path):
    now = time.time()
    for age, name in enumerate(["newest", "middle", "oldest"]):
        path = tmp_path / f"{name}.so"
        path.write_bytes(b"x" * 1000)
        Path(f"{path}.sha256").write_text("0")
        os.utime(path, (now - 100 * age, now - 100 * age))
    removed = library_cache.prune_cache(tmp_path, keep=tmp_path / "oldest.so", limit=2000)
    assert removed == 1
    assert sorted(p.name for p in tmp_path.glob("*.so")) == ["newest.so", "oldest.so"]
    assert not (tmp_path / "middle.so.sha256").exists()


def test_folders_of_dead_jobs_are_removed_and_live_ones_kept(tmp_path):
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    (tmp_path / f"build-{dead.pid}-abc").mkdir()
    (tmp_path / f"build-{os.getpid()}-abc").mkdir()
    (tmp_path / "mine").mkdir()
    assert library_cache.clean_dead_builds(tmp_path) == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == [f"build-{os.getpid()}-abc", "mine"]


def test_a_keyed_library_is_found_through_the_index_without_generating_code(cache, monkeypatch):
    job = codegen.compile_functions(functions(), "idx", key="structure A")
    assert job is not None and job.wait()

    class NoCodegen:
        def __init__(self, *args, **kwargs):
            raise AssertionError("code generated although the index names the library")

    monkeypatch.setattr(codegen.ca, "CodeGenerator", NoCodegen)
    found = codegen.compile_functions(functions(), "idx", key="structure A")
    assert found is not None and found.library == job.library and found.ready()
    assert float(found.load()["f"]([1, 2, 3])[0]) == pytest.approx(14 + 0.8414709848)
    # another key, a damaged library, or other sources: the index is not trusted
    assert codegen.compile_functions(functions(), "idx", key="structure B") is None
    Path(f"{job.library}.sha256").write_text("0\n")
    assert codegen.compile_functions(functions(), "idx", key="structure A") is None
    Path(f"{job.library}.sha256").write_text(library_cache.sha256_of(job.library) + "\n")
    monkeypatch.setattr(library_index, "source_version", lambda: "edited sources")
    assert codegen.compile_functions(functions(), "idx", key="structure A") is None


def test_a_plug_in_module_is_keyed_by_its_own_source(tmp_path, monkeypatch):
    module = tmp_path / "my_sensor.py"
    module.write_text("class Sensor:\n    pass\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    import my_sensor

    before = library_index.module_digest(my_sensor.Sensor)
    module.write_text("class Sensor:\n    noise = 2\n")
    assert before is not None and library_index.module_digest(my_sensor.Sensor) != before
    assert library_index.module_digest(int) is None  # built in: no source, so no index


def test_the_supervisor_publishes_the_library_with_its_checksum_and_removes_its_folder(tmp_path):
    work, slots = tmp_path / "build-1-x", tmp_path / "slots"
    work.mkdir()
    slots.mkdir()
    library = tmp_path / "lib.so"
    command = ["sh", "-c", f"printf built > {work / 'out.so'}"]
    args = [str(os.getpid()), str(work), str(slots), "1", str(library), *command]
    module = "resilient_tracking.planning.compile_supervisor"
    done = subprocess.run([sys.executable, "-m", module, *args], timeout=60)
    assert done.returncode == 0
    assert library.read_bytes() == b"built" and not work.exists()
    assert Path(f"{library}.sha256").read_text().strip() == library_cache.sha256_of(library)
    work.mkdir()
    failed = subprocess.run([sys.executable, "-m", module, *args[:5], "false"], timeout=60)
    assert failed.returncode == 1 and not work.exists()
