"""Running a batch: jobs in worker processes on this machine, or on a Dask cluster.

`run_batch(plan, ...)` skips jobs whose files are all there (unless `force`), runs the others
in parallel, shows their progress, and returns a `BatchReport`; a failing job does not stop the
others. Worker processes start by `spawn`, never by forking a process with threads. Ctrl-C (or
SIGTERM, SIGHUP) stops running jobs within a simulated second and queued ones at once, and the
workers end quietly. Staged files that killed runs left are removed at the start and the end of
every batch.
"""

from __future__ import annotations

import multiprocessing
import os
import queue
import time
import uuid
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

from quadpipe.batch.jobs import (
    Job,
    JobResult,
    Outcome,
    WorkerLink,
    expand_jobs,
    remove_leftovers,
    run_job,
    skipped_result,
)
from quadpipe.batch.plan import BatchPlan
from quadpipe.batch.report import BatchReport, ProgressDisplay
from quadpipe.core.atomic import note_written
from quadpipe.core.errors import QuadpipeError
from quadpipe.core.limits import MAX_WORKERS
from quadpipe.core.signals import ignore_interrupts, signals_deferred

POLL_S = 0.1
"""Wall-clock seconds between two looks at the running jobs and their progress reports."""

CONNECT_TIMEOUT_S = 10.0
"""How long to try reaching a Dask scheduler before giving up."""


def run_batch(
    plan: BatchPlan,
    *,
    workers: int | None = None,
    force: bool = False,
    scheduler: str | None = None,
    progress: bool = True,
) -> BatchReport:
    """Run every job of a plan in parallel and report how each ended.

    Args:
        plan: what to bake.
        workers: worker processes on this machine (default: one per CPU core, at most one
            per job); ignored with `scheduler`.
        force: redo jobs whose files are all present (default: skip them).
        scheduler: address of a Dask distributed scheduler (`tcp://host:8786`): run the jobs
            on its workers, which must see the output folder and the config files at the
            same paths.
        progress: show progress bars on stderr.

    Raises:
        QuadpipeError: more workers than `MAX_WORKERS`, the output folder cannot be made, a
            format cannot be written, the scheduler cannot be reached. A failing job does not raise: see the report.
    """
    if workers is not None:
        MAX_WORKERS.check(workers)
    jobs = expand_jobs(plan)
    made = _prepare_folder(jobs)
    done = {job.name for job in jobs if not force and job.finished()}
    todo = [job for job in jobs if job.name not in done]
    results = {job.name: skipped_result(job) for job in jobs if job.name in done}
    try:
        with ProgressDisplay(jobs, done=len(results), enabled=progress) as display:
            if todo:
                finished = (
                    _run_on_dask(todo, scheduler, display)
                    if scheduler
                    else _run_locally(todo, _worker_count(workers, len(todo)), display)
                )
                for result in finished:
                    results[result.job.name] = result
                    if result.outcome is Outcome.ok:
                        note_written(result.job.files)
    finally:
        for job in todo:
            remove_leftovers(job)
        _remove_if_empty(made)
    return BatchReport([results[job.name] for job in jobs])


def _prepare_folder(jobs: Sequence[Job]) -> list[Path]:
    """Create the output folder, check before any simulation that every file can be written, and
    remove what killed runs left there. Returns the folders it made (outermost first)."""
    from quadpipe.exporters import check_output_path

    if not jobs:
        return []
    folder = Path(jobs[0].folder)
    made = [parent for parent in reversed([folder, *folder.parents]) if not parent.exists()]
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise QuadpipeError.single(
            "unwritable-output",
            f"cannot make the output folder {str(folder)!r}: {exc.strerror}",
            file=str(folder),
            hint="choose another output folder",
        ) from None
    for path in jobs[0].outputs:
        check_output_path(path)
    for job in jobs:
        remove_leftovers(job)
    return made


def _remove_if_empty(folders: list[Path]) -> None:
    """Remove the folders a batch made if it wrote nothing into them (innermost first)."""
    for folder in reversed(folders):
        try:
            folder.rmdir()
        except OSError:  # not empty: the batch wrote files there
            return


def _worker_count(requested: int | None, jobs: int) -> int:
    """Worker processes to start: as requested, else one per usable CPU core; never more than jobs."""
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1
    return max(1, min(requested or cores, jobs))


START_METHOD = "spawn"
"""How worker processes start: a fresh interpreter each, never a fork of a process with threads.
Not `forkserver`: its server listens on a Unix socket in a `pymp-*` folder of the temporary
directory, which a long TMPDIR makes fail (AF_UNIX paths are short) and a killed batch leaves."""


def _run_locally(jobs: Sequence[Job], workers: int, display: ProgressDisplay) -> Iterable[JobResult]:
    """Run jobs in `workers` processes, yielding results as they finish.

    The workers ignore SIGINT, SIGTERM and SIGHUP (a Ctrl-C reaches every process of the
    terminal): the batch stops them through the link's stop flag and waits for them to end.
    """
    context = multiprocessing.get_context(START_METHOD)
    link = WorkerLink(context.Queue(), context.Event())
    pool = ProcessPoolExecutor(max_workers=workers, mp_context=context, initializer=_start_worker, initargs=(link,))
    futures: dict[Any, Job] = {}
    try:
        with signals_deferred():  # a process half started would outlive the batch
            futures = {pool.submit(_run_in_worker, job): job for job in jobs}
        yield from _collect(futures, display, lambda: _drain(link.reports))
    except BaseException:  # Ctrl-C: running jobs stop within a simulated second, queued ones at once
        link.stop.set()
        with signals_deferred():
            pool.shutdown(wait=True, cancel_futures=True)
        note_written(_files_written(futures))
        raise
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


_worker_link: WorkerLink | None = None
"""In a worker process: its link to the batch (set by `_start_worker`)."""


def _start_worker(link: WorkerLink) -> None:
    """A worker process's start: keep the link, and leave interrupting to the batch."""
    global _worker_link
    _worker_link = link
    ignore_interrupts()


def _run_in_worker(job: Job) -> JobResult:
    """`run_job` in a worker process, linked to its batch."""
    return run_job(job, _worker_link)


def _files_written(futures: dict[Any, Job]) -> list[Path]:
    """The files of the jobs that ended well (after an interruption, as reported by their futures)."""
    ended = [future for future in futures if future.done() and not future.cancelled() and not future.exception()]
    return [path for future in ended if future.result().outcome is Outcome.ok for path in futures[future].files]


def _drain(reports: queue.Queue[tuple[str, float]]) -> list[tuple[str, float]]:
    """Every progress report waiting in the queue, without blocking."""
    items = []
    while True:
        try:
            items.append(reports.get_nowait())
        except queue.Empty:
            return items


def _run_on_dask(jobs: Sequence[Job], address: str, display: ProgressDisplay) -> Iterable[JobResult]:
    """Run jobs on a Dask distributed cluster, yielding results as they finish."""
    distributed = _import_distributed()
    try:
        client = distributed.Client(address, timeout=CONNECT_TIMEOUT_S)
    except (OSError, TimeoutError, ValueError) as exc:
        raise QuadpipeError.single(
            "scheduler-unreachable",
            f"cannot reach the Dask scheduler at {address!r}: {exc}",
            hint="check the address (tcp://HOST:8786) and that `dask scheduler` runs there",
        ) from None
    with client:
        batch_id = uuid.uuid4().hex[:8]
        futures = {client.submit(run_job, job, key=f"quadpipe-{job.name}-{batch_id}", pure=False): job for job in jobs}
        yield from _collect(futures, display, lambda: [])


def _import_distributed() -> Any:
    """The `distributed` package, or an error saying how to install it."""
    try:
        import distributed
    except ImportError:
        raise QuadpipeError.single(
            "missing-package",
            "running a batch on a Dask cluster needs the `distributed` package",
            hint='pip install "dask[distributed]"',
        ) from None
    return distributed


def _collect(futures: dict[Any, Job], display: ProgressDisplay, drain: Callable[[], list]) -> Iterable[JobResult]:
    """Yield each job's result as its future finishes, showing progress reports meanwhile.

    Works for `concurrent.futures` and Dask futures alike (both have `done()` and `result()`).
    """
    pending = dict(futures)
    while pending:
        finished = [future for future in pending if future.done()]
        display.report(drain())
        if not finished:
            time.sleep(POLL_S)
        for future in finished:
            result = _result_of(future, pending.pop(future))
            display.finished(result)
            yield result


def _result_of(future: Any, job: Job) -> JobResult:
    """The job's result; a crashed worker or a bug in quadpipe becomes a failed job."""
    try:
        return future.result()
    except Exception as exc:  # a worker died, or a bug: the other jobs go on
        message = (
            f"internal error: {type(exc).__name__}: {exc}\n  hint: run the job alone for the traceback: quadpipe "
            f"--debug bake --animal {job.animal} --controller {job.controller} --scene {job.scene} "
            f"--seconds {job.seconds:g} -o {job.name}.{job.formats[0]}"
        )
        return JobResult(job, Outcome.failed, error=message)
