"""The `quadpipe` program: the typer app, its global options, and how errors end it.

Errors in the user's input print as `file:line:col: error CODE: message` with a hint, and exit 1
without a traceback (add `--debug` to see one); a bug in quadpipe exits 3. SIGINT (Ctrl-C),
SIGTERM and SIGHUP end a run with one line saying what was written, and exit 128 + the signal's
number: 130, 143, 129.
"""

from __future__ import annotations

import os
import sys
import warnings
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, NoReturn

import typer

if TYPE_CHECKING:
    from quadpipe.core.signals import Interrupted

app = typer.Typer(
    name="quadpipe",
    help="Animate quadrupeds by physics alone and bake the motion into clips.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    rich_markup_mode=None,
    context_settings={"help_option_names": ["-h", "--help"]},
)

_state = {"debug": False}

EXIT_INPUT_ERROR = 1
EXIT_INTERNAL_ERROR = 3

INTERRUPT_FILES_SHOWN = 3
"""How many of the files written before an interruption its message names."""


def _version(value: bool) -> None:
    if value:
        from quadpipe import __version__

        typer.echo(f"quadpipe {__version__}")
        raise typer.Exit()


@app.callback()
def _main(
    debug: Annotated[bool, typer.Option("--debug", help="Show Python tracebacks on errors.")] = False,
    version: Annotated[
        bool | None, typer.Option("--version", callback=_version, is_eager=True, help="Print the version.")
    ] = None,
) -> None:
    """Animate quadrupeds by physics alone and bake the motion into clips."""
    _state["debug"] = debug
    if not debug:
        _hide_library_warnings()


def _hide_library_warnings() -> None:
    """The safety net under every fix at the source: a library warning (numpy's divide by zero,
    a deprecation) that still escapes is not shown, in this process or in the batch workers it
    starts; `--debug` shows them."""
    warnings.simplefilter("ignore")
    os.environ["PYTHONWARNINGS"] = "ignore"


def main() -> None:
    """Entry point: run the app, turning input errors and signals into clean messages and exit codes."""
    from quadpipe.core import signals
    from quadpipe.core.errors import QuadpipeError

    signals.install_handlers()
    try:
        try:
            app()
        finally:
            signals.ignore_interrupts()  # the command has ended: a later signal changes nothing
            signals.raise_pending()  # one whose exception was lost on the way
    except QuadpipeError as exc:
        if _state["debug"]:
            raise
        typer.echo(exc.format(), err=True)
        sys.exit(EXIT_INPUT_ERROR)
    except signals.Interrupted as exc:
        if _state["debug"]:
            raise
        _end_interrupted(exc)
    except Exception as exc:  # a bug in quadpipe, not in the user's input
        if _state["debug"]:
            raise
        interrupt = _interrupt_behind(exc)
        if interrupt is not None:
            _end_interrupted(interrupt)
        typer.echo(
            f"internal error: {type(exc).__name__}: {exc}\n  hint: run again with --debug for the traceback, and report it",
            err=True,
        )
        sys.exit(EXIT_INTERNAL_ERROR)


def _interrupt_behind(error: BaseException) -> Interrupted | None:
    """The signal that caused `error`, if one did: a C extension interrupted while it ran Python
    code reports it as its own error (pybind11 modules, such as MuJoCo's, fail to import with
    `ImportError: initialization failed`), the interrupt as its cause."""
    from quadpipe.core.signals import Interrupted

    seen: set[int] = set()
    cause: BaseException | None = error
    while cause is not None and id(cause) not in seen:
        if isinstance(cause, Interrupted):
            return cause
        seen.add(id(cause))
        cause = cause.__cause__ or cause.__context__
    return None


def _end_interrupted(interrupt: Interrupted) -> NoReturn:
    """End an interrupted run at once with 128 + the signal's number, after its one line.

    Everything that must be undone (staged files, workers) was undone on the way here; the
    interpreter's own teardown is skipped, so that a library interrupted half-way (a big C
    extension's import, its threads) cannot change the exit code (a bake under load once ended
    with the right line and exit code 1).
    """
    typer.echo(_interrupted(interrupt), err=True)
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(interrupt.exit_code)


def _interrupted(interrupt: Interrupted) -> str:
    """The line ending an interrupted run: the signal, and which complete files it wrote."""
    from quadpipe.core.atomic import written_files

    written = [_shown(path) for path in written_files()]
    shown = ", ".join(written[:INTERRUPT_FILES_SHOWN]) + (", ..." if len(written) > INTERRUPT_FILES_SHOWN else "")
    what = f"only complete files were written ({len(written)}: {shown})" if written else "nothing was written"
    return f"interrupted ({interrupt.name}): {what}"


def _shown(path: Path) -> str:
    """A path as the user would write it: relative to the working folder when it is inside it."""
    return str(path.relative_to(Path.cwd())) if path.is_absolute() and path.is_relative_to(Path.cwd()) else str(path)
