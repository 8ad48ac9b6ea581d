"""Run many episodes and store each as it finishes; resume where an interrupted sweep stopped.

A run lives in ``OUT/runs/<experiment>/<variant>/seed-NNN/``. It is written into a hidden
staging folder beside its final place and renamed when complete (``runs.records.write_run``),
so a run folder is either whole or absent, whatever kills the process. A run is skipped when
its folder exists and its manifest carries the task's fingerprint (scenario, policy, seed and the
package's code: a run stored by other code is run again) and
the record that it ran to completion without an interrupt (``"interrupted": false``); a stale
one, or one without that record, is run again, and so is one during which the compiled code
failed (its manifest's ``compiled_code.failures``, docs/reliability.md §11).

Ctrl-C or SIGTERM stops the sweep (``KeyboardInterrupt``/``interrupts.Terminated``); a run
during which one came is never stored: the solver ladder raises an interrupt again rather than
counting it as a failed solve, and the sweep checks for one before storing each run.

Episodes run in worker processes (joblib locally, or Dask workers given a scheduler address);
only the parent process writes, so workers need no shared file system. A run that raises (a
plug-in's bug, a number that is not finite) is stored nowhere and the sweep goes on; once every
other run is stored, :class:`SweepError` lists each failed run on one line.
"""

from __future__ import annotations

import logging
import os
import shutil
import signal
import threading
import time
import traceback
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

from resilient_tracking import interrupts
from resilient_tracking.experiments.catalog import Task
from resilient_tracking.planning import codegen, codegen_status
from resilient_tracking.runs import folders
from resilient_tracking.runs.manifest import code_digest, compiled_code_failed
from resilient_tracking.runs.records import EpisodeResult, write_run
from resilient_tracking.sim.episode import run_episode

log = logging.getLogger(__name__)

#: Names of the hidden folders ``write_run`` stages a run in (left behind only by a kill).
PARTIAL = (".*.partial", ".*.old")


def run_dir(out: Path, task: Task) -> Path:
    """The folder a task's run is stored in: ``out/runs/<experiment>/<variant>/seed-NNN``."""
    return Path(out) / "runs" / task.run_id


def is_done(out: Path, task: Task) -> bool:
    """Whether ``task``'s run is stored intact: its manifest carries the task's fingerprint, the
    record that the run finished without an interrupt, and its own checksum, and every table its
    recorded checksum. A damaged or edited stored run is not done (a warning names the file);
    it is run again, as is one without the record (stored by an older version) and one during
    which the compiled code failed (docs/reliability.md §11)."""
    folder = run_dir(out, task)
    if not (folder / "manifest.json").exists():
        return False
    damage = folders.verify(folder)
    if damage is None:
        try:
            manifest = folders.read_manifest(folder)
        except (OSError, ValueError) as err:  # pragma: no cover - verify read it just now
            damage = str(err)
        else:
            if manifest.get("fingerprint") != task.fingerprint:
                return False
            if compiled_code_failed(manifest):
                log.info("%s: its compiled code failed during the run; running it again", folder)
                return False
            if manifest.get("interrupted") is False:
                return True
            log.info("%s: no record that it finished uninterrupted; running it again", folder)
            return False
    if damage is not None:
        log.warning("%s; running that stored run again", damage)
    return False


@dataclass(frozen=True)
class RunFailure:
    """A run that raised: ``message`` says what on one line, ``details`` holds the traceback."""

    run_id: str
    message: str
    details: str = ""


class SweepError(RuntimeError):
    """Runs of a sweep failed; every other run is stored. ``failures`` has one per failed run."""

    def __init__(self, failures: Sequence[RunFailure], total: int):
        self.failures = list(failures)
        super().__init__(f"{len(self.failures)} of {total} run(s) failed; none of them is stored")


def run_task(task: Task) -> tuple[str, EpisodeResult | RunFailure]:
    """Run one task (in a worker); the result carries the sweep's labels in its manifest, and
    the record that it ran to completion without an interrupt (``interrupted``: an interrupt
    raises instead of returning). A run that raises comes back as a :class:`RunFailure` naming
    the policy, never as the exception, so one failed run stops neither the others nor the
    worker pool."""
    try:
        result = run_episode(
            task.scenario, policy=task.variant.policy, seed=task.seed, bound=task.bound
        )
    except Exception as err:
        interrupts.check()  # Ctrl-C swallowed by a library stays an interrupt
        message = f"{task.run_id}: policy {task.variant.policy}: {type(err).__name__}: {err}"
        return task.run_id, RunFailure(task.run_id, message, traceback.format_exc())
    interrupts.check()  # one a library swallowed: this run is not the uninterrupted one
    result.manifest.update(
        experiment=task.experiment,
        variant=task.variant.label,
        tags=dict(task.variant.tags),
        interrupted=False,
    )
    return task.run_id, result


def store(out: Path, task: Task, result: EpisodeResult) -> Path:
    """Write a finished run; ``write_run`` stages it and renames it into place, replacing a
    stale run of the same id (beside any file someone else put in its folder, kept).

    The fingerprint stored is this process's (:attr:`Task.fingerprint`), which a later sweep in
    it compares with; a worker that ran other code than this process is warned of.

    Raises the interrupt instead if Ctrl-C or SIGTERM came (the run may have met it), and
    ``ValueError`` for a result without the record that it finished uninterrupted."""
    interrupts.check()
    if result.manifest.get("interrupted") is not False:
        raise ValueError(f"{task.run_id}: not recorded as finished uninterrupted; not stored")
    if result.manifest.get("code", code_digest()) != code_digest():
        log.warning("%s: the worker ran other code than this process", task.run_id)
    result.manifest["fingerprint"] = task.fingerprint
    return write_run(result, run_dir(out, task), overwrite=True)


def clean_partial(out: Path) -> int:
    """Remove staging folders left by a killed sweep; returns how many. Called with the
    sweep's lock held, so a run folder's ``.NAME.lock`` left by a killed write is stale too
    and is removed."""
    runs = Path(out) / "runs"
    if not runs.exists():
        return 0
    leftovers = [p for pattern in PARTIAL for p in runs.glob(f"*/*/{pattern}") if p.is_dir()]
    for p in leftovers:
        shutil.rmtree(p, ignore_errors=True)
    for lock in runs.glob("*/*/.*.lock"):
        if lock.is_file():
            lock.unlink(missing_ok=True)
    return len(leftovers)


def _worker_setup(parent: int) -> None:
    """In a joblib worker, once: leave Ctrl-C to the parent (a terminal sends it to the
    workers too; the parent stops them), and exit as soon as ``parent`` is gone.

    joblib's workers would otherwise finish their episode (and keep their memory) after the
    sweep was killed. A daemon thread polls the parent id twice a second; on its death the
    worker stops its compile jobs and exits at once. (Done in the first task rather than as
    an executor initializer, so the worker pool stays the one plain ``joblib.Parallel`` uses.)
    """
    global _SET_UP
    if _SET_UP or os.getpid() == parent:
        return
    _SET_UP = True
    signal.signal(signal.SIGINT, signal.SIG_IGN)

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(0.5)
        from resilient_tracking.planning import compile_jobs

        compile_jobs.stop_all()
        os._exit(1)

    threading.Thread(target=watch, name="watch-parent", daemon=True).start()


_SET_UP = False


def run_task_in_worker(
    task: Task, parent: int, codegen_off: str | None = None
) -> tuple[str, EpisodeResult | RunFailure]:
    """:func:`run_task` in a joblib worker of the process ``parent``; ``codegen_off``: why the
    parent turned compiled code off (it warned once; the worker follows it without a word)."""
    _worker_setup(parent)
    if codegen_off is not None and not codegen_status.checked():
        codegen_status.set_checked(codegen_off, quiet=True)
    return run_task(task)


def _joblib_results(
    todo: Sequence[Task], jobs: int
) -> Iterator[tuple[str, EpisodeResult | RunFailure]]:
    if jobs == 1:
        yield from map(run_task, todo)
        return
    from joblib import Parallel, delayed

    parallel = Parallel(n_jobs=jobs, return_as="generator_unordered")
    off = codegen_status.off_reason()
    with interrupts.deaf_children():  # the call starts the workers
        results = parallel(delayed(run_task_in_worker)(t, os.getpid(), off) for t in todo)
    yield from results


#: What ``--dask`` needs when ``dask.distributed`` cannot be imported.
DASK_MISSING = "--dask needs dask.distributed: pip install 'resilient-tracking[cluster]'"


def dask_problem() -> str | None:
    """Why a sweep cannot run on Dask here (:data:`DASK_MISSING`), else ``None``."""
    try:
        import dask.distributed  # noqa: F401
    except ImportError:
        return DASK_MISSING
    return None


def _dask_results(
    todo: Sequence[Task], address: str, jobs: int
) -> Iterator[tuple[str, EpisodeResult | RunFailure]]:
    try:
        from dask.distributed import Client, LocalCluster, as_completed
    except ImportError as err:  # pragma: no cover - the CLI checks first (dask_problem)
        raise RuntimeError(DASK_MISSING) from err
    cluster = (
        LocalCluster(n_workers=jobs, threads_per_worker=1, processes=True, dashboard_address=None)
        if address == "local"
        else None
    )
    client = Client(cluster if cluster is not None else address)
    try:
        futures = client.map(run_task, list(todo), pure=False)
        for future in as_completed(futures):
            yield future.result()
            future.release()
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def run_sweep(
    tasks: Sequence[Task],
    out: str | Path,
    jobs: int = 1,
    dask: str | None = None,
    on_done: Callable[[Task, bool], object] | None = None,
) -> list[Task]:
    """Run every task not already stored under ``out``; returns the tasks that ran.

    ``on_done(task, ran)`` is called once per task: at once for skipped ones (``ran=False``),
    then as each run is stored or fails. Raises :class:`SweepError` after the last run when
    any run failed.
    """
    out = Path(out)
    with folders.folder_lock(out):
        return _run_sweep_locked(tasks, out, jobs, dask, on_done)


def _run_sweep_locked(
    tasks: Sequence[Task],
    out: Path,
    jobs: int,
    dask: str | None,
    on_done: Callable[[Task, bool], object] | None,
) -> list[Task]:
    removed = clean_partial(out)
    if removed:
        log.info("removed %d partial run folder(s) of an interrupted sweep", removed)
    by_id = {t.run_id: t for t in tasks}
    if len(by_id) != len(tasks):
        raise ValueError("two tasks share a run id")
    todo = [t for t in tasks if not is_done(out, t)]
    pending = {t.run_id for t in todo}
    for t in tasks:
        if on_done is not None and t.run_id not in pending:
            on_done(t, False)
    log.info("%d run(s) to do, %d already stored", len(todo), len(tasks) - len(todo))
    if todo:
        codegen.prepare()  # a cache that cannot be used: one warning here, not one per worker
    results = _dask_results(todo, dask, jobs) if dask else _joblib_results(todo, jobs)
    failures: list[RunFailure] = []
    for run_id, result in results:
        task = by_id[run_id]
        if isinstance(result, RunFailure):
            log.debug("%s failed:\n%s", run_id, result.details)
            failures.append(result)
        else:
            store(out, task, result)
        if on_done is not None:
            on_done(task, True)
    interrupts.check()  # one a library swallowed after the last run: the sweep did not finish
    if failures:
        raise SweepError(failures, len(todo))
    return todo
