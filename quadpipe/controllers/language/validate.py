"""`quadpipe validate`: check controller files and report every issue.

`validate_files(paths, fmt)` returns the report text and the exit code (1 when any error
was found, 0 otherwise). Formats:

- `text`: `file:line:col: error CODE: message`, with `  hint: ...` under it, then a summary;
- `json`: a list of objects with file, line, column, severity, code, message, hint;
- `github`: workflow commands (`::error file=F,line=L,col=C::CODE: message`) that GitHub
  Actions shows as annotations on the pull request.

Paths may be files, folders (every `*.yaml` in them) or built-in controller names. Files are
shown relative to the working directory when they lie under it.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterable, Sequence
from pathlib import Path

from quadpipe.controllers.language.semantics import analyze_controller
from quadpipe.core import codes
from quadpipe.core.errors import Issue, Location, QuadpipeError

FORMATS: tuple[str, ...] = ("text", "json", "github")
"""Output formats of `validate_files`."""

ISSUE_CODES: dict[str, str] = codes.meanings(
    (
        "yaml-syntax",
        "duplicate-key",
        "file-unreadable",
        "file-not-found",
        "is-a-folder",
        "empty-file",
        "unknown-controller",
        "extends-cycle",
        "unknown-key",
        "missing-key",
        "invalid-value",
        "unsupported-schema",
        "unknown-element-type",
        "duplicate-name",
        "template-name",
        "unknown-placeholder",
        "unknown-leg",
        "unknown-element",
        "bad-override",
        "name-clash",
        "bad-name",
        "expression-syntax",
        "forbidden-syntax",
        "unknown-name",
        "unknown-function",
        "unknown-cycle",
        "wrong-arguments",
        "wrong-type",
        "wrong-dimension",
        "dimension-mismatch",
        "parameter-cycle",
        "unknown-parameter",
        "out-of-range",
        "bad-range",
        "tunable-not-constant",
        "unknown-role",
        "glob-matches-nothing",
        "no-joint",
        "bad-point",
        "duplicate-point",
        "unknown-frame",
        "direction-kind",
        "strength-kind",
        "zero-vector",
        "unused-key",
        "nothing-to-do",
        "same-point",
        "bad-weights",
        "parallel-axis",
        "unknown-state",
        "not-switchable",
        "state-conflict",
        "unused-parameter",
        "unused-sensor",
        "unreachable-state",
    )
)
"""Every issue code `validate_files` may report, with what it means (from `quadpipe.core.codes`)."""


def _display_path(file: str | None) -> str | None:
    """A file name relative to the working directory when it lies under it."""
    if file is None or not os.path.isabs(file):
        return file
    relative = os.path.relpath(file)
    return file if relative.startswith("..") else relative


def _displayed(issue: Issue) -> Issue:
    where = issue.where
    if where is None or where.file is None:
        return issue
    moved = type(where)(_display_path(where.file), where.line, where.column)
    return Issue(issue.code, issue.message, moved, issue.hint, issue.severity)


def expand_paths(paths: Iterable[str | Path]) -> list[str]:
    """Files to check: folders become their `*.yaml` files (sorted); names stay as given."""
    found: list[str] = []
    for path in paths:
        folder = Path(path)
        if folder.is_dir():
            found.extend(str(p) for p in sorted(folder.glob("*.yaml")))
        else:
            found.append(str(path))
    return found


def collect_issues(paths: Sequence[str | Path]) -> list[Issue]:
    """Every issue of every controller named, files in the order given."""
    issues: list[Issue] = [_empty_folder(path) for path in paths if _is_empty_folder(path)]
    for path in expand_paths(paths):
        _, found = analyze_controller(path)
        issues.extend(_displayed(issue) for issue in found if _displayed(issue) not in issues)
    return issues


def _is_empty_folder(path: str | Path) -> bool:
    """Whether `path` is a folder holding no controller file (`*.yaml`)."""
    return Path(path).is_dir() and not any(Path(path).glob("*.yaml"))


def _empty_folder(path: str | Path) -> Issue:
    return Issue(
        "no-controllers",
        "this folder holds no controller files (*.yaml): nothing was checked",
        Location(str(path)),
        hint="name controller files, or a folder holding some",
    )


def format_text(issues: Sequence[Issue], checked: int) -> str:
    """Issue lines, then a one-line summary."""
    errors = sum(issue.severity == "error" for issue in issues)
    warnings = len(issues) - errors
    files = f"{checked} file{'s' if checked != 1 else ''}"
    if not issues:
        return f"{files} checked: no problems\n"
    summary = (
        f"{files} checked: {errors} error{'s' if errors != 1 else ''}, {warnings} warning{'s' if warnings != 1 else ''}"
    )
    return "".join(issue.format() + "\n" for issue in issues) + summary + "\n"


def format_json(issues: Sequence[Issue]) -> str:
    """A JSON list of issue objects."""
    rows = [
        {
            "file": issue.where.file if issue.where else None,
            "line": issue.where.line if issue.where else None,
            "column": issue.where.column if issue.where else None,
            "severity": issue.severity,
            "code": issue.code,
            "message": issue.message,
            "hint": issue.hint,
        }
        for issue in issues
    ]
    return json.dumps(rows, indent=2, ensure_ascii=False) + "\n"


def _escape_data(text: str) -> str:
    return text.replace("%", "%25").replace("\r", "%0D").replace("\n", "%0A")


def _escape_property(text: str) -> str:
    return _escape_data(text).replace(":", "%3A").replace(",", "%2C")


def format_github(issues: Sequence[Issue]) -> str:
    """GitHub Actions workflow commands, one per issue (hints on a second line)."""
    lines = []
    for issue in issues:
        where = issue.where
        props = []
        if where is not None and where.file is not None:
            props.append(f"file={_escape_property(where.file)}")
            if where.line is not None:
                props.append(f"line={where.line}")
                if where.column is not None:
                    props.append(f"col={where.column}")
        message = f"{issue.code}: {issue.message}" + (f"\n  hint: {issue.hint}" if issue.hint else "")
        command = "error" if issue.severity == "error" else "warning"
        head = f"::{command} {','.join(props)}" if props else f"::{command}"
        lines.append(f"{head}::{_escape_data(message)}\n")
    return "".join(lines)


def validate_files(paths: Sequence[str | Path], fmt: str = "text") -> tuple[str, int]:
    """Check controller files; return the report in `fmt` and the exit code.

    Args:
        paths: controller files, folders of them, or built-in names.
        fmt: `text`, `json` or `github`.

    Returns:
        (report, 1 if any error else 0).

    Raises:
        QuadpipeError: an unknown format.
    """
    if fmt not in FORMATS:
        raise QuadpipeError.single(
            "unknown-format", f"there is no output format {fmt!r}", hint=f"valid: {', '.join(FORMATS)}"
        )
    issues = collect_issues(paths)
    code = 1 if any(issue.severity == "error" for issue in issues) else 0
    if fmt == "json":
        return format_json(issues), code
    if fmt == "github":
        return format_github(issues), code
    return format_text(issues, len(expand_paths(paths))), code
