"""Running a batch: jobs in worker processes on this machine, or on a Dask cluster.

`run_batch(plan, ...)` skips jobs whose files are all there (unless `force`), runs the others
in parallel, shows their progress, and returns a `BatchReport`; a failing job does not stop the
others. Worker processes start by `forkserver` (or `spawn`), never by forking a process with
threads; Ctrl-C stops running jobs within a simulated second and queued ones at once.
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

from quadpipe.batch.jobs import Job, JobResult, Outcome, WorkerLink, expand_jobs, run_job, skipped_result
from quadpipe.batch.plan import BatchPlan
from quadpipe.batch.report import BatchReport, ProgressDisplay
from quadpipe.core.errors import QuadpipeError
from quadpipe.core.limits import MAX_WORKERS

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
    _prepare_folder(jobs)
    done = {job.name for job in jobs if not force and job.finished()}
    todo = [job for job in jobs if job.name not in done]
    results = {job.name: skipped_result(job) for job in jobs if job.name in done}
    with ProgressDisplay(jobs, done=len(results), enabled=progress) as display:
        if todo:
            finished = (
                _run_on_dask(todo, scheduler, display)
                if scheduler
                else _run_locally(todo, _worker_count(workers, len(todo)), display)
            )
            for result in finished:
                results[result.job.name] = result
    return BatchReport([results[job.name] for job in jobs])


def _prepare_folder(jobs: Sequence[Job]) -> None:
    """Create the output folder and check, before any simulation, that every file can be written."""
    from quadpipe.exporters import check_output_path

    if not jobs:
        return
    folder = Path(jobs[0].folder)
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


def _worker_count(requested: int | None, jobs: int) -> int:
    """Worker processes to start: as requested, else one per usable CPU core; never more than jobs."""
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1
    return max(1, min(requested or cores, jobs))


def _start_method() -> str:
    """`forkserver` where there is one (Linux, macOS), else `spawn`: never fork a process with threads."""
    return "forkserver" if "forkserver" in multiprocessing.get_all_start_methods() else "spawn"


def _run_locally(jobs: Sequence[Job], workers: int, display: ProgressDisplay) -> Iterable[JobResult]:
    """Run jobs in `workers` processes, yielding results as they finish."""
    context = multiprocessing.get_context(_start_method())
    with context.Manager() as manager:
        link = WorkerLink(manager.Queue(), manager.Event())
        pool = ProcessPoolExecutor(max_workers=workers, mp_context=context)
        try:
            futures = {pool.submit(run_job, job, link): job for job in jobs}
            yield from _collect(futures, display, lambda: _drain(link.reports))
        except BaseException:  # Ctrl-C: running jobs stop within a simulated second, queued ones at once
            link.stop.set()
            raise
        finally:
            pool.shutdown(wait=True, cancel_futures=True)


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
