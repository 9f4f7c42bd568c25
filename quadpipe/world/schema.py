"""The JSON Schemas of scene files, `schemas/scene.schema.json`, and of direction files,
`schemas/direction.schema.json`, made from the formats' models.

Regenerate them with `python -m quadpipe.world.generate` (a test checks that they are current).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from quadpipe.core.yamlio import JSON_SCHEMA_DIALECT
from quadpipe.world.direction_format import DirectionFile
from quadpipe.world.format import SceneFile

SCHEMA_PATH = Path("schemas/scene.schema.json")
"""Where the scene JSON Schema is committed, relative to the repository root."""


def scene_json_schema() -> dict[str, Any]:
    """The JSON Schema of scene files, for editors (yaml-language-server) and CI."""
    model_schema = SceneFile.model_json_schema(by_alias=True)
    return {
        "$schema": JSON_SCHEMA_DIALECT,
        "title": "quadpipe scene",
        **{k: v for k, v in model_schema.items() if k != "title"},
    }


def json_schema_text() -> str:
    """The JSON Schema as the committed file's text."""
    return json.dumps(scene_json_schema(), indent=2, ensure_ascii=False) + "\n"


def write_schema(root: Path) -> Path:
    """Rewrite `schemas/scene.schema.json` under a repository root; returns its path."""
    path = root / SCHEMA_PATH
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json_schema_text(), encoding="utf-8")
    return path


DIRECTION_SCHEMA_PATH = Path("schemas/direction.schema.json")
"""Where the direction-file JSON Schema is committed, relative to the repository root."""


def direction_json_schema() -> dict[str, Any]:
    """The JSON Schema of direction files (`--direction FILE`, docs/direction.md)."""
    model_schema = DirectionFile.model_json_schema(by_alias=True)
    return {
        "$schema": JSON_SCHEMA_DIALECT,
        "title": "quadpipe direction",
        **{k: v for k, v in model_schema.items() if k != "title"},
    }


def direction_schema_text() -> str:
    """The direction JSON Schema as the committed file's text."""
    return json.dumps(direction_json_schema(), indent=2, ensure_ascii=False) + "\n"


def write_direction_schema(root: Path) -> Path:
    """Rewrite `schemas/direction.schema.json` under a repository root; returns its path."""
    path = root / DIRECTION_SCHEMA_PATH
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(direction_schema_text(), encoding="utf-8")
    return path
