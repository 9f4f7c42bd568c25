"""Errors that reach the user: what went wrong, where, and what to do about it.

Every problem caused by the user's input (a file, a name, a number) is raised as a
`QuadpipeError` holding one or more `Issue`s. The CLI prints them as

    configs/animals/dog.yaml:4:3: error unknown-key: 'mas' is not a key here
      hint: did you mean 'mass_kg'?

and exits non-zero without a traceback (unless `--debug`). Anything else that escapes is a
bug in quadpipe and keeps its traceback.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path


@dataclass(frozen=True)
class Location:
    """A place in a file; line and column are 1-based and optional."""

    file: str | None = None
    line: int | None = None
    column: int | None = None

    def __str__(self) -> str:
        parts = [self.file or "<input>"]
        if self.line is not None:
            parts.append(str(self.line))
            if self.column is not None:
                parts.append(str(self.column))
        return ":".join(parts)


@dataclass(frozen=True)
class Issue:
    """One coded problem: `code` is a stable kebab-case name that tests and CI can match."""

    code: str
    message: str
    where: Location | None = None
    hint: str | None = None
    severity: str = "error"

    def format(self) -> str:
        """Return the `file:line:col: severity code: message` line (plus a hint line)."""
        head = f"{self.where}: " if self.where is not None else ""
        text = f"{head}{self.severity} {self.code}: {self.message}"
        if self.hint:
            text += f"\n  hint: {self.hint}"
        return text


@dataclass
class QuadpipeError(Exception):
    """An error in the user's input, carrying every issue found."""

    issues: list[Issue] = field(default_factory=list)

    def __post_init__(self) -> None:
        super().__init__(self.format())

    @classmethod
    def single(
        cls,
        code: str,
        message: str,
        *,
        where: Location | None = None,
        file: str | Path | None = None,
        line: int | None = None,
        column: int | None = None,
        hint: str | None = None,
    ) -> QuadpipeError:
        """Build an error with one issue; `file/line/column` are a shortcut for `where`."""
        if where is None and file is not None:
            where = Location(str(file), line, column)
        return cls([Issue(code, message, where, hint)])

    def format(self) -> str:
        """All issues, one per line (hints indented under their issue)."""
        return "\n".join(issue.format() for issue in self.issues)

    def __str__(self) -> str:
        return self.format()


def did_you_mean(name: str, options: Iterable[str], *, listing: bool = True) -> str:
    """Return a hint naming the closest valid option(s), and the whole list when short.

    Args:
        name: what the user wrote.
        options: the valid names.
        listing: also list all valid options when there are at most 40 of them.
    """
    options = sorted(set(options))
    close = difflib.get_close_matches(name, options, n=3, cutoff=0.6)
    hint = f"did you mean {' or '.join(repr(c) for c in close)}?" if close else ""
    if listing and len(options) <= 40:
        valid = "valid: " + ", ".join(options)
        hint = f"{hint} ({valid})" if hint else valid
    return hint
