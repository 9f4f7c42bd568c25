"""Signals that end a run: SIGINT (Ctrl-C), SIGTERM and SIGHUP all become `Interrupted`.

The CLI installs `install_handlers()` first thing, so that a `kill` or a closed terminal unwinds
the program like Ctrl-C does: staged outputs are removed, worker processes stopped, and the run
ends with one line and exit code 128 + the signal's number (130, 143, 129). Code that must not
be cut in the middle (renaming a set of finished files into place; C++ libraries that cannot
carry a Python exception through their own frames, as OpenUSD's `pxr`) runs under
`signals_deferred()`: a signal arriving meanwhile is delivered when the block ends.
"""

from __future__ import annotations

import contextlib
import signal
import sys
import threading
from collections.abc import Iterator
from types import FrameType
from typing import Any

INTERRUPTS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
"""The signals that interrupt a run."""

EXIT_BASE = 128
"""A run ended by signal N exits with 128 + N, as a shell reports a process killed by it."""


class Interrupted(BaseException):
    """A run interrupted by a signal.

    Like `KeyboardInterrupt` it is no `Exception`, so that no `except Exception` swallows it;
    unlike it, click and typer let it through (they turn a `KeyboardInterrupt` into exit 130,
    whatever the signal).

    Attributes:
        signum: the signal's number.
    """

    def __init__(self, signum: int) -> None:
        super().__init__(signal.Signals(signum).name)
        self.signum = signum

    @property
    def name(self) -> str:
        """The signal's name: `SIGTERM`."""
        return signal.Signals(self.signum).name

    @property
    def exit_code(self) -> int:
        """The exit code of a run it ends: 128 + the signal's number."""
        return EXIT_BASE + self.signum


_received: list[int] = []
"""The signals `install_handlers`' handler has raised, first first."""


def _raise_interrupted(signum: int, _frame: FrameType | None) -> None:
    _received.append(signum)
    raise Interrupted(signum)


def install_handlers() -> None:
    """Make SIGINT, SIGTERM and SIGHUP raise `Interrupted` in the main thread.

    A handler's exception raised where Python cannot propagate it (a weakref callback of the
    import system, a `__del__`) is lost: such a lost interrupt is kept quiet here and raised
    again by `raise_pending`. A signal the process was started ignoring (`nohup`, a background
    job of a script) stays ignored.
    """
    for signum in INTERRUPTS:
        if signal.getsignal(signum) is not signal.SIG_IGN:
            signal.signal(signum, _raise_interrupted)
    previous_hook = sys.unraisablehook

    def quiet_interrupts(unraisable: Any) -> None:
        if not isinstance(unraisable.exc_value, Interrupted):
            previous_hook(unraisable)

    sys.unraisablehook = quiet_interrupts


def raise_pending() -> None:
    """Raise `Interrupted` if a signal has come since `install_handlers` (its first exception
    may have been lost: see there); at the points that must not be passed once interrupted."""
    if _received:
        raise Interrupted(_received[0])


def ignore_interrupts() -> None:
    """Ignore SIGINT, SIGTERM and SIGHUP from now on: for a run whose work is over, and for
    worker processes, which their parent stops."""
    for signum in INTERRUPTS:
        signal.signal(signum, signal.SIG_IGN)


class _Recorder:
    """A stand-in handler that only notes which signals came."""

    def __init__(self) -> None:
        self.received: list[int] = []

    def __call__(self, signum: int, _frame: FrameType | None) -> None:
        self.received.append(signum)


@contextlib.contextmanager
def signals_deferred() -> Iterator[None]:
    """Hold SIGINT, SIGTERM and SIGHUP back while the block runs; the first that came meanwhile
    is delivered to its handler (raising, for `Interrupted`) as the block ends.

    The handlers are swapped for one that only takes note, so that no exception is raised
    inside the block, whichever thread the signal reached. Only the main thread can swap
    handlers; elsewhere the block runs as it is (signals interrupt only the main thread).
    """
    if threading.current_thread() is not threading.main_thread() or isinstance(
        signal.getsignal(signal.SIGINT), _Recorder
    ):
        yield
        return
    recorder = _Recorder()
    previous = {signum: signal.signal(signum, recorder) for signum in INTERRUPTS}
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, signal.SIG_DFL if handler is None else handler)
        if recorder.received:
            first = signal.Signals(recorder.received[0])
            _deliver(first, previous[first])


def _deliver(signum: int, handler: object) -> None:
    """Hand a held-back signal to the handler it would have reached."""
    if callable(handler):
        handler(signum, None)
    elif handler == signal.SIG_DFL:
        signal.raise_signal(signum)
