"""The thesis's skeleton exchange format: one XML element per joint (see docs/formats.md).

    <skeleton name="dog" units="cm" up="y" version="1">
      <joint name="pelvis" role="pelvis" position="0 65.56 0" axis="1 0 0"/>
      <joint name="spine0" role="spine0" parent="pelvis" position="0 66.8 6.1" axis="1 0 0"/>
      ...
      <joint name="head" role="head" parent="neck4" position="..." axis="..." end="0 60 90"/>
    </skeleton>

Positions are world-space rest positions, `axis` the joint's main rotation axis (the twist
axis of the limits table), `end` the far end of a leaf bone.
"""

from __future__ import annotations

from pathlib import Path
from typing import NoReturn
from xml.parsers import expat

from quadpipe.anatomy.skeleton import UNIT_TO_METRES, UP_AXES, JointRecord, RawSkeleton
from quadpipe.core import limits
from quadpipe.core.errors import Location, QuadpipeError, did_you_mean
from quadpipe.core.textfiles import read_text

FORMAT_VERSION = "1"
JOINT_ATTRIBUTES = {"name", "parent", "role", "position", "axis", "end"}
SKELETON_ATTRIBUTES = {"name", "units", "up", "version"}


def read_skeleton(path: str | Path) -> RawSkeleton:
    """Read a quadpipe skeleton XML file.

    Raises:
        QuadpipeError: malformed XML, unknown elements or attributes, bad numbers.
    """
    path = Path(path)
    source = str(path)
    elements: list[tuple[str, dict[str, str], int, int]] = []
    parser = expat.ParserCreate()
    parser.StartElementHandler = lambda tag, attrs: elements.append(
        (tag, attrs, parser.CurrentLineNumber, parser.CurrentColumnNumber + 1)
    )
    text = read_text(path, limits.MAX_SKELETON_FILE_BYTES)
    try:
        parser.Parse(text, True)
    except expat.ExpatError as exc:
        raise QuadpipeError.single(
            "malformed-xml",
            f"not well-formed XML: {expat.ErrorString(exc.code)}",
            file=source,
            line=exc.lineno,
            column=exc.offset + 1,
            hint="check the tags and quotes around this place",
        ) from None

    root_tag, root_attrs, line, column = elements[0]
    if root_tag != "skeleton":
        _fail(source, line, column, "bad-element", f"the root element is <{root_tag}>, expected <skeleton>")
    _check_attributes(source, root_tag, root_attrs, SKELETON_ATTRIBUTES, line, column)
    units = root_attrs.get("units", "cm")
    up = root_attrs.get("up", "y")
    if units not in UNIT_TO_METRES:
        _fail(source, line, column, "bad-units", f"units {units!r} unknown", f"use one of {', '.join(UNIT_TO_METRES)}")
    if up not in UP_AXES:
        _fail(source, line, column, "bad-up-axis", f"up axis {up!r} unknown", "use 'y' or 'z'")

    if len(elements) > limits.MAX_JOINTS.value + 1:
        _, _, line, column = elements[int(limits.MAX_JOINTS.value) + 1]
        raise limits.MAX_JOINTS.exceeded(len(elements) - 1, where=Location(source, line, column))
    joints = []
    for tag, attrs, line, column in elements[1:]:
        if tag != "joint":
            _fail(
                source,
                line,
                column,
                "bad-element",
                f"unexpected element <{tag}>",
                "a skeleton holds <joint> elements only",
            )
        _check_attributes(source, tag, attrs, JOINT_ATTRIBUTES, line, column)
        for required in ("name", "position"):
            if required not in attrs:
                _fail(source, line, column, "missing-attribute", f"<joint> without a {required!r} attribute")
        joints.append(
            JointRecord(
                name=attrs["name"],
                parent=attrs.get("parent") or None,
                position=_vector(source, line, column, attrs, "position"),
                axis=_vector(source, line, column, attrs, "axis") if "axis" in attrs else None,
                end=_vector(source, line, column, attrs, "end") if "end" in attrs else None,
                role=attrs.get("role") or None,
                line=line,
                column=column,
            )
        )
    name = root_attrs.get("name") or path.name.split(".")[0]
    return RawSkeleton(name=name, source=source, joints=tuple(joints), units=units, up=up)


def _vector(source: str, line: int, column: int, attrs: dict[str, str], key: str) -> tuple[float, float, float]:
    text = attrs[key]
    try:
        values = tuple(float(v) for v in text.replace(",", " ").split())
    except ValueError:
        values = ()
    if len(values) != 3 or any(v != v for v in values):
        _fail(source, line, column, "bad-vector", f"{key}={text!r} is not three numbers", 'write it as "x y z"')
    x, y, z = values
    return x, y, z


def _check_attributes(source: str, tag: str, attrs: dict[str, str], allowed: set[str], line: int, column: int) -> None:
    for key in attrs:
        if key not in allowed:
            _fail(
                source,
                line,
                column,
                "unknown-attribute",
                f"<{tag}> has no attribute {key!r}",
                did_you_mean(key, allowed),
            )


def _fail(source: str, line: int, column: int, code: str, message: str, hint: str | None = None) -> NoReturn:
    raise QuadpipeError.single(code, message, file=source, line=line, column=column, hint=hint)
