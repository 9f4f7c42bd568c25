"""What a batch shows: live progress bars while it runs, and the summary table at the end."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from quadpipe.batch.jobs import Job, JobResult, Outcome

EXIT_JOBS_FAILED = 1
"""Exit code of `quadpipe batch` when any job failed (the others still finished)."""


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


class ProgressDisplay:
    """Live progress on stderr: a bar for the batch, and one per running job while it runs."""

    def __init__(self, jobs: Sequence[Job], *, done: int, enabled: bool):
        from rich.console import Console
        from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

        self.enabled = enabled
        self.seconds = {job.name: job.seconds for job in jobs}
        self.total, self.done = len(jobs), done
        self.progress = Progress(
            TextColumn("{task.description}", markup=False),
            BarColumn(),
            TextColumn("{task.fields[amount]}"),
            TimeElapsedColumn(),
            console=Console(stderr=True),
            disable=not enabled,
        )
        self.overall = self.progress.add_task("batch", total=self.total, completed=done, amount=self._jobs_text())
        self.running: dict[str, Any] = {}

    def __enter__(self) -> ProgressDisplay:
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
    from rich.markup import escape
    from rich.table import Table

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
