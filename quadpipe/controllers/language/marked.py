"""Finding the fields to check: the markers of `schema.py` inside the pydantic models.

A field whose `Annotated` type carries a marker (`Quantity(...)`, `BodyPoint()`, ...) is
found by `iter_marked`, so a new field with a marker is checked and compiled without
touching the checks.
"""

from __future__ import annotations

import types
import typing
from collections.abc import Iterator
from typing import Any

import pydantic

from quadpipe.controllers.language import schema

MARKERS = (
    schema.Quantity,
    schema.BodyPoint,
    schema.PointMap,
    schema.RoleGlobs,
    schema.LegSet,
    schema.FrameName,
    schema.ElementNames,
)
"""The marker types the checks and the compiler look for."""


def _markers_in(annotation: Any) -> list[Any]:
    found = []
    if hasattr(annotation, "__metadata__"):
        found += [m for m in annotation.__metadata__ if isinstance(m, MARKERS)]
        annotation = typing.get_args(annotation)[0]
    if typing.get_origin(annotation) in (typing.Union, types.UnionType):
        for arm in typing.get_args(annotation):
            found += _markers_in(arm)
    return found


def field_markers(info: Any) -> list[Any]:
    """The markers of a pydantic field (on the field itself or inside its union arms)."""
    return [m for m in info.metadata if isinstance(m, MARKERS)] + _markers_in(info.annotation)


def iter_marked(model: pydantic.BaseModel, path: tuple[Any, ...] = ()) -> Iterator[tuple[tuple[Any, ...], Any, Any]]:
    """Every marked field value inside a model, as (key path, value, marker); None values skipped."""
    for name, info in type(model).model_fields.items():
        value = getattr(model, name)
        if value is None:
            continue
        here = path + (info.alias or name,)
        for marker in field_markers(info):
            yield here, value, marker
        if isinstance(value, pydantic.BaseModel):
            yield from iter_marked(value, here)
        elif isinstance(value, dict):
            for key, item in value.items():
                if isinstance(item, pydantic.BaseModel):
                    yield from iter_marked(item, here + (key,))
        elif isinstance(value, list):
            for index, item in enumerate(value):
                if isinstance(item, pydantic.BaseModel):
                    yield from iter_marked(item, here + (index,))
