"""Checks on the files a command is asked to write, made before any work: each output must be a
file of its own (not another output, not one of the command's inputs) and carry a suffix that
matches what is written into it.

Options are named as the user typed them (`-o`, `--metrics`), so that a message says which
option to change.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from pathlib import Path

from quadpipe.core.errors import QuadpipeError

Named = tuple[str, Path]
"""A file and what named it: an output's option (`("--metrics", Path("x.json"))`), an input's
description (`("the --controller file", Path("walk.yaml"))`, `("the clip", Path("run.npz"))`)."""


def check_distinct(outputs: Sequence[Named], inputs: Iterable[Named] = ()) -> None:
    """Refuse two outputs naming the same file, and an output naming an input file.

    Paths are compared once resolved (`./x.npz` and `x.npz`, or a link and its target, are one
    file). Inputs that are not files (built-in names such as `dog`) are left out.

    Raises:
        QuadpipeError: `output-collision`, located at the output, naming both options.
    """
    claimed: dict[Path, str] = {}
    for option, path in inputs:
        if Path(path).is_file():
            claimed.setdefault(_identity(path), f"{option}: writing it would destroy the input")
    for option, path in outputs:
        key = _identity(path)
        if key in claimed:
            raise QuadpipeError.single(
                "output-collision",
                f"{option} {str(path)!r} names {claimed[key]}",
                file=str(path),
                hint="give every output its own file name, apart from the input files",
            )
        claimed[key] = f"the same file as {option} {str(path)!r}: one would overwrite the other"


def check_suffix(option: str, path: Path, suffixes: Sequence[str], what: str) -> None:
    """Refuse an output whose suffix is not one of `suffixes` (lower case, with the dot).

    Args:
        option: the option naming the file (`-o`).
        path: the file.
        suffixes: the suffixes of what is written (`.xml`, `.mjcf`).
        what: what is written, for the message (`MJCF`).

    Raises:
        QuadpipeError: `wrong-suffix`, located at the file.
    """
    suffix = path.suffix.lower()
    if suffix not in suffixes:
        actual = f"its suffix is {suffix!r}" if suffix else "it has no suffix"
        raise QuadpipeError.single(
            "wrong-suffix",
            f"{option} {str(path)!r} would hold {what}, but {actual}",
            file=str(path),
            hint=f"name it with {' or '.join(suffixes)}: {path.with_suffix(suffixes[0]).name}",
        )


def _identity(path: Path) -> Path:
    """The file a path names, for comparing paths (resolved, links followed where they exist)."""
    return Path(path).expanduser().resolve()
