"""Batches: many simulations baked in parallel, on this machine or on a Dask cluster.

A plan (`configs/batches/<name>.yaml`, or lists given on the command line) names animals,
controllers and scenes; every combination is one job, baked like `quadpipe bake` into
`<output>/<animal>_<controller>_<scene>.<format>` for each format, plus
`<animal>_<controller>_<scene>.metrics.json`. See docs/batch.md.

- `load_plan(path)` / `plan_from(path, animals=..., ...)` -> `BatchPlan` (errors at file:line:col);
- `expand_jobs(plan)` -> the `Job`s, plain picklable data;
- `run_job(job)` bakes one job, all of its files or none (they are written into a hidden
  staging folder and renamed into place, the metrics JSON last);
- `run_batch(plan, workers=..., force=..., scheduler=..., progress=...)` -> `BatchReport`: the
  jobs run in worker processes (or on a Dask cluster at `scheduler`), a failing job does not
  stop the others, jobs whose files are all present are skipped unless `force`;
- `summary_table(report)`: the rich table printed at the end.

A job's files are byte-identical whether it runs alone, in a batch or on Dask: the simulation
and the writers are deterministic, and nothing about the run (time, host) enters the files.
"""

from __future__ import annotations

import json
import multiprocessing
import os
import queue
import shutil
import tempfile
import time
import uuid
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from enum import Enum
from pathlib import Path
from typing import Annotated, Any, Callable, Iterable, Sequence

from pydantic import AfterValidator, BaseModel, BeforeValidator, ConfigDict, Field

from quadpipe.core import configs
from quadpipe.core.errors import Issue, QuadpipeError, did_you_mean
from quadpipe.core.yamlio import YamlDocument, load_yaml, validate_document

ALL = "all"
"""In a list of animals, controllers or scenes: every built-in one."""

DEFAULT_SCENE = "flat"
DEFAULT_SECONDS = 10.0
DEFAULT_FORMAT = "glb"
DEFAULT_OUTPUT = "out/batch"

METRICS_SUFFIX = ".metrics.json"
"""A job's metrics file: `<job name>.metrics.json`, the same JSON `quadpipe bake` writes."""

PROGRESS_STEP_S = 1.0
"""Simulated seconds between two progress reports of a running job."""

POLL_S = 0.1
"""Wall-clock seconds between two looks at the running jobs and their progress reports."""

CONNECT_TIMEOUT_S = 10.0
"""How long to try reaching a Dask scheduler before giving up."""

EXIT_JOBS_FAILED = 1
"""Exit code of `quadpipe batch` when any job failed (the others still finished)."""

COMMAND_LINE = "<command line>"
"""Where options given on the command line are reported to come from."""


# ---------------------------------------------------------------------------------- the plan


def _as_list(value: Any) -> Any:
    """Accept one name where a list of names is expected (`animals: dog`)."""
    return [value] if isinstance(value, str) else value


def _names(value: list[str]) -> list[str]:
    """Strip and de-duplicate names; `all` must stand alone."""
    names = list(dict.fromkeys(name.strip() for name in value))
    if "" in names:
        raise ValueError("a name is empty")
    if ALL in names and len(names) > 1:
        raise ValueError(f"{ALL!r} already means every built-in one: write it alone, or list the names")
    return names


def _format(value: str) -> str:
    """A format as a bare lower-case suffix (`.GLB` -> `glb`) that quadpipe can write."""
    from quadpipe.exporters import supported_formats

    known = {fmt.suffix.lstrip("."): fmt for fmt in supported_formats()}
    name = value.strip().lower().lstrip(".")
    if name not in known:
        raise ValueError(f"quadpipe cannot write {name!r} files; {did_you_mean(name, known)}")
    if not known[name].available:
        raise ValueError(f"writing {name} needs a package that is not installed: {known[name].install_hint}")
    return name


def _unique(value: list[str]) -> list[str]:
    """The list without repeats, in order."""
    return list(dict.fromkeys(value))


Names = Annotated[list[str], BeforeValidator(_as_list), Field(min_length=1), AfterValidator(_names)]
Formats = Annotated[
    list[Annotated[str, AfterValidator(_format)]], BeforeValidator(_as_list), Field(min_length=1), AfterValidator(_unique)
]


class JobOverride(BaseModel):
    """Settings for the jobs an override selects (every job when it names no selector).

    Selectors compare with the names as they appear in file names: a built-in name (`dog`) or
    a config file's stem (`my_walk` for `controllers/my_walk.yaml`).
    """

    model_config = ConfigDict(extra="forbid")

    animal: str | None = Field(None, description="Only jobs of this animal (omitted: any).")
    controller: str | None = Field(None, description="Only jobs of this controller (omitted: any).")
    scene: str | None = Field(None, description="Only jobs in this scene (omitted: any).")
    seconds: float | None = Field(None, gt=0, description="Simulated time of the selected jobs.")
    parameters: dict[str, Any] = Field(
        {}, description="Controller parameter values, as in a controller file (`pedal_force: 0.2 bw`)."
    )

    def selects(self, animal: str, controller: str, scene: str) -> bool:
        """Whether this override applies to the job with these labels."""
        wanted = (self.animal, self.controller, self.scene)
        return all(want is None or want == have for want, have in zip(wanted, (animal, controller, scene)))


class BatchPlan(BaseModel):
    """What to bake: the cross product of animals, controllers and scenes, in some formats."""

    model_config = ConfigDict(extra="forbid")

    animals: Names = Field(description="Animal names or config files, or `all`.")
    controllers: Names = Field(description="Controller names or files, or `all`.")
    scenes: Names = Field([DEFAULT_SCENE], description="Scene names or files, or `all`.")
    seconds: float = Field(DEFAULT_SECONDS, gt=0, description="Simulated time of every job.")
    formats: Formats = Field([DEFAULT_FORMAT], description="Formats to write, by suffix: glb, usdc, bvh, npz...")
    output: str = Field(DEFAULT_OUTPUT, min_length=1, description="Folder of the files (created if missing).")
    overrides: list[JobOverride] = Field([], description="Per-job settings, applied in order (later ones win).")


def load_plan(path: str | Path) -> BatchPlan:
    """Read and check a batch plan file.

    Raises:
        QuadpipeError: syntax or schema errors, and override selectors that name no animal,
            controller or scene of the plan, each at its file:line:col.
    """
    doc = load_yaml(path)
    plan = validate_document(BatchPlan, doc)
    issues = _selector_issues(plan, doc)
    if issues:
        raise QuadpipeError(issues)
    return plan


def _selector_issues(plan: BatchPlan, doc: YamlDocument) -> list[Issue]:
    """An issue for each override selector that matches none of the plan's names."""
    labels = {
        "animal": [label(n) for n in expand_names(plan.animals, "animals")],
        "controller": [label(n) for n in expand_names(plan.controllers, "controllers")],
        "scene": [label(n) for n in expand_names(plan.scenes, "scenes")],
    }
    issues = []
    for index, override in enumerate(plan.overrides):
        for key, valid in labels.items():
            wanted = getattr(override, key)
            if wanted is not None and wanted not in valid:
                issues.append(
                    Issue(
                        "override-selects-nothing",
                        f"overrides[{index}] selects {key} {wanted!r}, which is not in the plan's {key}s",
                        doc.locate(("overrides", index, key)),
                        did_you_mean(wanted, valid),
                    )
                )
    return issues


def plan_from(
    path: str | Path | None,
    *,
    animals: Sequence[str] | None = None,
    controllers: Sequence[str] | None = None,
    scenes: Sequence[str] | None = None,
    seconds: float | None = None,
    formats: Sequence[str] | None = None,
    output: str | Path | None = None,
) -> BatchPlan:
    """A plan from a file (optional) and command-line options, which replace the file's values.

    List options accept repeated and comma-separated names (`["dog,horse", "cat"]`).

    Raises:
        QuadpipeError: errors in the file (located), or in the options (`<command line>`).
    """
    base = load_plan(path).model_dump(exclude_unset=True) if path is not None else {}
    options = {
        "animals": _split(animals),
        "controllers": _split(controllers),
        "scenes": _split(scenes),
        "seconds": seconds,
        "formats": _split(formats),
        "output": None if output is None else str(output),
    }
    merged = base | {key: value for key, value in options.items() if value is not None}
    if "animals" not in merged or "controllers" not in merged:
        raise QuadpipeError.single(
            "incomplete-plan",
            "a batch needs animals and controllers",
            hint="give a plan file, or --animal and --controller (e.g. quadpipe batch -a dog,horse -c spine_walk)",
        )
    return validate_document(BatchPlan, YamlDocument(data=merged, file=COMMAND_LINE))


def _split(values: Sequence[str] | None) -> list[str] | None:
    """Repeated and comma-separated command-line names as one list (None when not given)."""
    if not values:
        return None
    return [name.strip() for value in values for name in value.split(",") if name.strip()]


# ---------------------------------------------------------------------------------- jobs


def looks_like_path(name: str) -> bool:
    """Whether a config is given by file (`walks/fast.yaml`) rather than by built-in name."""
    return Path(name).suffix in (".yaml", ".yml") or "/" in name or os.sep in name


def label(name: str) -> str:
    """What a config contributes to a job's file names: its name, or its file's stem."""
    return Path(name).stem if looks_like_path(name) else name


def expand_names(names: Sequence[str], kind: str) -> list[str]:
    """`all` as every built-in config of `kind` (`animals`, `controllers`, `scenes`)."""
    return configs.available(kind) if list(names) == [ALL] else list(names)


@dataclass(frozen=True)
class Job:
    """One simulation and its files: plain data, so that it pickles to worker processes.

    Attributes:
        animal: built-in name, or absolute path of an animal config.
        controller: built-in name, or absolute path of a controller file.
        scene: built-in name, or absolute path of a scene file.
        seconds: simulated time.
        formats: bare suffixes (`glb`), one file each.
        folder: absolute path of the output folder.
        parameters: controller parameter values, as (name, value) pairs.
    """

    animal: str
    controller: str
    scene: str
    seconds: float
    formats: tuple[str, ...]
    folder: str
    parameters: tuple[tuple[str, Any], ...] = ()

    @property
    def name(self) -> str:
        """`<animal>_<controller>_<scene>`: the stem of every file of the job."""
        return f"{label(self.animal)}_{label(self.controller)}_{label(self.scene)}"

    @property
    def outputs(self) -> list[Path]:
        """The clip files, one per format."""
        return [Path(self.folder) / f"{self.name}.{fmt}" for fmt in self.formats]

    @property
    def metrics_path(self) -> Path:
        """The metrics JSON, written last."""
        return Path(self.folder) / f"{self.name}{METRICS_SUFFIX}"

    @property
    def files(self) -> list[Path]:
        """Every file of the job, the metrics JSON last."""
        return [*self.outputs, self.metrics_path]

    def finished(self) -> bool:
        """Whether every file of the job is present (a finished job is skipped on re-runs)."""
        return all(path.is_file() for path in self.files)


def expand_jobs(plan: BatchPlan) -> list[Job]:
    """Every animal x controller x scene of the plan, with its overrides applied, in plan order.

    Raises:
        QuadpipeError: `duplicate-job` when two configs give the same file names
            (`a/walk.yaml` and `b/walk.yaml`).
    """
    folder = str(Path(plan.output).resolve())
    jobs = [
        _job(plan, folder, animal, controller, scene)
        for animal in expand_names(plan.animals, "animals")
        for controller in expand_names(plan.controllers, "controllers")
        for scene in expand_names(plan.scenes, "scenes")
    ]
    seen: dict[str, Job] = {}
    for job in jobs:
        if job.name in seen:
            raise QuadpipeError.single(
                "duplicate-job",
                f"two jobs would write the same files {job.name}.*: "
                f"({seen[job.name].animal}, {seen[job.name].controller}, {seen[job.name].scene}) and "
                f"({job.animal}, {job.controller}, {job.scene})",
                hint="rename one of the config files: file names are built from their stems",
            )
        seen[job.name] = job
    return jobs


def _job(plan: BatchPlan, folder: str, animal: str, controller: str, scene: str) -> Job:
    """One job of the plan, its overrides applied in order."""
    seconds, parameters = plan.seconds, {}
    for override in plan.overrides:
        if override.selects(label(animal), label(controller), label(scene)):
            seconds = override.seconds or seconds
            parameters |= override.parameters
    return Job(
        animal=_absolute(animal),
        controller=_absolute(controller),
        scene=_absolute(scene),
        seconds=seconds,
        formats=tuple(plan.formats),
        folder=folder,
        parameters=tuple(parameters.items()),
    )


def _absolute(name: str) -> str:
    """A config file's absolute path (workers may run elsewhere); a built-in name as it is."""
    return str(Path(name).resolve()) if looks_like_path(name) else name


# ---------------------------------------------------------------------------------- one job


class Outcome(str, Enum):
    """How a job ended."""

    ok = "ok"
    failed = "failed"
    skipped = "skipped"


@dataclass(frozen=True)
class JobResult:
    """What a job did.

    Attributes:
        job: the job.
        outcome: ok, failed, or skipped (its files were already there).
        wall_s: wall-clock seconds it took (0 when skipped).
        error: the error message (no traceback) when it failed.
        distances_hp: distance travelled by each animal of the clip, in pelvis heights.
        sizes: (file name, bytes) of each file written.
    """

    job: Job
    outcome: Outcome
    wall_s: float = 0.0
    error: str | None = None
    distances_hp: tuple[float, ...] = ()
    sizes: tuple[tuple[str, int], ...] = ()


@dataclass(frozen=True)
class WorkerLink:
    """How a job in a worker process talks with its batch: progress reports out, a stop flag in.

    Attributes:
        reports: a queue (a `multiprocessing` manager's proxy) receiving `(job name, simulated
            seconds done)`.
        stop: an event (a manager's proxy) the batch sets when it is interrupted.
    """

    reports: Any
    stop: Any

    def report(self, job: str, simulated_s: float) -> None:
        """Tell the batch how far a job has simulated."""
        self.reports.put((job, simulated_s))

    def check(self) -> None:
        """Raise `interrupted` once the batch has been interrupted.

        Raises:
            QuadpipeError: `interrupted`.
        """
        if self.stop.is_set():
            raise QuadpipeError.single("interrupted", "the batch was interrupted before this job finished")


class _ProgressTicker:
    """Called after every frame: reports the simulated time every `PROGRESS_STEP_S` and stops
    the simulation (raising `interrupted`) once the batch is interrupted."""

    def __init__(self, job: str, link: WorkerLink):
        self.job, self.link, self.next_s = job, link, PROGRESS_STEP_S

    def __call__(self, time_s: float) -> None:
        """At each whole simulated second: report it, and check for an interruption."""
        if time_s >= self.next_s - 1e-9:
            self.link.report(self.job, self.next_s)
            self.link.check()
            self.next_s += PROGRESS_STEP_S


def run_job(job: Job, link: WorkerLink | None = None) -> JobResult:
    """Simulate one job and write all of its files, or none of them.

    Args:
        job: the job.
        link: to the batch running it in a worker process: progress at the start and every
            simulated second, and an interruption stops the job (None: neither).

    Returns:
        `ok` with the clip's distances and the file sizes, or `failed` with the error's text
        when the input was at fault (unknown name, bad file, blow-up) or the batch was
        interrupted. Bugs propagate.
    """
    start = time.perf_counter()
    try:
        if link is not None:
            link.check()
            link.report(job.name, 0.0)
        metrics = _bake(job, link)
    except QuadpipeError as exc:
        return JobResult(job, Outcome.failed, time.perf_counter() - start, error=exc.format())
    return _result_from_files(job, Outcome.ok, time.perf_counter() - start, metrics)


def _bake(job: Job, link: WorkerLink | None) -> dict:
    """Simulate and write the files into a hidden staging folder, then rename them into place."""
    from quadpipe.core.atomic import write_text
    from quadpipe.exporters import export_clip
    from quadpipe.sim.simulation import simulate

    staging = Path(_staging_folder(job))
    try:
        result = simulate(
            job.animal, job.controller, seconds=job.seconds, scene=job.scene,
            parameters=dict(job.parameters), on_frame=_ProgressTicker(job.name, link) if link is not None else None,
        )
        for output in job.outputs:
            export_clip(result.clip, staging / output.name)
        write_text(staging / job.metrics_path.name, json.dumps(result.metrics, indent=2) + "\n")
        for path in job.files:
            os.replace(staging / path.name, path)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    return result.metrics


def _staging_folder(job: Job) -> str:
    """A fresh hidden folder beside the job's files (same file system, so renames are atomic)."""
    try:
        return tempfile.mkdtemp(prefix=f".{job.name}.partial-", dir=job.folder)
    except OSError as exc:
        raise QuadpipeError.single(
            "unwritable-output", f"cannot write into {job.folder!r}: {exc.strerror}", file=job.folder,
            hint="check that the output folder exists and is writable (on every Dask worker too)",
        ) from None


def _result_from_files(job: Job, outcome: Outcome, wall_s: float, metrics: dict | None) -> JobResult:
    """A result whose distances come from `metrics` and sizes from the job's files on disk."""
    distances = tuple(animal["distance_hp"] for animal in (metrics or {}).get("animals", {}).values())
    sizes = tuple((path.name, path.stat().st_size) for path in job.files if path.is_file())
    return JobResult(job, outcome, wall_s, distances_hp=distances, sizes=sizes)


def _skipped(job: Job) -> JobResult:
    """The result of a job whose files are all there: its figures read back from them."""
    try:
        metrics = json.loads(job.metrics_path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        metrics = None
    return _result_from_files(job, Outcome.skipped, 0.0, metrics)


# ---------------------------------------------------------------------------------- the batch


@dataclass
class BatchReport:
    """Every job's result, in plan order."""

    results: list[JobResult] = field(default_factory=list)

    def count(self, outcome: Outcome) -> int:
        """How many jobs ended so."""
        return sum(result.outcome is outcome for result in self.results)

    @property
    def exit_code(self) -> int:
        """0 when no job failed, else `EXIT_JOBS_FAILED`."""
        return EXIT_JOBS_FAILED if self.count(Outcome.failed) else 0


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
        QuadpipeError: the output folder cannot be made, a format cannot be written, the
            scheduler cannot be reached. A failing job does not raise: see the report.
    """
    jobs = expand_jobs(plan)
    _prepare_folder(jobs)
    done = {job.name for job in jobs if not force and job.finished()}
    todo = [job for job in jobs if job.name not in done]
    results = {job.name: _skipped(job) for job in jobs if job.name in done}
    with _Display(jobs, done=len(results), enabled=progress) as display:
        if todo:
            run = _run_on_dask if scheduler else _run_locally
            target = scheduler if scheduler else _worker_count(workers, len(todo))
            for result in run(todo, target, display):
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
            "unwritable-output", f"cannot make the output folder {str(folder)!r}: {exc.strerror}", file=str(folder),
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


def _run_locally(jobs: Sequence[Job], workers: int, display: "_Display") -> Iterable[JobResult]:
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


def _drain(reports: "queue.Queue[tuple[str, float]]") -> list[tuple[str, float]]:
    """Every progress report waiting in the queue, without blocking."""
    items = []
    while True:
        try:
            items.append(reports.get_nowait())
        except queue.Empty:
            return items


def _run_on_dask(jobs: Sequence[Job], address: str, display: "_Display") -> Iterable[JobResult]:
    """Run jobs on a Dask distributed cluster, yielding results as they finish."""
    distributed = _import_distributed()
    try:
        client = distributed.Client(address, timeout=CONNECT_TIMEOUT_S)
    except (OSError, TimeoutError, ValueError) as exc:
        raise QuadpipeError.single(
            "scheduler-unreachable", f"cannot reach the Dask scheduler at {address!r}: {exc}",
            hint="check the address (tcp://HOST:8786) and that `dask scheduler` runs there",
        ) from None
    with client:
        batch_id = uuid.uuid4().hex[:8]
        futures = {
            client.submit(run_job, job, key=f"quadpipe-{job.name}-{batch_id}", pure=False): job for job in jobs
        }
        yield from _collect(futures, display, lambda: [])


def _import_distributed() -> Any:
    """The `distributed` package, or an error saying how to install it."""
    try:
        import distributed
    except ImportError:
        raise QuadpipeError.single(
            "missing-package", "running a batch on a Dask cluster needs the `distributed` package",
            hint='pip install "dask[distributed]"',
        ) from None
    return distributed


def _collect(futures: dict[Any, Job], display: "_Display", drain: Callable[[], list]) -> Iterable[JobResult]:
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


# ---------------------------------------------------------------------------------- display


class _Display:
    """Live progress on stderr: a bar for the batch, and one per running job while it runs."""

    def __init__(self, jobs: Sequence[Job], *, done: int, enabled: bool):
        from rich.console import Console
        from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

        self.enabled = enabled
        self.seconds = {job.name: job.seconds for job in jobs}
        self.total, self.done = len(jobs), done
        self.progress = Progress(
            TextColumn("{task.description}", markup=False), BarColumn(), TextColumn("{task.fields[amount]}"), TimeElapsedColumn(),
            console=Console(stderr=True), disable=not enabled,
        )
        self.overall = self.progress.add_task("batch", total=self.total, completed=done, amount=self._jobs_text())
        self.running: dict[str, Any] = {}

    def __enter__(self) -> "_Display":
        self.progress.start()
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.progress.stop()

    def _jobs_text(self) -> str:
        return f"{self.done}/{self.total} jobs"

    def report(self, items: Sequence[tuple[str, float]]) -> None:
        """Move running jobs' bars to their latest simulated time."""
        for name, simulated_s in items:
            total = self.seconds[name]
            if name not in self.running:
                self.running[name] = self.progress.add_task(name, total=total, amount="")
            self.progress.update(self.running[name], completed=simulated_s, amount=f"{simulated_s:g}/{total:g} s")

    def finished(self, result: JobResult) -> None:
        """Drop a finished job's bar, count it, and print its outcome line."""
        name = result.job.name
        if name in self.running:
            self.progress.remove_task(self.running.pop(name))
        self.done += 1
        self.progress.update(self.overall, completed=self.done, amount=self._jobs_text())
        if self.enabled:
            first_line = (result.error or "").splitlines()[0] if result.error else ""
            line = f"{result.outcome.value:7} {name} ({result.wall_s:.1f} s) {first_line}".rstrip()
            self.progress.console.print(line, markup=False, highlight=False)


def summary_table(report: BatchReport) -> Any:
    """A rich `Table`: job, outcome, wall time, distance in HP, file sizes, error message."""
    from rich.table import Table

    from rich.markup import escape

    counts = ", ".join(f"{report.count(outcome)} {outcome.value}" for outcome in Outcome)
    jobs = len(report.results)
    table = Table(title=f"Batch: {jobs} job{'' if jobs == 1 else 's'} ({counts})")
    for header in ("job", "outcome", "wall (s)", "distance (HP)", "files", "message"):
        table.add_column(header)
    styles = {Outcome.ok: "green", Outcome.failed: "bold red", Outcome.skipped: "dim"}
    for result in report.results:
        table.add_row(
            escape(result.job.name),
            f"[{styles[result.outcome]}]{result.outcome.value}[/]",
            f"{result.wall_s:.1f}" if result.outcome is not Outcome.skipped else "-",
            " ".join(f"{d:.2f}" for d in result.distances_hp) or "-",
            ", ".join(f"{name.removeprefix(result.job.name)} {_size_text(size)}" for name, size in result.sizes) or "-",
            _message(result),
        )
    return table


def _message(result: JobResult) -> str:
    """The summary's message cell: the error for a failed job, why for a skipped one."""
    from rich.markup import escape

    if result.outcome is Outcome.skipped:
        return "files already there (force to redo)"
    return escape(result.error or "")


def _size_text(size: int) -> str:
    """Bytes as `812 B`, `746 KiB`, `3.2 MiB`."""
    for unit, scale in (("MiB", 1 << 20), ("KiB", 1 << 10)):
        if size >= scale:
            value = size / scale
            return f"{value:.1f} {unit}" if value < 10 else f"{value:.0f} {unit}"
    return f"{size} B"
