"""The `quadpipe` program: the typer app, its global options, and how errors end it.

Errors in the user's input print as `file:line:col: error CODE: message` with a hint, and exit 1
without a traceback (add `--debug` to see one); a bug in quadpipe exits 3, Ctrl-C 130.
"""

from __future__ import annotations

import os
import sys
import warnings
from typing import Annotated

import typer

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
EXIT_INTERRUPTED = 130


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
    """Entry point: run the app, turning input errors into clean messages and exit codes."""
    from quadpipe.core.errors import QuadpipeError

    try:
        app()
    except QuadpipeError as exc:
        if _state["debug"]:
            raise
        typer.echo(exc.format(), err=True)
        sys.exit(EXIT_INPUT_ERROR)
    except KeyboardInterrupt:
        if _state["debug"]:
            raise
        typer.echo("interrupted", err=True)
        sys.exit(EXIT_INTERRUPTED)
    except Exception as exc:  # a bug in quadpipe, not in the user's input
        if _state["debug"]:
            raise
        typer.echo(
            f"internal error: {type(exc).__name__}: {exc}\n  hint: run again with --debug for the traceback, and report it",
            err=True,
        )
        sys.exit(EXIT_INTERNAL_ERROR)
