"""The `quadpipe` command line: thin commands over library functions.

`program` holds the typer app, its global options (`--debug`, `--version`) and the error
handling; the commands live in modules by topic, registered below in the order `quadpipe --help`
lists them:

    library   animals, roles, convert, inspect, controllers, scenes   the built-in library and skeleton files
    checks    validate, schema                                        checking files, their formats
    run       simulate, bake, batch, preview                          running simulations
    media     render, analyze, blender-script                         pictures and figures of a clip, DCC import

Every command's help ends with an example. Heavy modules (mujoco, numpy, pxr, open3d) are
imported inside the commands so that `quadpipe --help` stays instant.
"""

from __future__ import annotations

from quadpipe.cli import checks, library, media, run
from quadpipe.cli.program import app, main

COMMANDS = (
    library.animals,
    library.roles,
    library.convert,
    library.inspect,
    checks.validate,
    checks.schema,
    library.controllers,
    library.scenes,
    run.simulate,
    run.bake,
    run.batch,
    run.preview,
    media.render,
    media.analyze,
    media.blender_script,
)
"""Every command, in the order of `quadpipe --help`; each is named after its function."""

for _command in COMMANDS:
    app.command()(_command)

__all__ = ["COMMANDS", "app", "main"]
