"""Atomic file output: a failed or interrupted run never leaves a half-written file, nor half of
its set of files.

Every file quadpipe writes is first written as a hidden temporary file beside its target
(`.<name>.tmp-<pid>-<random><suffix>`, same file system, so that a rename moves it into place
at once) and renamed onto its target when complete. Writes made inside a `transaction()` block
are all renamed together as the block ends, under `signals_deferred()`, and none of them if the
block fails or is interrupted: a bake writes every requested file or none. A write outside any
block is a transaction of its own.

A process killed outright (SIGKILL, a power cut) cannot clean up: the next transaction writing
the same target removes the temporary files that a dead process left beside it.
"""

from __future__ import annotations

import contextlib
import glob
import os
import re
import tempfile
from collections.abc import Iterable, Iterator
from contextvars import ContextVar
from pathlib import Path
from typing import IO

from quadpipe.core.errors import QuadpipeError
from quadpipe.core.signals import raise_pending, signals_deferred

_STAGED = re.compile(r"\.tmp-(\d+)-\w+(\.\w+)?$")
"""The end of a staged file's name: the writing process's id, mkstemp's random letters, a suffix."""


class Transaction:
    """Files staged beside their targets, all renamed into place by `commit`, or all removed."""

    def __init__(self) -> None:
        self._staged: dict[Path, Path] = {}
        """target -> its staged temporary file."""

    def stage(self, path: str | Path, suffix: str = ".part") -> Path:
        """A fresh, empty temporary file beside `path`, renamed onto it at the commit.

        `suffix` keeps the format suffix that some writers choose their format by (USD).
        Staging a target again replaces its earlier staged file.

        Raises:
            QuadpipeError: `unwritable-output`: the folder does not exist or is not writable.
        """
        path = Path(path)
        remove_stale(_folder(path) / glob.escape(path.name))
        try:
            handle, name = tempfile.mkstemp(prefix=f".{path.name}.tmp-{os.getpid()}-", suffix=suffix, dir=_folder(path))
        except OSError as exc:
            raise _unwritable(path, exc.strerror or str(exc), "check that the folder exists and is writable") from None
        os.close(handle)
        os.chmod(name, _new_file_mode())
        self.drop(path)
        self._staged[path] = Path(name)
        return Path(name)

    def drop(self, path: str | Path) -> None:
        """Forget `path`'s staged file, and remove it."""
        staged = self._staged.pop(Path(path), None)
        if staged is not None:
            staged.unlink(missing_ok=True)

    def commit(self) -> list[Path]:
        """Rename every staged file onto its target, signals held back meanwhile; return the targets.

        Raises:
            QuadpipeError: `unwritable-output`: a target has become a folder (checked before
                any rename), or a rename failed (the staged files left are removed).
        """
        raise_pending()
        with signals_deferred():
            for target in self._staged:
                if target.is_dir():
                    raise _unwritable(target, "it is a folder", "remove the folder or choose another output path")
            written = []
            for target, staged in list(self._staged.items()):
                try:
                    os.replace(staged, target)
                except OSError as exc:
                    raise _unwritable(
                        target, exc.strerror or str(exc), "check that the disk is not full and the folder writable"
                    ) from None
                del self._staged[target]
                written.append(target)
            note_written(written)
            return written

    def discard(self) -> None:
        """Remove every staged file."""
        for target in list(self._staged):
            self.drop(target)


_current: ContextVar[Transaction | None] = ContextVar("quadpipe_transaction", default=None)

_written: dict[Path, None] = {}
"""Every file written so far, in order (see `note_written`)."""


@contextlib.contextmanager
def transaction() -> Iterator[Transaction]:
    """Stage every write made in the block; rename them all into place when it ends, or remove
    them all if it raises (an error, Ctrl-C, SIGTERM).

    A block inside another joins it: the outermost block commits.

    Raises:
        QuadpipeError: `unwritable-output` from the commit.
    """
    running = _current.get()
    if running is not None:
        yield running
        return
    started = Transaction()
    token = _current.set(started)
    try:
        yield started
        started.commit()
    finally:
        _current.reset(token)
        started.discard()


@contextlib.contextmanager
def atomic_path(path: str | Path, suffix: str = ".part") -> Iterator[Path]:
    """A temporary path beside `path` for a writer that needs a file name (USD, video encoders);
    what the block leaves there replaces `path` when the transaction commits (at once outside one).

    `suffix` keeps the format suffix that some writers choose their format by.

    Raises:
        QuadpipeError: `unwritable-output`: the folder does not exist or is not writable.
    """
    with transaction() as running:
        staged = running.stage(path, suffix)
        try:
            yield staged
        except BaseException:
            running.drop(path)
            raise


@contextlib.contextmanager
def scratch_path(path: str | Path, suffix: str = ".part") -> Iterator[Path]:
    """A temporary path beside `path` for an intermediate file, removed when the block ends.

    Raises:
        QuadpipeError: `unwritable-output`: the folder does not exist or is not writable.
    """
    scratch = Transaction()
    try:
        yield scratch.stage(path, suffix)
    finally:
        scratch.discard()


@contextlib.contextmanager
def atomic_output(path: str | Path, mode: str = "wb") -> Iterator[IO]:
    """Open a temporary file beside `path`; it replaces `path` when the transaction commits.

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


def note_written(paths: Iterable[Path]) -> None:
    """Add complete files to what this run has written: files this process renamed into place,
    and those its worker processes did (for the message after an interruption)."""
    _written.update(dict.fromkeys(paths))


def written_files() -> list[Path]:
    """Every complete file this run has written so far, in order."""
    return list(_written)


def remove_stale(path: str | Path) -> None:
    """Remove the temporary files beside `path` that a process no longer running left there.

    `path`'s name may be a glob pattern (`folder/dog_walk_flat.*`: every file of a batch job).
    """
    path = Path(path)
    with contextlib.suppress(OSError):
        for leftover in _folder(path).glob(f".{path.name}.tmp-*"):
            match = _STAGED.search(leftover.name)
            if match and not _running(int(match.group(1))):
                leftover.unlink(missing_ok=True)


def _running(pid: int) -> bool:
    """Whether a process with this id runs (on this machine)."""
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # it exists, under another user
        return True
    return True


def _folder(path: Path) -> Path:
    return path.parent if str(path.parent) else Path(".")


def _unwritable(path: Path, why: str, hint: str) -> QuadpipeError:
    return QuadpipeError.single("unwritable-output", f"cannot write {str(path)!r}: {why}", file=str(path), hint=hint)


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
    folder = _folder(path)
    if path.is_dir() or not folder.is_dir() or not os.access(folder, os.W_OK):
        problem = "is a folder" if path.is_dir() else "is in a folder that does not exist or is not writable"
        raise QuadpipeError.single(
            "unwritable-output", f"{str(path)!r} {problem}", file=str(path), hint="check the output path"
        )
