"""Commands that check files or describe their formats: validate, schema."""

from __future__ import annotations

import json
from enum import Enum
from typing import Annotated

import typer


class ValidateFormat(str, Enum):
    """Report formats of `validate`."""

    text = "text"
    json = "json"
    github = "github"


class SchemaKind(str, Enum):
    """Files that have a JSON Schema."""

    controller = "controller"
    scene = "scene"
    direction = "direction"


def validate(
    files: Annotated[
        list[str], typer.Argument(help="Controller files, folders of them, or built-in controller names.")
    ],
    fmt: Annotated[
        ValidateFormat, typer.Option("--format", help="text, json, or github (annotations for CI).")
    ] = ValidateFormat.text,
) -> None:
    """Check controller files: syntax, schema, roles, units and references. Exit 1 on any error.

    Example: quadpipe validate configs/controllers/ --format github
    """
    from quadpipe.controllers.language import validate_files

    report, code = validate_files(files, fmt.value)
    if report:
        typer.echo(report)
    raise typer.Exit(code)


def schema(kind: Annotated[SchemaKind, typer.Argument(help="Which file format.")]) -> None:
    """Print the JSON Schema of a file format, for editors (yaml-language-server) and CI.

    Example: quadpipe schema controller > controller.schema.json
    """
    if kind is SchemaKind.controller:
        from quadpipe.controllers.language import controller_json_schema

        typer.echo(json.dumps(controller_json_schema(), indent=2))
    elif kind is SchemaKind.direction:
        from quadpipe.world.schema import direction_json_schema

        typer.echo(json.dumps(direction_json_schema(), indent=2))
    else:
        from quadpipe.world import scene_json_schema

        typer.echo(json.dumps(scene_json_schema(), indent=2))
