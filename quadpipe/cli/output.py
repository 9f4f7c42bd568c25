"""What commands print: tables, warnings, and the gait files some of them write."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import typer

if TYPE_CHECKING:
    from quadpipe.analysis import GaitReport
    from quadpipe.core.errors import Issue


def print_table(title: str, headers: Sequence[str], rows: Iterable[Sequence[object]]) -> None:
    """A titled table on stdout (rich), every cell shown with `str`."""
    from rich.console import Console
    from rich.table import Table

    table = Table(title=title)
    for header in headers:
        table.add_column(header)
    for row in rows:
        table.add_row(*(str(cell) for cell in row))
    Console().print(table)


def print_warnings(issues: Iterable[Issue]) -> None:
    """Warnings on stderr, one formatted issue each."""
    for issue in issues:
        typer.echo(issue.format(), err=True)


def write_gait_files(report: GaitReport, report_path: Path | None, diagram: Path | None) -> None:
    """Write a gait analysis as JSON and its footfall diagram as PNG (either may be None): both, or neither."""
    from quadpipe.analysis import draw_footfall_diagram
    from quadpipe.core.atomic import transaction, write_text

    with transaction():
        if report_path is not None:
            write_text(report_path, report.to_json())
        if diagram is not None:
            draw_footfall_diagram(report, diagram)
    for written in (report_path, diagram):
        if written is not None:
            typer.echo(f"wrote {written}")
