"""The JSON Schemas of scene files, `schemas/scene.schema.json`, and of direction files,
`schemas/direction.schema.json`, made from the formats' models.

Regenerate them with `python -m quadpipe.world.generate` (a test checks that they are current).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from pydantic import BaseModel

from quadpipe.core.yamlio import JSON_SCHEMA_DIALECT
from quadpipe.world.direction_format import DirectionFile
from quadpipe.world.format import SceneFile

SCHEMA_PATH = Path("schemas/scene.schema.json")
"""Where the scene JSON Schema is committed, relative to the repository root."""


def scene_json_schema() -> dict[str, Any]:
    """The JSON Schema of scene files, for editors (yaml-language-server) and CI."""
    return _json_schema(SceneFile, "quadpipe scene")


def json_schema_text() -> str:
    """The JSON Schema as the committed file's text."""
    return _schema_text(scene_json_schema())


def write_schema(root: Path) -> Path:
    """Rewrite `schemas/scene.schema.json` under a repository root; returns its path."""
    return _write(root / SCHEMA_PATH, json_schema_text())


DIRECTION_SCHEMA_PATH = Path("schemas/direction.schema.json")
"""Where the direction-file JSON Schema is committed, relative to the repository root."""


def direction_json_schema() -> dict[str, Any]:
    """The JSON Schema of direction files (`--direction FILE`, docs/direction.md)."""
    return _json_schema(DirectionFile, "quadpipe direction")


def direction_schema_text() -> str:
    """The direction JSON Schema as the committed file's text."""
    return _schema_text(direction_json_schema())


def write_direction_schema(root: Path) -> Path:
    """Rewrite `schemas/direction.schema.json` under a repository root; returns its path."""
    return _write(root / DIRECTION_SCHEMA_PATH, direction_schema_text())


def _json_schema(model: type[BaseModel], title: str) -> dict[str, Any]:
    """A pydantic model's JSON Schema under the dialect editors read, with our title."""
    model_schema = model.model_json_schema(by_alias=True)
    return {"$schema": JSON_SCHEMA_DIALECT, "title": title, **{k: v for k, v in model_schema.items() if k != "title"}}


def _schema_text(schema: dict[str, Any]) -> str:
    """A JSON Schema as a committed file's text."""
    return json.dumps(schema, indent=2, ensure_ascii=False) + "\n"


def _write(path: Path, text: str) -> Path:
    """Write `text` to `path`, making its folder; returns the path."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text, encoding="utf-8")
    return path
