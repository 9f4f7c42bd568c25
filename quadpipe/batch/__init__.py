"""Batches: many simulations baked in parallel, on this machine or on a Dask cluster.

A plan (`configs/batches/<name>.yaml`, or lists given on the command line) names animals,
controllers and scenes; every combination is one job, baked like `quadpipe bake` into
`<output>/<animal>_<controller>_<scene>.<format>` for each format, plus
`<animal>_<controller>_<scene>.metrics.json`. See docs/batch.md.

- `load_plan(path)` / `plan_from(path, animals=..., ...)` -> `BatchPlan` (errors at file:line:col)
  (`quadpipe.batch.plan`);
- `expand_jobs(plan)` -> the `Job`s, plain picklable data; `run_job(job)` bakes one job, all of
  its files or none (they are written into a hidden staging folder and renamed into place, the
  metrics JSON last) (`quadpipe.batch.jobs`, over `quadpipe.batch.bake.bake`, which the
  `simulate` and `bake` commands use too);
- `run_batch(plan, workers=..., force=..., scheduler=..., progress=...)` -> `BatchReport`: the
  jobs run in worker processes (or on a Dask cluster at `scheduler`), a failing job does not
  stop the others, jobs whose files are all present are skipped unless `force`
  (`quadpipe.batch.scheduling`);
- `summary_table(report)`: the rich table printed at the end (`quadpipe.batch.report`).

A job's files are byte-identical whether it runs alone, in a batch or on Dask: the simulation
and the writers are deterministic, and nothing about the run (time, host) enters the files.
"""

from quadpipe.batch.jobs import Job, JobResult, Outcome, WorkerLink, expand_jobs, run_job
from quadpipe.batch.plan import BatchPlan, JobOverride, load_plan, plan_from
from quadpipe.batch.report import BatchReport, summary_table
from quadpipe.batch.scheduling import run_batch

__all__ = [
    "BatchPlan",
    "BatchReport",
    "Job",
    "JobOverride",
    "JobResult",
    "Outcome",
    "WorkerLink",
    "expand_jobs",
    "load_plan",
    "plan_from",
    "run_batch",
    "run_job",
    "summary_table",
]
