"""Atomic file output: a failed or interrupted run never leaves a half-written file."""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import IO

from quadpipe.core.errors import QuadpipeError


@contextlib.contextmanager
def atomic_path(path: str | Path, suffix: str = ".part") -> Iterator[Path]:
    """A fresh temporary path beside `path`, for writers that need a file name (USD).

    Whatever is left at that path when the block ends is removed; the caller renames it onto
    `path` (with `os.replace`) when, and only when, it is complete. `suffix` keeps the format
    suffix that some writers choose their format by.

    Raises:
        QuadpipeError: the folder does not exist or is not writable.
    """
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    try:
        handle, temp_name = tempfile.mkstemp(prefix=f".{path.name}.tmp-", suffix=suffix, dir=folder)
    except OSError as exc:
        raise QuadpipeError.single(
            "unwritable-output",
            f"cannot write {str(path)!r}: {exc.strerror}",
            file=str(path),
            hint="check that the folder exists and is writable",
        ) from None
    os.close(handle)
    os.chmod(temp_name, _new_file_mode())
    try:
        yield Path(temp_name)
    finally:
        Path(temp_name).unlink(missing_ok=True)


@contextlib.contextmanager
def atomic_output(path: str | Path, mode: str = "wb") -> Iterator[IO]:
    """Open a temporary file beside `path`; on success it replaces `path` in one rename.

    Args:
        path: the final file.
        mode: `"wb"` or `"w"` (text, UTF-8).

    Raises:
        QuadpipeError: the folder does not exist or is not writable.
    """
    with atomic_path(path) as temporary:
        encoding = None if "b" in mode else "utf-8"
        with open(temporary, mode, encoding=encoding) as stream:
            yield stream
            stream.flush()
            os.fsync(stream.fileno())
        os.replace(temporary, path)


def _new_file_mode() -> int:
    """The permissions `open()` gives a new file under the current umask (mkstemp's are 0600)."""
    umask = os.umask(0)
    os.umask(umask)
    return 0o666 & ~umask


def write_text(path: str | Path, text: str) -> None:
    """Write a text file atomically (UTF-8)."""
    with atomic_output(path, "w") as stream:
        stream.write(text)


def write_bytes(path: str | Path, data: bytes) -> None:
    """Write a binary file atomically."""
    with atomic_output(path, "wb") as stream:
        stream.write(data)


def check_writable(path: str | Path) -> None:
    """Fail early, before a long simulation, if a file cannot be written at `path`.

    Raises:
        QuadpipeError: `unwritable-output`: a folder, or a file in a folder that does not
            exist or is not writable.
    """
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    if path.is_dir() or not folder.is_dir() or not os.access(folder, os.W_OK):
        problem = "is a folder" if path.is_dir() else "is in a folder that does not exist or is not writable"
        raise QuadpipeError.single(
            "unwritable-output", f"{str(path)!r} {problem}", file=str(path), hint="check the output path"
        )
