"""Batch jobs: one simulation each, baked into its files (all of them or none).

`expand_jobs(plan)` turns a plan into `Job`s, plain picklable data; `run_job(job)` bakes one
(its files are staged beside their targets and renamed into place together, the metrics JSON
last), reporting progress to its batch through a `WorkerLink` when it runs in a worker.
"""

from __future__ import annotations

import glob
import json
import shutil
import time
from dataclasses import dataclass
from enum import Enum
from pathlib import Path
from typing import Any

from quadpipe.batch.bake import METRICS_SUFFIX, bake
from quadpipe.batch.plan import BatchPlan, expand_names, label, looks_like_path
from quadpipe.controllers.runtime.variation import Variation
from quadpipe.core.atomic import remove_stale
from quadpipe.core.errors import Location, QuadpipeError

PROGRESS_STEP_S = 1.0
"""Simulated seconds between two progress reports of a running job."""


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
        parameter_places: where each of them is written in the plan file, as (name, location) pairs.
        variation: stride-to-stride variation of the gait (0: none), drawn from `seed`.
        seed: the variation's seed.
    """

    animal: str
    controller: str
    scene: str
    seconds: float
    formats: tuple[str, ...]
    folder: str
    parameters: tuple[tuple[str, Any], ...] = ()
    parameter_places: tuple[tuple[str, Location], ...] = ()
    variation: float = 0.0
    seed: int = 0

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
    seconds = plan.seconds
    parameters: dict[str, Any] = {}
    places: dict[str, Location] = {}
    for index, override in enumerate(plan.overrides):
        if override.selects(label(animal), label(controller), label(scene)):
            seconds = override.seconds or seconds
            parameters |= override.parameters
            places |= plan.parameter_places(index)
    return Job(
        animal=_absolute(animal),
        controller=_absolute(controller),
        scene=_absolute(scene),
        seconds=seconds,
        formats=tuple(plan.formats),
        folder=folder,
        parameters=tuple(parameters.items()),
        parameter_places=tuple(places.items()),
        variation=plan.variation,
        seed=plan.seed,
    )


def _absolute(name: str) -> str:
    """A config file's absolute path (workers may run elsewhere); a built-in name as it is."""
    return str(Path(name).resolve()) if looks_like_path(name) else name


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
    """Simulate and write the job's files, all of them or none (`quadpipe.batch.bake`)."""
    result = bake(
        job.animal,
        job.controller,
        seconds=job.seconds,
        scene=job.scene,
        parameters=dict(job.parameters),
        places=dict(job.parameter_places),
        outputs=job.outputs,
        metrics_path=job.metrics_path,
        on_frame=_ProgressTicker(job.name, link) if link is not None else None,
        variation=Variation(job.variation, job.seed) if job.variation else None,
    )
    return result.metrics


def remove_leftovers(job: Job) -> None:
    """Remove what killed runs of the job left: staged files of processes that no longer run, and
    the staging folders (`.<job>.partial-*`) where earlier versions of quadpipe staged a job's files."""
    folder = Path(job.folder)
    remove_stale(folder / f"{glob.escape(job.name)}.*")
    for staging in folder.glob(f".{glob.escape(job.name)}.partial-*"):
        shutil.rmtree(staging, ignore_errors=True)


def _result_from_files(job: Job, outcome: Outcome, wall_s: float, metrics: dict | None) -> JobResult:
    """A result whose distances come from `metrics` and sizes from the job's files on disk."""
    distances = tuple(animal["distance_hp"] for animal in (metrics or {}).get("animals", {}).values())
    sizes = tuple((path.name, path.stat().st_size) for path in job.files if path.is_file())
    return JobResult(job, outcome, wall_s, distances_hp=distances, sizes=sizes)


def skipped_result(job: Job) -> JobResult:
    """The result of a job whose files are all there: its figures read back from them."""
    try:
        metrics = json.loads(job.metrics_path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        metrics = None
    return _result_from_files(job, Outcome.skipped, 0.0, metrics)
