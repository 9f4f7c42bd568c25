"""Generated documentation of the controller language: JSON Schema and markdown reference.

Both come from the pydantic models of `schema.py` and the tables of `units.py`,
`expressions.py`, `validate.py`, so they cannot drift from the code; tests check that the
committed `schemas/controller.schema.json` and the reference part of `docs/controllers.md`
match what this module produces. Regenerate both with

    python -m quadpipe.controllers.language.generate
"""

from __future__ import annotations

import json
import typing
from pathlib import Path
from typing import Any

import pydantic

from quadpipe.anatomy import roles
from quadpipe.controllers.language.loader import unwrap_annotation
from quadpipe.controllers.language.marked import field_markers
from quadpipe.controllers.language.parameters import SENSOR_TYPES
from quadpipe.controllers.language.schema import (
    ELEMENT_TYPE_NAMES,
    ELEMENT_TYPES,
    SENSOR_KINDS,
    BodyPoint,
    ControllerFile,
    Direction,
    Elastic,
    ElementNames,
    FrameName,
    LegSet,
    Parameter,
    PointMap,
    Quantity,
    RoleGlobs,
    State,
    Strength,
    Transition,
    Tunable,
)
from quadpipe.controllers.language.templates import BUILTIN_GROUPS
from quadpipe.controllers.language.validate import ISSUE_CODES
from quadpipe.core.yamlio import JSON_SCHEMA_DIALECT
from quadpipe.quantities.expressions import (
    CONSTANTS,
    FUNCTIONS,
    LEG_LANDMARKS,
    LEG_REST_LENGTH,
    LOCAL_HELP,
    POINT_ANCHORS,
    TIME_VARIABLE,
)
from quadpipe.quantities.units import UNITS, dimension_name

SCHEMA_PATH = Path("schemas") / "controller.schema.json"
"""Where the JSON Schema is committed, relative to the repository root."""

DOCS_PATH = Path("docs") / "controllers.md"
"""The controller guide, whose reference part is generated."""

BEGIN_MARKER = "<!-- BEGIN GENERATED REFERENCE (python -m quadpipe.controllers.language.generate) -->"
END_MARKER = "<!-- END GENERATED REFERENCE -->"

PARTS: tuple[type[pydantic.BaseModel], ...] = (Direction, Strength, Elastic, Tunable, Parameter, State, Transition)
"""Nested mappings documented after the elements."""


def controller_json_schema() -> dict[str, Any]:
    """The JSON Schema of controller files, for editors (yaml-language-server) and CI."""
    schema = ControllerFile.model_json_schema(by_alias=True)
    return {
        "$schema": JSON_SCHEMA_DIALECT,
        "title": "quadpipe controller",
        **{k: v for k, v in schema.items() if k != "title"},
    }


def json_schema_text() -> str:
    """The JSON Schema as the committed file's text."""
    return json.dumps(controller_json_schema(), indent=2, ensure_ascii=False) + "\n"


# --------------------------------------------------------------------------- markdown


def _marker_text(marker: Any) -> str | None:
    if isinstance(marker, Quantity):
        return marker.expect.label
    return {
        BodyPoint: "body point",
        RoleGlobs: "role(s) or glob(s)",
        LegSet: "leg(s) or group(s)",
        FrameName: "frame",
        ElementNames: "element name(s) or glob(s)",
    }.get(type(marker)) or (f"body point → {marker.expect.label}" if isinstance(marker, PointMap) else None)


def _type_text(annotation: Any) -> str:
    texts = []
    for candidate in unwrap_annotation(annotation):
        if candidate is type(None):
            continue
        origin = typing.get_origin(candidate)
        if isinstance(candidate, type) and issubclass(candidate, pydantic.BaseModel):
            texts.append(f"[{candidate.__name__}](#{candidate.__name__.lower()})")
        elif origin is typing.Literal:
            texts.append(" \\| ".join(f"`{arg}`" for arg in typing.get_args(candidate)))
        elif origin is list:
            item = typing.get_args(candidate)[0]
            texts.append("name(s)" if item is str else f"list of {_type_text(item)}")
        elif origin is dict:
            item = typing.get_args(candidate)[1]
            texts.append("name → keys" if typing.get_origin(item) is dict else f"name → {_type_text(item)}")
        else:
            texts.append({bool: "true/false", str: "text", int: "integer"}.get(candidate, "value"))
    return " or ".join(dict.fromkeys(texts))


def _default_text(info: Any) -> str:
    if info.is_required():
        return "required"
    default = info.default
    if default is None:
        return "—"
    if isinstance(default, bool):
        return f"`{str(default).lower()}`"
    if default == "":
        return '`""`'
    if isinstance(default, (list, dict)) and not default:
        return "`[]`" if isinstance(default, list) else "`{}`"
    return f"`{default}`"


def _escape(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def model_table(model: type[pydantic.BaseModel]) -> str:
    """A markdown table of a model's keys: key, value, default, description."""
    rows = ["| key | value | default | description |", "|---|---|---|---|"]
    for name, info in model.model_fields.items():
        markers = [text for text in (_marker_text(m) for m in field_markers(info)) if text]
        value = markers[0] if markers else _type_text(info.annotation)
        rows.append(f"| `{info.alias or name}` | {value} | {_default_text(info)} | {_escape(info.description or '')} |")
    return "\n".join(rows) + "\n"


def _section(title: str, body: str) -> str:
    return f"### {title}\n\n{body}\n"


def _docstring(model: type) -> str:
    """A model's docstring, stripped: the reference's text for it."""
    assert model.__doc__ is not None, f"{model.__name__} needs a docstring for the reference"
    return model.__doc__.strip()


def _elements_section() -> str:
    parts = []
    for model, type_name in zip(ELEMENT_TYPES, ELEMENT_TYPE_NAMES):
        parts.append(f"#### `{type_name}`\n\n{_docstring(model)}\n\n{model_table(model)}")
    return "### Elements\n\nEvery element has a `type` and a unique `name`.\n\n" + "\n".join(parts)


def _parts_section() -> str:
    parts = [f"#### {model.__name__}\n\n{_docstring(model)}\n\n{model_table(model)}" for model in PARTS]
    return "### Parts\n\n" + "\n".join(parts)


def _sensor_table() -> str:
    rows = ["| kind | value in expressions | measures |", "|---|---|---|"]
    rows += [f"| `{kind}` | {SENSOR_TYPES[kind].describe()} | {_escape(text)} |" for kind, text in SENSOR_KINDS.items()]
    return "\n".join(rows) + "\n"


def _units_table() -> str:
    rows = ["| unit | dimension | meaning |", "|---|---|---|"]
    rows += [f"| `{u.symbol}` | {dimension_name(u.dim)} | {_escape(u.description)} |" for u in UNITS.values()]
    return "\n".join(rows) + "\n"


def _functions_table() -> str:
    rows = ["| function | what it gives |", "|---|---|"]
    rows += [f"| `{f.signature}` | {_escape(f.description)} |" for f in FUNCTIONS.values()]
    return "\n".join(rows) + "\n"


def _names_list() -> str:
    items = [
        f"- `{TIME_VARIABLE}`: time since the controller started (a time).",
        *(f"- `{name}`: the number {value:.6g}." for name, value in CONSTANTS.items()),
        *(f"- `{name}`: {text}." for name, text in LOCAL_HELP.items()),
        "- parameter names, sensor names (their current value), unit symbols (1 of that unit).",
        "- body points (positions in the world, vectors of lengths): see below.",
        "- `v.x`, `v.y`, `v.z` (or `v[0]`...): components of a vector `v`.",
    ]
    return "\n".join(items) + "\n"


def _points_text() -> str:
    anchors = ", ".join(f"`.{a}`" for a in POINT_ANCHORS)
    rows = ["| leg point | front leg | hind leg |", "|---|---|---|"]
    rows += [
        f"| `<leg>.{mark}` | `<leg>_{by_front[True]}` | `<leg>_{by_front[False]}` |"
        for mark, by_front in LEG_LANDMARKS.items()
    ]
    return (
        f"A body point is a role with an anchor: {anchors} (its proximal joint, its far end, halfway); "
        "a bare role means `.start`. A force at a point acts on that role's bone.\n\n"
        + "\n".join(rows)
        + f"\n\n`<leg>.{LEG_REST_LENGTH}` is a length, not a point: the distance from `<leg>.top` to `<leg>.foot` "
        "in the rest pose, one per animal, known before the simulation (the `rest` of a segment between them), "
        "for parameters that ask for a share of a leg's length.\n"
    )


def _roles_text() -> str:
    axial = [role for role in roles.ROLES if roles.leg_of(role) is None]
    lines = [f"- trunk, neck, head and tail: {', '.join(f'`{r}`' for r in axial)}"]
    lines.append(f"- front legs `lf_`, `rf_` + {', '.join(f'`{b}`' for b in roles.FRONT_CHAIN)}")
    lines.append(f"- hind legs `lh_`, `rh_` + {', '.join(f'`{b}`' for b in roles.HIND_CHAIN)}")
    return "\n".join(lines) + "\n\nA bone is named after the joint at its proximal end (`lh_knee` is the tibia).\n"


def _groups_table() -> str:
    rows = ["| group | legs |", "|---|---|"]
    rows += [f"| `{name}` | {', '.join(legs)} |" for name, legs in BUILTIN_GROUPS.items()]
    return "\n".join(rows) + "\n"


def _codes_table() -> str:
    rows = ["| code | meaning |", "|---|---|"]
    rows += [f"| `{code}` | {_escape(text)} |" for code, text in ISSUE_CODES.items()]
    return "\n".join(rows) + "\n"


def reference_markdown() -> str:
    """The generated reference part of docs/controllers.md (without the markers)."""
    return "\n".join(
        [
            "## Reference\n",
            _section("File keys", f"{_docstring(ControllerFile)}\n\n{model_table(ControllerFile)}"),
            _elements_section(),
            _parts_section(),
            _section("Sensor kinds", _sensor_table()),
            _section("Units", _units_table()),
            _section("Functions", _functions_table()),
            _section("Names in expressions", _names_list()),
            _section("Body points", _points_text()),
            _section("Roles", _roles_text()),
            _section("Leg groups", _groups_table()),
            _section("Issue codes", _codes_table()),
        ]
    )


def render_docs(text: str) -> str:
    """`text` with the part between the reference markers regenerated.

    Raises:
        ValueError: the markers are missing.
    """
    if BEGIN_MARKER not in text or END_MARKER not in text:
        raise ValueError(f"the markers {BEGIN_MARKER!r} and {END_MARKER!r} are missing")
    head, rest = text.split(BEGIN_MARKER, 1)
    _, tail = rest.split(END_MARKER, 1)
    return f"{head}{BEGIN_MARKER}\n\n{reference_markdown()}\n{END_MARKER}{tail}"


def write_generated(root: Path) -> list[Path]:
    """Rewrite the JSON Schema and the docs' reference part under a repository root."""
    schema_file, docs_file = root / SCHEMA_PATH, root / DOCS_PATH
    schema_file.parent.mkdir(parents=True, exist_ok=True)
    schema_file.write_text(json_schema_text(), encoding="utf-8")
    docs_file.write_text(render_docs(docs_file.read_text(encoding="utf-8")), encoding="utf-8")
    return [schema_file, docs_file]
