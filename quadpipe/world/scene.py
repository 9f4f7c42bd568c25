"""Scenes: the world an animal runs in (`configs/scenes/<name>.yaml`).

A scene declares the ground, static terrain built from boxes (ramps, hills, stairs, blocks),
loose props, objects thrown at the animals at given times (one by one or as a seeded random
series), goal points for the controllers, and where each animal starts. Its numbers carry
units of the controller language (`3 HP`, `10 deg`, `0.1 bm`, `4 m/s`), so one scene works
for a rat and an elephant: in a scene `HP`, `bw` and `bm` are those of the scene's FIRST
animal. See docs/scenes.md.

Entry points:

- `load_scene(name_or_path)` -> `SceneSpec` (validated; errors point at file:line:col);
- `available_scenes()` -> the built-in scene names;
- `build_scene(scene, species)` -> `SceneSetup`: the world's `MjSpec` with the animals
  attached, their placements, the goal parameters as controller expressions, and
  `events(model)`, the callables that throw objects during the simulation;
- `scene_json_schema()` / `write_schema(root)`: `schemas/scene.schema.json`
  (regenerate with `python -m quadpipe.world.scene`).

The world follows `quadpipe.world.placement`'s conventions (a `floor` plane, a `sun`, each animal
attached under the prefix `<name>/`, collision bits: world geoms contype 1 / conaffinity 3,
bones contype 2 / conaffinity 1) and adds headings, terrain-aware start heights, props and
throws. Terrain, props and thrown objects are boxes, spheres and capsules only, the shapes a
`quadpipe.clip.model.Clip` carries.
"""

from __future__ import annotations

import json
import math
import re
import types
import typing
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any, Callable, Iterator, Literal, Sequence, Union

import mujoco
import numpy as np
import pydantic
from pydantic import BaseModel, BeforeValidator, ConfigDict, Discriminator, Field, Tag, field_validator, model_validator

from quadpipe.core import configs
from quadpipe.animals import sizing
from quadpipe.quantities.expressions import Expect, ExprError, Namespace, SCALAR, TIME_VARIABLE, VECTOR, ZERO_NORM, check_expected, compile_quantity, resolve_point_name
from quadpipe.controllers.language import schema
from quadpipe.quantities import units
from quadpipe.controllers.language.loader import field_names_at
from quadpipe.controllers.language.reference import JSON_SCHEMA_DIALECT
from quadpipe.core.errors import Issue, Location, QuadpipeError, did_you_mean
from quadpipe.animals.model import FRICTION, BuiltAnimal
from quadpipe.world.placement import (
    DROP_CLEARANCE_HP,
    WORLD_CONAFFINITY,
    WORLD_CONTYPE,
    Placement,
    add_floor,
    add_sky_and_light,
    yaw_matrix,
    yaw_quat,
)
from quadpipe.core.yamlio import YamlDocument, load_yaml, without_missing_explained_by_typos

SCHEMA_VERSION = 1
"""The only `schema:` version this quadpipe reads."""

SCHEMA_PATH = Path("schemas/scene.schema.json")
"""Where the scene JSON Schema is committed, relative to the repository root."""

SCENE_KIND = "scenes"
"""The config folder of scenes (see `quadpipe.core.configs`)."""

NAME_PATTERN = r"^[A-Za-z][A-Za-z0-9_]*$"
"""Animal and prop names: they prefix MuJoCo element names (`dog/pelvis`)."""

THROWN_PREFIX = "thrown"
"""Thrown bodies are named `thrown0`, `thrown1`, ... in declaration order (series drawn in place)."""

RESERVED_PROP_NAMES = re.compile(rf"^(world|floor|{THROWN_PREFIX}\d+|terrain\d+_\w*)$")
"""Names the scene's own elements take: a prop (body and geom of that name) cannot use them."""

# Expected kinds and dimensions of scene quantities (examples are shown in hints).
LENGTH = Expect(SCALAR, (units.LENGTH,), "length", "3 HP")
ANGLE = Expect(SCALAR, (units.ANGLE,), "angle", "10 deg")
TIME = Expect(SCALAR, (units.TIME,), "time", "3 s")
MASS = Expect(SCALAR, (units.MASS,), "mass", "0.1 bm")
SPEED = Expect(SCALAR, (units.VELOCITY,), "velocity", "4 m/s")
POINT = Expect(VECTOR, (units.LENGTH,), "point (vector of lengths)", "[20 HP, 0, 0]")
ANGLES = Expect(VECTOR, (units.ANGLE,), "vector of angles", "[0, 0, 30 deg]")
VELOCITY = Expect(VECTOR, (units.VELOCITY,), "vector of velocities", "[1 m/s, 0, 0]")

FROM_DIRECTIONS: dict[str, tuple[float, float, float]] = {
    "left": (0.0, 1.0, 0.0),
    "right": (0.0, -1.0, 0.0),
    "front": (1.0, 0.0, 0.0),
    "back": (-1.0, 0.0, 0.0),
}
"""Where a throw comes from, in the target animal's heading frame (x where it faces, y its left)."""

SHAPE_SIZES: dict[str, tuple[str, ...]] = {
    "sphere": ("radius",),
    "box": ("length (x)", "width (y)", "height (z)"),
    "capsule": ("radius", "length of the straight part"),
}
"""The `size` items of each shape, in order."""

MAX_RAMP_ANGLE_DEG = 60.0
"""Steepest ramp or hill side, degrees; steeper is a wall: use a `box`."""

RAMP_BASE_HP = 0.1
"""How far a ramp's slab reaches below the ground, in pelvis heights (no gap under its high end)."""

THROW_DISTANCE_HP = 2.0
"""Default distance a throw starts from its target, in pelvis heights of the scene."""

THROW_RANGE_FRACTION = 0.5
"""A default throw distance is at most this fraction of the farthest the speed can carry
(half of it: a 15 degree throw when level)."""

PARK_DEPTH_HP = 50.0
"""Thrown objects wait this many pelvis heights under the floor, without collisions and held
against gravity, until their throw (well inside `simulate.FAR_AWAY_HP`)."""

ANCHOR_FRACTIONS = {"start": 0.0, "mid": 0.5, "end": 1.0}
"""Where a body point lies along its bone (see `quadpipe.quantities.expressions.POINT_ANCHORS`)."""

RAY_HEIGHT_HP = 1000.0
"""Height from which the ground under an animal is found by casting rays down, in HP."""

TERRAIN_RGBA = (0.52, 0.47, 0.40, 1.0)
PROP_RGBA = (0.85, 0.30, 0.20, 1.0)
THROWN_RGBA = (0.90, 0.65, 0.15, 1.0)
"""Display colours of terrain, props and thrown objects."""



# --------------------------------------------------------------------------- markers


@dataclass(frozen=True)
class Bounds:
    """Marks a quantity whose value (in SI, once evaluated for the scene's animals) is bounded.

    Attributes:
        positive: True: it must be more than 0; False: it may also be 0.
        high: the highest value allowed, or None.
        high_text: how messages write `high`.
    """

    positive: bool = True
    high: float | None = None
    high_text: str = ""


POSITIVE = Bounds()
NON_NEGATIVE = Bounds(positive=False)
RAMP_ANGLE = Bounds(high=math.radians(MAX_RAMP_ANGLE_DEG), high_text=f"{MAX_RAMP_ANGLE_DEG:g} deg")


@dataclass(frozen=True)
class Items:
    """Marks a list field whose items are scalar quantities of the `expect`ed kind."""

    expect: Expect


@dataclass(frozen=True)
class Waypoints:
    """Marks a list of `[time, point]` pairs."""


def quantity(expect: Expect, bounds: Bounds | None = None) -> Any:
    """The type of a field holding one quantity (a number with units, or a vector of them)."""
    base = schema.quantity(expect)
    return Annotated[base, bounds] if bounds else base


def quantities(expect: Expect, count: int | tuple[int, int], bounds: Bounds | None = None) -> Any:
    """The type of a field holding a list of `count` scalar quantities (or min, max counts)."""
    low, high = (count, count) if isinstance(count, int) else count
    marks = [Items(expect), Field(min_length=low, max_length=high)] + ([bounds] if bounds else [])
    return Annotated[list[schema.Value], *marks]


def _doc(text: str, expect: Expect | None = None) -> str:
    return text if expect is None else f"{text} Expects {expect.describe()}, e.g. `{expect.example}`."


# --------------------------------------------------------------------------- file format


EULER_TEXT = "Orientation: MuJoCo's `xyz` Euler sequence (about x, then the new y, then the new z)."


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", populate_by_name=True)


class Ground(_Model):
    """The floor: an endless plane at z = 0."""

    friction: Annotated[float, Field(1.0, gt=0, description="Sliding friction of the floor and the terrain. MuJoCo lets the bones decide their contacts (so that each animal keeps its own softness), so the animals' bones take this friction too.")]


def _ground_shorthand(value: Any) -> Any:
    return None if value == "none" else value


GroundField = Annotated[Ground | None, BeforeValidator(_ground_shorthand, json_schema_input_type=Union[Ground, Literal["none"]])]


class _Strip(_Model):
    start: Annotated[quantity(LENGTH), Field(description=_doc("Where it begins along x (forward) from the origin.", LENGTH))]
    width: Annotated[quantity(LENGTH, POSITIVE), Field("8 HP", description=_doc("Its extent across (along y), centred on y = 0.", LENGTH))]


class Slope(_Strip):
    """A ramp rising along +x, then a flat top."""

    type: Annotated[Literal["slope"], Field(description="Terrain type.")]
    angle: Annotated[quantity(ANGLE, RAMP_ANGLE), Field(description=_doc(f"How steep it is (0 to {MAX_RAMP_ANGLE_DEG:g} deg).", ANGLE))]
    length: Annotated[quantity(LENGTH, POSITIVE), Field(description=_doc("Horizontal length of the ramp; it rises length x tan(angle).", LENGTH))]
    top: Annotated[quantity(LENGTH, NON_NEGATIVE), Field("2 HP", description=_doc("Length of the flat top after the ramp (0: the ramp ends in a drop).", LENGTH))]


class Hill(_Strip):
    """A ramp up, a flat top, the same ramp down."""

    type: Annotated[Literal["hill"], Field(description="Terrain type.")]
    angle: Annotated[quantity(ANGLE, RAMP_ANGLE), Field(description=_doc(f"How steep both sides are (0 to {MAX_RAMP_ANGLE_DEG:g} deg).", ANGLE))]
    height: Annotated[quantity(LENGTH, POSITIVE), Field(description=_doc("Height of the top.", LENGTH))]
    top: Annotated[quantity(LENGTH, NON_NEGATIVE), Field("2 HP", description=_doc("Length of the flat top.", LENGTH))]


class Stairs(_Strip):
    """Steps along +x: up from the ground to a landing, or down from a landing to the ground."""

    type: Annotated[Literal["stairs"], Field(description="Terrain type.")]
    step_height: Annotated[quantity(LENGTH, POSITIVE), Field(description=_doc("Rise of each step.", LENGTH))]
    step_depth: Annotated[quantity(LENGTH, POSITIVE), Field(description=_doc("Depth (tread) of each step.", LENGTH))]
    steps: Annotated[int, Field(ge=1, description="Number of steps.")]
    direction: Annotated[Literal["up", "down"], Field("up", description="`up`: the stairs climb from `start`, with the landing after them; `down`: the landing ends at `start` (an animal can start on it) and the stairs descend from there.")]
    landing: Annotated[quantity(LENGTH, NON_NEGATIVE), Field("4 HP", description=_doc("Length of the flat landing at the top.", LENGTH))]


class TerrainBox(_Model):
    """Any static block."""

    type: Annotated[Literal["box"], Field(description="Terrain type.")]
    at: Annotated[quantity(POINT), Field(description=_doc("Centre of the box, in world coordinates (x forward, y left, z up).", POINT))]
    size: Annotated[quantities(LENGTH, 3, POSITIVE), Field(description="Full length (x), width (y) and height (z), e.g. `[2 HP, 8 HP, 0.3 HP]`.")]
    euler: Annotated[quantity(ANGLES), Field([0, 0, 0], description=_doc(EULER_TEXT, ANGLES))]


TERRAIN_TYPES: dict[str, type[_Model]] = {"slope": Slope, "hill": Hill, "stairs": Stairs, "box": TerrainBox}

Terrain = Annotated[Union[Slope, Hill, Stairs, TerrainBox], Field(discriminator="type")]


def _check_size(kind: str | None, size: list[Any]) -> list[Any]:
    """A shape's `size` must have one item per dimension of its shape."""
    names = SHAPE_SIZES.get(kind or "")
    if names is not None and len(size) != len(names):
        raise ValueError(f"a {kind} has {len(names)} size item(s): {', '.join(names)}; got {len(size)}")
    return size


class Prop(_Model):
    """A loose rigid object, present from the start."""

    name: Annotated[str, Field(pattern=NAME_PATTERN, description="Unique name (the MuJoCo body's name).")]
    type: Annotated[Literal["sphere", "box", "capsule"], Field(description="Shape.")]
    at: Annotated[quantity(POINT), Field(description=_doc("Centre at the start, in world coordinates.", POINT))]
    size: Annotated[quantities(LENGTH, (1, 3), POSITIVE), Field(description="sphere: `[radius]`; box: `[length, width, height]` (full sizes); capsule: `[radius, length of the straight part]` (its axis is z before `euler`).")]
    mass: Annotated[quantity(MASS, POSITIVE), Field(description=_doc("Its mass.", MASS))]
    euler: Annotated[quantity(ANGLES), Field([0, 0, 0], description=_doc(EULER_TEXT, ANGLES))]
    velocity: Annotated[quantity(VELOCITY), Field([0, 0, 0], description=_doc("Velocity at the start.", VELOCITY))]

    @field_validator("size")
    @classmethod
    def _size_fits_type(cls, size: list[Any], info: pydantic.ValidationInfo) -> list[Any]:
        return _check_size(info.data.get("type"), size)


FromDirection = Union[Literal["left", "right", "front", "back"], Annotated[list[float], Field(min_length=3, max_length=3)]]


class _ThrowBase(_Model):
    shape: Annotated[Literal["box", "sphere", "capsule"], Field(description="Shape of the thrown object.")]
    size: Annotated[quantities(LENGTH, (1, 3), POSITIVE), Field(description="As a prop's `size`: sphere `[radius]`, box `[length, width, height]`, capsule `[radius, length]`.")]
    target: Annotated[str, Field("pelvis", description="Body point aimed at: a role (its joint), `role.start|mid|end`, or `leg.top|foot` (e.g. `thorax.mid`, `lf.foot`).")]
    animal: Annotated[int | str, Field(0, description="The animal aimed at: its index in the scene (0 is the first) or its name.")]
    distance: Annotated[quantity(LENGTH, POSITIVE) | None, Field(None, description=_doc(f"How far from the target the object appears. Default: {THROW_DISTANCE_HP:g} HP, or half the farthest the speed can carry if that is shorter.", LENGTH))]

    @field_validator("size")
    @classmethod
    def _size_fits_shape(cls, size: list[Any], info: pydantic.ValidationInfo) -> list[Any]:
        return _check_size(info.data.get("shape"), size)


def _nonzero(vector: Any) -> Any:
    if isinstance(vector, list) and not any(vector):
        raise ValueError("a direction vector cannot be [0, 0, 0]")
    return vector


class Throw(_ThrowBase):
    """One object thrown at an animal: it reaches the target point at `speed`, `at` + the flight time."""

    at: Annotated[quantity(TIME, NON_NEGATIVE), Field(description=_doc("When it is thrown (it appears, already flying).", TIME))]
    mass: Annotated[quantity(MASS, POSITIVE), Field(description=_doc("Its mass; `bm` is the first animal's body mass.", MASS))]
    speed: Annotated[quantity(SPEED, POSITIVE), Field(description=_doc("Its speed when it reaches the target (and when thrown, from the same height); `froude_speed(2.5)` scales with the animal.", SPEED))]
    from_: Annotated[FromDirection, Field("left", alias="from", description="Where it comes from, relative to where the target animal faces when it is thrown: `left`, `right`, `front`, `back`, or a vector `[forward, left, up]` pointing from the target toward the thrower.")]

    _direction_is_nonzero = field_validator("from_")(_nonzero)


class RandomThrows(_Model):
    """A seeded random series of throws: same seed, same series."""

    count: Annotated[int, Field(ge=1, description="Number of throws.")]
    seed: Annotated[int, Field(description="Random seed.")]
    start: Annotated[quantity(TIME, NON_NEGATIVE), Field("2 s", description=_doc("Time of the first throw.", TIME))]
    every: Annotated[quantity(TIME, POSITIVE), Field("2 s", description=_doc("Time between throws.", TIME))]
    mass: Annotated[quantities(MASS, 2, POSITIVE), Field(description="Range `[lowest, highest]` the masses are drawn from, uniformly, e.g. `[0.05 bm, 0.15 bm]`.")]
    speed: Annotated[quantities(SPEED, 2, POSITIVE), Field(description="Range `[lowest, highest]` the speeds are drawn from, uniformly, e.g. `[3 m/s, 5 m/s]`.")]
    from_: Annotated[list[Literal["left", "right", "front", "back"]], Field(["left", "right", "front", "back"], alias="from", min_length=1, description="Directions drawn from, uniformly.")]


class ThrowSeries(_ThrowBase):
    """Throws drawn at random (see `random`), all of one shape and size."""

    random: Annotated[RandomThrows, Field(description="The series.")]


def _throw_tag(value: Any) -> str:
    has_random = "random" in value if isinstance(value, dict) else isinstance(value, ThrowSeries)
    return "random" if has_random else "throw"


ThrowItem = Annotated[Union[Annotated[Throw, Tag("throw")], Annotated[ThrowSeries, Tag("random")]], Discriminator(_throw_tag)]


class _AnimalBase(_Model):
    species: Annotated[str | None, Field(None, description="Animal name (`configs/animals`) or config path relative to this file; default: the animal given on the command line.")]
    at: Annotated[quantities(LENGTH, 2), Field([0, 0], description="Start position on the ground `[x, y]`; the animal is lifted to stand on whatever is below it.")]
    heading: Annotated[quantity(ANGLE), Field("0 deg", description=_doc("Direction it faces, counter-clockwise from +x (90 deg faces +y, its left at the start).", ANGLE))]


class AnimalEntry(_AnimalBase):
    """One animal."""

    name: Annotated[str, Field(pattern=NAME_PATTERN, description="Unique name: its MuJoCo elements are `<name>/<role>`.")]


class Grid(_Model):
    """Animals in rows (one behind the other, along -x) and columns (side by side, along -y)."""

    rows: Annotated[int, Field(ge=1, description="Number of rows.")]
    columns: Annotated[int, Field(ge=1, description="Number of animals in a row.")]
    spacing: Annotated[quantities(LENGTH, 2, POSITIVE), Field(description="`[between rows, between columns]`, e.g. `[3 HP, 1 HP]`.")]


class AnimalGrid(_AnimalBase):
    """A grid of animals of one species: the first at `at`, then row by row."""

    grid: Annotated[Grid, Field(description="The grid's shape.")]
    name: Annotated[str, Field(pattern=NAME_PATTERN, description="Name prefix: the animals are `<name>1`, `<name>2`, ... row by row.")]


def _animal_tag(value: Any) -> str:
    has_grid = "grid" in value if isinstance(value, dict) else isinstance(value, AnimalGrid)
    return "grid" if has_grid else "animal"


AnimalItem = Annotated[Union[Annotated[AnimalEntry, Tag("animal")], Annotated[AnimalGrid, Tag("grid")]], Discriminator(_animal_tag)]


Waypoint = tuple[schema.Value, schema.quantity(POINT)]


class Goal(_Model):
    """A controller parameter set by the scene: a fixed point, or a path through timed points."""

    point: Annotated[quantity(POINT) | None, Field(None, description=_doc("A fixed point, in world coordinates.", POINT))]
    path: Annotated[list[Waypoint] | None, Waypoints(), Field(None, min_length=1, description="`[[time, point], ...]`: the goal moves in straight lines between the points, at times in increasing order, and stays at the first before its time and at the last after.")]

    @model_validator(mode="after")
    def _one_kind(self) -> "Goal":
        if (self.point is None) == (self.path is None):
            raise ValueError("give either a point or a `path`")
        return self


def _goal_shorthand(value: Any) -> Any:
    return value if isinstance(value, dict) else {"point": value}


GoalField = Annotated[Goal, BeforeValidator(_goal_shorthand, json_schema_input_type=Union[Goal, str, Annotated[list[Union[float, str]], Field(min_length=3, max_length=3)]])]


class SceneFile(_Model):
    """Schema of `configs/scenes/<name>.yaml`."""

    schema_: Annotated[int, Field(alias="schema", description=f"Format version; this quadpipe reads `{SCHEMA_VERSION}`.")]
    name: Annotated[str, Field(description="Name of the scene, as used on the command line.")]
    description: Annotated[str, Field("", description="One line for `quadpipe scenes`.")]
    ground: Annotated[GroundField, Field(default_factory=Ground, description="The floor (`{friction: 1.0}`), or `none` for no floor.")]
    terrain: Annotated[list[Terrain], Field([], description="Static terrain: `slope`, `hill`, `stairs` or `box` items.")]
    props: Annotated[list[Prop], Field([], description="Loose objects present from the start.")]
    throws: Annotated[list[ThrowItem], Field([], description="Objects thrown at animals: single throws, or `random:` series.")]
    goals: Annotated[dict[str, GoalField], Field({}, description="Controller parameters the scene sets, by name (usually `goal` or `target`): a point, or `{path: [[time, point], ...]}`.")]
    animals: Annotated[list[AnimalItem] | None, Field(None, description="Where the animals start; default: one animal (the command line's) at the origin, facing +x. `HP`, `bw` and `bm` in the whole scene are those of the first.")]


TAGGED_LISTS: dict[str, tuple[Callable[[dict[str, Any]], str | None], dict[str, type[_Model]], str]] = {
    "terrain": (lambda item: item.get("type"), TERRAIN_TYPES, "terrain"),
    "props": (lambda item: "prop", {"prop": Prop}, "prop"),
    "throws": (_throw_tag, {"throw": Throw, "random": ThrowSeries}, "throw"),
    "animals": (_animal_tag, {"animal": AnimalEntry, "grid": AnimalGrid}, "animal"),
}
"""Lists whose items are validated one by one, so that errors point inside the right item:
list key -> (item -> its type tag, tag -> model, what an item is called)."""


# --------------------------------------------------------------------------- loading


@dataclass(frozen=True)
class SceneSpec:
    """A validated scene file.

    Attributes:
        file: its content.
        doc: the parsed YAML, to point at values in errors found when building.
    """

    file: SceneFile
    doc: YamlDocument

    @property
    def name(self) -> str:
        """The scene's name."""
        return self.file.name

    @property
    def description(self) -> str:
        """Its one-line description."""
        return self.file.description

    def locate(self, path: tuple[Any, ...]) -> Location:
        """Where a value of the file is (or its nearest enclosing value)."""
        return self.doc.locate(path)


def available_scenes() -> list[str]:
    """Names of the built-in scenes."""
    return configs.available(SCENE_KIND)


def load_scene(name_or_path: str | Path) -> SceneSpec:
    """Load a built-in scene by name, or a scene file by path.

    Raises:
        QuadpipeError: unknown name (listing the valid ones), unreadable file, or every
            problem found in it, each at its file:line:col.
    """
    path = configs.find_config(SCENE_KIND, name_or_path)
    doc = load_yaml(path)
    return SceneSpec(parse_scene(doc), doc)


def parse_scene(doc: YamlDocument) -> SceneFile:
    """Validate a parsed scene document: structure, then units, then cross-references.

    Raises:
        QuadpipeError: every problem found, in file order.
    """
    if not isinstance(doc.data, dict):
        raise QuadpipeError.single("invalid-value", "a scene file must be a mapping of keys (schema, name, terrain, ...)", where=doc.locate(()))
    issues = _structure_issues(doc)
    if not issues:
        scene = SceneFile.model_validate(doc.data)
        issues = _quantity_issues(scene, doc) + _reference_issues(scene, doc)
    if issues:
        raise QuadpipeError(sorted(issues, key=_file_order))
    return scene


def _file_order(issue: Issue) -> tuple[int, int]:
    where = issue.where or Location()
    return (where.line or 0, where.column or 0)


def _structure_issues(doc: YamlDocument) -> list[Issue]:
    """Keys and value shapes: the top level, then each item of the tagged lists on its own."""
    top = {key: ([] if key in TAGGED_LISTS and isinstance(value, list) else value) for key, value in doc.data.items()}
    issues = _validate_part(SceneFile, top, (), doc)
    for key, (tag_of, models, what) in TAGGED_LISTS.items():
        items = doc.data.get(key)
        for index, item in enumerate(items if isinstance(items, list) else []):
            path = (key, index)
            if not isinstance(item, dict):
                issues.append(Issue("invalid-value", f"{what} item {index + 1} must be a mapping of keys", doc.locate(path)))
                continue
            tag = tag_of(item)
            if tag is None:
                issues.append(Issue("missing-key", f"{what} item {index + 1} has no `type`", doc.locate(path), f"valid: {', '.join(models)}"))
            elif tag not in models:
                issues.append(Issue(f"unknown-{what}-type", f"there is no {what} type {tag!r}", doc.locate(path + ("type",)), did_you_mean(str(tag), models)))
            else:
                issues += _validate_part(models[tag], item, path, doc)
    if not issues and doc.data.get("schema") != SCHEMA_VERSION:
        issues.append(Issue("unsupported-schema", f"schema version {doc.data.get('schema')!r} is not supported", doc.locate(("schema",)), f"this quadpipe reads `schema: {SCHEMA_VERSION}`"))
    return issues


def _validate_part(model: type[BaseModel], data: Any, prefix: tuple[Any, ...], doc: YamlDocument) -> list[Issue]:
    """Pydantic errors of `data` against `model`, located at `prefix` + their path in the file."""
    try:
        model.model_validate(data)
    except pydantic.ValidationError as exc:
        return [_issue(err, model, prefix, doc) for err in without_missing_explained_by_typos(exc.errors())]
    return []


def _issue(err: Any, model: type[BaseModel], prefix: tuple[Any, ...], doc: YamlDocument) -> Issue:
    """One pydantic error as a located issue, worded as `quadpipe.core.yamlio` words them."""
    loc = tuple(err["loc"])
    path = prefix + loc
    if err["type"] == "extra_forbidden":
        name = str(loc[-1])
        valid = field_names_at(model, loc[:-1])
        return Issue("unknown-key", f"{name!r} is not a valid key here", doc.locate(path, key=True), did_you_mean(name, valid) if valid else None)
    if err["type"] == "missing":
        where = ".".join(str(p) for p in path[:-1]) or "the top level"
        return Issue("missing-key", f"required key {loc[-1]!r} is missing in {where}", doc.locate(path[:-1]))
    message = err["msg"].removeprefix("Value error, ")
    return Issue("invalid-value", f"{_dotted(path)}: {message}", doc.locate(path))


def _dotted(path: tuple[Any, ...]) -> str:
    return ".".join(str(part) for part in path)


def _shown(path: tuple[Any, ...], doc: YamlDocument) -> str:
    """A value's path for messages, without the keys a shorthand leaves out of the file."""
    while path and path not in doc.value_positions:
        path = path[:-1]
    return _dotted(path)


_MARKERS = (schema.Quantity, Items, Waypoints, Bounds)


def _markers(info: Any) -> list[Any]:
    """The markers of a field, on the field itself or inside an optional type (`X | None`)."""
    found = [m for m in info.metadata if isinstance(m, _MARKERS)]
    for arm in typing.get_args(info.annotation) if typing.get_origin(info.annotation) in (Union, types.UnionType) else ():
        found += [m for m in getattr(arm, "__metadata__", ()) if isinstance(m, _MARKERS)]
    return found


def iter_quantities(model: BaseModel, path: tuple[Any, ...] = ()) -> Iterator[tuple[tuple[Any, ...], Any, Expect, Bounds | None]]:
    """Every quantity in a validated scene: (path in the file, value as written, expected kind, bounds)."""
    for name, info in type(model).model_fields.items():
        value = getattr(model, name)
        if value is None:
            continue
        here = path + (info.alias or name,)
        marks = _markers(info)
        bounds = next((m for m in marks if isinstance(m, Bounds)), None)
        for mark in marks:
            if isinstance(mark, schema.Quantity):
                yield here, value, mark.expect, bounds
            elif isinstance(mark, Items):
                yield from ((here + (i,), item, mark.expect, bounds) for i, item in enumerate(value))
            elif isinstance(mark, Waypoints):
                for i, (time, point) in enumerate(value):
                    yield here + (i, 0), time, TIME, NON_NEGATIVE
                    yield here + (i, 1), point, POINT, None
        for child_path, child in _models_in(value, here):
            yield from iter_quantities(child, child_path)


def _models_in(value: Any, path: tuple[Any, ...]) -> Iterator[tuple[tuple[Any, ...], BaseModel]]:
    """The models a field holds: itself, or the items of its list or mapping."""
    if isinstance(value, BaseModel):
        yield path, value
    elif isinstance(value, (list, dict)):
        pairs = value.items() if isinstance(value, dict) else enumerate(value)
        yield from ((path + (key,), item) for key, item in pairs if isinstance(item, BaseModel))


def _is_zero(value: Any) -> bool:
    """Plain 0 (or a vector of them) needs no unit: it is zero in every unit."""
    if isinstance(value, list):
        return all(_is_zero(item) for item in value)
    return isinstance(value, (int, float)) and not isinstance(value, bool) and value == 0


def _quantity_issues(scene: SceneFile, doc: YamlDocument) -> list[Issue]:
    """Units and dimensions of every quantity; scene values must be constants."""
    issues = []
    for path, value, expect, _ in iter_quantities(scene):
        if _is_zero(value):
            continue
        try:
            expr = check_expected(value, expect, Namespace())
        except ExprError as exc:
            issues.append(Issue(exc.code, f"{_shown(path, doc)}: {exc.message}", doc.locate(path), exc.hint))
            continue
        if expr.needs:
            issues.append(Issue("not-constant", f"{_shown(path, doc)}: a scene value must be fixed, but {value!r} reads the simulation", doc.locate(path), "`t`, body points and sensors only exist in controllers; moving goals use `path`"))
    return issues


def _reference_issues(scene: SceneFile, doc: YamlDocument) -> list[Issue]:
    """Names: unique animals and props, known species, throw targets and animals that exist."""
    issues = []
    names = animal_names(scene)
    if names == []:
        issues.append(Issue("invalid-value", "animals: the list is empty", doc.locate(("animals",)), "list at least one animal, or leave `animals` out for the default one"))
    seen: set[str] = set()
    for path, name in _named_things(scene):
        if name in seen:
            issues.append(Issue("duplicate-name", f"the name {name!r} is used twice", doc.locate(path), "give every animal and prop its own name"))
        seen.add(name)
    issues += _reserved_issues(scene, doc)
    for index, entry in enumerate(scene.animals or []):
        if entry.species is not None:
            issues += _species_issues(entry.species, ("animals", index, "species"), doc)
    for index, throw in enumerate(scene.throws):
        path = ("throws", index)
        try:
            resolve_point_name(throw.target)
        except ExprError as exc:
            issues.append(Issue(exc.code, f"{_dotted(path + ('target',))}: {exc.message}", doc.locate(path + ("target",)), exc.hint))
        if names is not None and not _animal_exists(throw.animal, names):
            issues.append(Issue("unknown-animal-ref", f"there is no animal {throw.animal!r} in this scene", doc.locate(path + ("animal",)), _animal_hint(names)))
    return issues


def _named_things(scene: SceneFile) -> Iterator[tuple[tuple[Any, ...], str]]:
    for index, entry in enumerate(scene.animals or []):
        for name in _entry_names(entry):
            yield ("animals", index, "name"), name
    for index, prop in enumerate(scene.props):
        yield ("props", index, "name"), prop.name


def _reserved_issues(scene: SceneFile, doc: YamlDocument) -> list[Issue]:
    return [
        Issue("reserved-name", f"the name {prop.name!r} is taken by the scene itself", doc.locate(("props", index, "name")), "rename the prop")
        for index, prop in enumerate(scene.props)
        if RESERVED_PROP_NAMES.match(prop.name)
    ]


def _entry_names(entry: AnimalEntry | AnimalGrid) -> list[str]:
    if isinstance(entry, AnimalGrid):
        return [f"{entry.name}{k + 1}" for k in range(entry.grid.rows * entry.grid.columns)]
    return [entry.name]


def animal_names(scene: SceneFile) -> list[str] | None:
    """The names of the scene's animals in order (grids expanded); None when it has the default one."""
    if scene.animals is None:
        return None
    return [name for entry in scene.animals for name in _entry_names(entry)]


def _animal_exists(ref: int | str, names: list[str]) -> bool:
    return 0 <= ref < len(names) if isinstance(ref, int) else ref in names


def _animal_hint(names: list[str]) -> str:
    return f"use an index from 0 to {len(names) - 1}, or a name ({', '.join(names[:10])}{', ...' if len(names) > 10 else ''})"


def _species_issues(species: str, path: tuple[Any, ...], doc: YamlDocument) -> list[Issue]:
    if _is_path(species):
        file = Path(doc.file).parent / species
        return [] if file.is_file() else [Issue("file-not-found", f"animal file {species!r} does not exist (relative to this scene)", doc.locate(path))]
    known = configs.available("animals")
    return [] if species in known else [Issue("unknown-animal", f"there is no animal named {species!r}", doc.locate(path), did_you_mean(species, known))]


def _is_path(text: str) -> bool:
    return "/" in text or text.endswith((".yaml", ".yml"))


# --------------------------------------------------------------------------- JSON Schema


def scene_json_schema() -> dict[str, Any]:
    """The JSON Schema of scene files, for editors (yaml-language-server) and CI."""
    model_schema = SceneFile.model_json_schema(by_alias=True)
    return {"$schema": JSON_SCHEMA_DIALECT, "title": "quadpipe scene", **{k: v for k, v in model_schema.items() if k != "title"}}


def json_schema_text() -> str:
    """The JSON Schema as the committed file's text."""
    return json.dumps(scene_json_schema(), indent=2, ensure_ascii=False) + "\n"


def write_schema(root: Path) -> Path:
    """Rewrite `schemas/scene.schema.json` under a repository root; returns its path."""
    path = root / SCHEMA_PATH
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json_schema_text(), encoding="utf-8")
    return path


# --------------------------------------------------------------------------- values


class Values:
    """A scene's quantities in SI, evaluated for its first animal, looked up by file path.

    Paths are those of `iter_quantities` (`("terrain", 0, "angle")`, list items by index).

    Attributes:
        scene: the scene, to locate errors.
        hp: the first animal's pelvis height, metres.

    Raises (on creation):
        QuadpipeError: a value out of its bounds (a negative size, a 70 degree ramp).
    """

    def __init__(self, scene: SceneSpec, scale: units.Scale):
        self.scene = scene
        self.hp = float(scale.hp[0])
        self._values: dict[tuple[Any, ...], Any] = {}
        issues = []
        for path, value, expect, bounds in iter_quantities(scene.file):
            resolved = _evaluate(value, expect, scale)
            self._values[path] = resolved
            problem = _out_of_bounds(resolved, bounds)
            if problem:
                issues.append(Issue("out-of-range", f"{_shown(path, scene.doc)}: {value!r} {problem}", scene.locate(path)))
        if issues:
            raise QuadpipeError(sorted(issues, key=_file_order))

    def __getitem__(self, path: tuple[Any, ...]) -> Any:
        return self._values[path]

    def get(self, path: tuple[Any, ...], default: Any = None) -> Any:
        """The value at `path`, or `default` when the file leaves it out."""
        return self._values.get(path, default)

    def items(self, path: tuple[Any, ...], count: int) -> np.ndarray:
        """The `count` scalar items of a list quantity, as an array."""
        return np.array([self._values[path + (i,)] for i in range(count)])


def _evaluate(value: Any, expect: Expect, scale: units.Scale) -> Any:
    if _is_zero(value):
        return np.zeros(3) if expect.kind == VECTOR else 0.0
    result = compile_quantity(value, scale, expect).constant[0]
    return np.array(result, dtype=float) if expect.kind == VECTOR else float(result)


def _out_of_bounds(value: Any, bounds: Bounds | None) -> str | None:
    if bounds is None:
        return None
    if value < 0 or (bounds.positive and value == 0):
        return "must be more than 0" if bounds.positive else "cannot be negative"
    if bounds.high is not None and value > bounds.high:
        return f"must be at most {bounds.high_text}"
    return None


# --------------------------------------------------------------------------- building


@dataclass(frozen=True)
class ThrowPlan:
    """One throw, resolved for the scene's animals.

    The object appears `distance` from the target point, on the side `direction` (in the
    target animal's heading frame at the throw time), already moving at `launch_velocity`
    (heading frame), and reaches the point `flight_time` later at `speed`, gravity included.

    Attributes:
        body: the thrown body's name (`thrown0`).
        time: when it is thrown, seconds.
        animal: name of the target animal.
        point: the target body point (`pelvis.start`).
        shape: `box`, `sphere` or `capsule`.
        size: MuJoCo geom size (half sizes for a box, half length for a capsule), metres.
        mass: kg.
        speed: arrival speed, m/s.
        direction: unit vector from the target toward where it comes from, heading frame.
        distance: metres from the target where it appears.
        flight_time: seconds from the throw to the target.
        launch_velocity: velocity when thrown, heading frame, m/s.
    """

    body: str
    time: float
    animal: str
    point: str
    shape: str
    size: tuple[float, ...]
    mass: float
    speed: float
    direction: np.ndarray
    distance: float
    flight_time: float
    launch_velocity: np.ndarray


@dataclass
class SceneSetup:
    """A scene built for its animals.

    Attributes:
        scene: what it was built from.
        spec: the world, uncompiled, animals attached under `<name>/`.
        placements: the animals, in scene order (the first sets HP, bw and bm).
        headings: each animal's start heading, radians counter-clockwise from +x.
        goal_parameters: controller parameter -> expression text (metres, `t` in seconds).
        throws: the throws in declaration order (random series expanded).
        prop_velocities: prop body name -> its start velocity, for props that move at the start.
    """

    scene: SceneSpec
    spec: mujoco.MjSpec
    placements: list[Placement]
    headings: list[float]
    goal_parameters: dict[str, str]
    throws: list[ThrowPlan] = field(default_factory=list)
    prop_velocities: dict[str, np.ndarray] = field(default_factory=dict)

    def events(self, model: mujoco.MjModel) -> list[Callable[[mujoco.MjModel, mujoco.MjData], None]]:
        """The scene's events for a model compiled from `spec`: props set moving, then the throws.

        Each is called before every physics step (see `quadpipe.sim.simulation.Run`). Thrown objects
        are parked (collisions off, held against gravity) until their time; binding resets
        that, so a model can be reused.
        """
        starts: list[Callable] = [PropStart(model, name, velocity) for name, velocity in self.prop_velocities.items()]
        headings = dict(zip((p.name for p in self.placements), self.headings))
        throws = [ThrowEvent(model, plan, self._point_offset(plan), headings[plan.animal]) for plan in self.throws]
        return starts + throws

    def _point_offset(self, plan: ThrowPlan) -> tuple[str, np.ndarray]:
        """The target's body and the point's offset from that body's origin, in the body frame."""
        placement = next(p for p in self.placements if p.name == plan.animal)
        role, anchor = plan.point.split(".")
        bone = placement.built.animal.skeleton.bones[role]
        fraction = ANCHOR_FRACTIONS[anchor]
        return f"{plan.animal}/{role}", fraction * (np.asarray(bone.end) - np.asarray(bone.start))


@dataclass(frozen=True)
class _Slot:
    """One animal of the scene before placement: its name, model and where it is declared.

    Attributes:
        name: instance name.
        built: its model.
        index: index of its item in `animals`, None for the default animal.
        cell: its rank in a grid (row by row), 0 otherwise.
    """

    name: str
    built: BuiltAnimal
    index: int | None = None
    cell: int = 0


@dataclass(frozen=True)
class _Entry:
    """One animal to place: its name, model, ground position (m) and heading (rad)."""

    name: str
    built: BuiltAnimal
    xy: tuple[float, float]
    heading: float


def build_scene(scene: SceneSpec, species: Sequence[BuiltAnimal] | BuiltAnimal) -> SceneSetup:
    """Build a scene's world with its animals.

    Args:
        scene: the loaded scene.
        species: the animal for scene entries without a `species` (the command line's): one
            for all of them, or a list with one per such animal, in scene order.

    Raises:
        QuadpipeError: a value out of range for these animals, a throw too slow for its
            distance, goal times out of order, the wrong number of animals given.
    """
    slots = _slots(scene, species)
    first = slots[0].built.animal
    hp = first.pelvis_height
    values = Values(scene, units.Scale.of(hp, first.mass_kg))
    entries = [_entry(values, scene, slot) for slot in slots]
    spec = mujoco.MjSpec()
    spec.modelname = scene.name
    spec.compiler.degree = False
    spec.option.timestep = min(entry.built.timestep for entry in entries)
    spec.option.iterations = sizing.SOLVER_ITERATIONS
    largest = max(entry.built.animal.pelvis_height for entry in entries)
    ground = scene.file.ground
    friction = (ground or Ground()).friction
    add_sky_and_light(spec, largest)
    if ground is not None:
        add_floor(spec, largest, friction)
    _add_terrain(spec, scene, values, friction)
    placements = _attach_animals(spec, entries, friction)
    tau = sizing.constraint_time_constant(hp)
    velocities = _add_props(spec, scene, values, tau)
    throws = _plan_throws(scene, values, [entry.name for entry in entries], -float(spec.option.gravity[2]))
    _add_thrown(spec, throws, tau, hp)
    goals = {name: _goal_text(scene, values, name) for name in scene.file.goals}
    return SceneSetup(scene, spec, placements, [entry.heading for entry in entries], goals, throws, velocities)


# --------------------------------------------------------------------------- animals


def _slots(scene: SceneSpec, species: Sequence[BuiltAnimal] | BuiltAnimal) -> list[_Slot]:
    """The scene's animals in order, grids expanded, each with its model."""
    given = list(species) if isinstance(species, (list, tuple)) else [species]
    items = scene.file.animals
    needed = 1 if items is None else sum(len(_entry_names(item)) for item in items if item.species is None)
    if needed and len(given) not in (1, needed):
        raise QuadpipeError.single(
            "animal-count",
            f"this scene has {needed} animals without a species, and {len(given)} animals were given",
            where=scene.locate(("animals",)),
            hint="give one animal for all of them, or one per animal",
        )
    if items is None:
        return [_Slot(given[0].animal.name, given[0])]
    pending = iter(given * needed if len(given) == 1 else given)
    built_of = _species_builder(scene)
    slots = []
    for index, item in enumerate(items):
        for cell, name in enumerate(_entry_names(item)):
            built = next(pending) if item.species is None else built_of(item.species)
            slots.append(_Slot(name, built, index, cell))
    return slots


def _species_builder(scene: SceneSpec) -> Callable[[str], BuiltAnimal]:
    """Load and build the animals a scene names, once per species."""
    from quadpipe.animals.library import load_animal
    from quadpipe.animals.model import build_animal

    cache: dict[str, BuiltAnimal] = {}

    def built_of(species: str) -> BuiltAnimal:
        if species not in cache:
            source = Path(scene.doc.file).parent / species if _is_path(species) else species
            cache[species] = build_animal(load_animal(source))
        return cache[species]

    return built_of


def _entry(values: Values, scene: SceneSpec, slot: _Slot) -> _Entry:
    """Where a slot's animal starts."""
    if slot.index is None:
        return _Entry(slot.name, slot.built, (0.0, 0.0), 0.0)
    base = ("animals", slot.index)
    item = scene.file.animals[slot.index]
    x, y = values.items(base + ("at",), 2)
    if isinstance(item, AnimalGrid):
        row_gap, column_gap = values.items(base + ("grid", "spacing"), 2)
        row, column = divmod(slot.cell, item.grid.columns)
        x, y = x - row * row_gap, y - column * column_gap
    return _Entry(slot.name, slot.built, (float(x), float(y)), float(values[base + ("heading",)]))


def _attach_animals(spec: mujoco.MjSpec, entries: list[_Entry], friction: float) -> list[Placement]:
    """Attach every animal, turned to its heading and lifted onto whatever lies under it.

    The ground is found on the world compiled before any animal is attached (compiling the
    spec itself: `MjSpec.copy()` of a spec whose material skips a texture role crashes
    MuJoCo 3.17).
    """
    ground_model = spec.compile()
    ground_data = mujoco.MjData(ground_model)
    mujoco.mj_kinematics(ground_model, ground_data)
    bottoms: dict[int, np.ndarray] = {}
    placements = []
    for entry in entries:
        if id(entry.built) not in bottoms:
            bottoms[id(entry.built)] = geom_bottoms(entry.built.spec)
        lift = _start_height(entry, bottoms[id(entry.built)], ground_model, ground_data)
        animal_spec = entry.built.spec.copy()
        animal_spec.option.timestep = spec.option.timestep
        for geom in animal_spec.geoms:
            geom.friction = [friction, *geom.friction[1:]]
        frame = spec.worldbody.add_frame(pos=[*entry.xy, lift], quat=yaw_quat(entry.heading))
        spec.attach(animal_spec, prefix=f"{entry.name}/", frame=frame)
        placements.append(Placement(entry.name, entry.built, entry.xy, entry.heading))
    return placements


def geom_bottoms(animal_spec: mujoco.MjSpec) -> np.ndarray:
    """The lowest point of each geom of an animal in its rest pose, in its own frame, (k, 3)."""
    model = animal_spec.copy().compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    rotations = data.geom_xmat.reshape(-1, 3, 3)
    centres = data.geom_xpos + np.einsum("kij,kj->ki", rotations, model.geom_aabb[:, :3])
    reach = np.einsum("kj,kj->k", np.abs(rotations[:, 2, :]), model.geom_aabb[:, 3:])
    return centres - np.outer(reach, [0.0, 0.0, 1.0])


def _start_height(entry: _Entry, bottoms: np.ndarray, ground_model: mujoco.MjModel, ground_data: mujoco.MjData) -> float:
    """How high to attach an animal so that its lowest part rests on the ground or terrain below."""
    hp = entry.built.animal.pelvis_height
    points = bottoms @ yaw_matrix(entry.heading).T + np.array([*entry.xy, 0.0])
    top = RAY_HEIGHT_HP * hp
    lifts = [
        ground - point[2]
        for point in points
        if (ground := ground_height(ground_model, ground_data, point[0], point[1], top)) is not None
    ]
    lift = max(lifts) if lifts else -float(points[:, 2].min())
    return lift + DROP_CLEARANCE_HP * hp


def ground_height(model: mujoco.MjModel, data: mujoco.MjData, x: float, y: float, top: float) -> float | None:
    """Height of the highest static surface under (x, y) below `top`, or None if there is none."""
    geom = np.zeros(1, dtype=np.int32)
    distance = mujoco.mj_ray(model, data, np.array([x, y, top]), np.array([0.0, 0.0, -1.0]), None, 1, -1, geom)
    return None if distance < 0 else top - distance


# --------------------------------------------------------------------------- world and terrain


@dataclass(frozen=True)
class Slab:
    """A static terrain box: name, centre (m), half sizes (m), orientation (w, x, y, z)."""

    name: str
    centre: np.ndarray
    half: np.ndarray
    quat: np.ndarray


def _add_terrain(spec: mujoco.MjSpec, scene: SceneSpec, values: Values, friction: float) -> None:
    for index, item in enumerate(scene.file.terrain):
        for slab in terrain_slabs(index, item, values):
            spec.worldbody.add_geom(
                name=slab.name, type=mujoco.mjtGeom.mjGEOM_BOX, pos=slab.centre, size=slab.half, quat=slab.quat,
                rgba=list(TERRAIN_RGBA), contype=WORLD_CONTYPE, conaffinity=WORLD_CONAFFINITY, friction=[friction, *FRICTION[1:]],
            )


def terrain_slabs(index: int, item: Any, values: Values) -> list[Slab]:
    """The boxes of one terrain item (named `terrain<index>_<type>[_<part>]`)."""
    base = ("terrain", index)
    name = f"terrain{index}_{item.type}"
    if isinstance(item, TerrainBox):
        return [Slab(name, values[base + ("at",)], values.items(base + ("size",), 3) / 2, euler_quat(values[base + ("euler",)]))]
    start, width = values[base + ("start",)], values[base + ("width",)]
    reach_down = RAMP_BASE_HP * values.hp
    if isinstance(item, Slope):
        angle, run, top = values[base + ("angle",)], values[base + ("length",)], values[base + ("top",)]
        rise = run * math.tan(angle)
        return [_ramp(f"{name}_ramp", start, 0.0, run, angle, True, width, reach_down), *_block(f"{name}_top", start + run, top, rise, width)]
    if isinstance(item, Hill):
        angle, height, top = values[base + ("angle",)], values[base + ("height",)], values[base + ("top",)]
        run = height / math.tan(angle)
        return [
            _ramp(f"{name}_up", start, 0.0, run, angle, True, width, reach_down),
            *_block(f"{name}_top", start + run, top, height, width),
            _ramp(f"{name}_down", start + run + top, height, run, angle, False, width, reach_down),
        ]
    return _stairs(name, item, start, width, values, base)


def _stairs(name: str, item: Stairs, start: float, width: float, values: Values, base: tuple[Any, ...]) -> list[Slab]:
    rise, depth, landing = values[base + ("step_height",)], values[base + ("step_depth",)], values[base + ("landing",)]
    count = item.steps
    if item.direction == "up":
        steps = [slab for k in range(1, count + 1) for slab in _block(f"{name}_step{k}", start + (k - 1) * depth, depth, k * rise, width)]
        return steps + _block(f"{name}_landing", start + count * depth, landing, count * rise, width)
    steps = [slab for k in range(1, count) for slab in _block(f"{name}_step{k}", start + (k - 1) * depth, depth, (count - k) * rise, width)]
    return _block(f"{name}_landing", start - landing, landing, count * rise, width) + steps


def _block(name: str, x0: float, length: float, height: float, width: float) -> list[Slab]:
    """A box from the ground up to `height`, from x0 over `length`; none if it is empty."""
    if length <= 0 or height <= 0:
        return []
    centre = np.array([x0 + length / 2, 0.0, height / 2])
    return [Slab(name, centre, np.array([length / 2, width / 2, height / 2]), np.array([1.0, 0.0, 0.0, 0.0]))]


def _ramp(name: str, x0: float, z0: float, run: float, angle: float, rising: bool, width: float, reach_down: float) -> Slab:
    """A tilted slab whose top face runs from (x0, z0) over `run` along x, up or down at `angle`.

    It is thick enough to reach below the ground under its high end, so no gap shows.
    """
    sign = 1.0 if rising else -1.0
    rise = run * math.tan(angle)
    thickness = rise / math.cos(angle) + reach_down
    normal = np.array([-sign * math.sin(angle), 0.0, math.cos(angle)])
    top_middle = np.array([x0 + run / 2, 0.0, z0 + sign * rise / 2])
    pitch = -sign * angle
    return Slab(
        name,
        top_middle - normal * thickness / 2,
        np.array([run / (2 * math.cos(angle)), width / 2, thickness / 2]),
        np.array([math.cos(pitch / 2), 0.0, math.sin(pitch / 2), 0.0]),
    )


def euler_quat(euler: np.ndarray) -> np.ndarray:
    """The quaternion of MuJoCo's default `xyz` Euler sequence (about x, then the new y, then the new z)."""
    quat = np.zeros(4)
    mujoco.mju_euler2Quat(quat, np.asarray(euler, dtype=float), "xyz")
    return quat


# --------------------------------------------------------------------------- props and throws


def mujoco_size(shape: str, size: np.ndarray) -> tuple[float, ...]:
    """A scene `size` (full box sides, capsule straight length) as MuJoCo's geom size."""
    if shape == "box":
        return tuple(float(v) / 2 for v in size)
    if shape == "capsule":
        return (float(size[0]), float(size[1]) / 2)
    return (float(size[0]),)


_GEOM_TYPES = {"box": "mjGEOM_BOX", "sphere": "mjGEOM_SPHERE", "capsule": "mjGEOM_CAPSULE"}


def _add_shape(body: mujoco.MjsBody, name: str, shape: str, size: tuple[float, ...], mass: float, rgba: tuple[float, ...], tau: float, hp: float, colliding: bool) -> None:
    """A loose object's geom: it touches the world and the animals, softened for the scene's size."""
    body.add_geom(
        name=name, type=getattr(mujoco.mjtGeom, _GEOM_TYPES[shape]), size=[*size, *[0.0] * (3 - len(size))],
        mass=mass, rgba=list(rgba), solref=[tau, 1.0], solimp=sizing.constraint_impedance(hp),
        contype=WORLD_CONTYPE if colliding else 0, conaffinity=WORLD_CONAFFINITY if colliding else 0,
    )


def _add_props(spec: mujoco.MjSpec, scene: SceneSpec, values: Values, tau: float) -> dict[str, np.ndarray]:
    """Add every prop as a free body; returns the start velocities of those that move."""
    velocities = {}
    for index, prop in enumerate(scene.file.props):
        base = ("props", index)
        body = spec.worldbody.add_body(name=prop.name, pos=values[base + ("at",)], quat=euler_quat(values[base + ("euler",)]))
        body.add_freejoint(name=prop.name)
        size = mujoco_size(prop.type, values.items(base + ("size",), len(prop.size)))
        _add_shape(body, prop.name, prop.type, size, values[base + ("mass",)], PROP_RGBA, tau, values.hp, colliding=True)
        velocity = values[base + ("velocity",)]
        if np.any(velocity):
            velocities[prop.name] = velocity
    return velocities


def _add_thrown(spec: mujoco.MjSpec, throws: list[ThrowPlan], tau: float, hp: float) -> None:
    """Add every thrown object, parked under the floor, held against gravity, touching nothing."""
    for plan in throws:
        body = spec.worldbody.add_body(name=plan.body, pos=[0.0, 0.0, -PARK_DEPTH_HP * hp], gravcomp=1.0)
        body.add_freejoint(name=plan.body)
        _add_shape(body, plan.body, plan.shape, plan.size, plan.mass, THROWN_RGBA, tau, hp, colliding=False)


def _plan_throws(scene: SceneSpec, values: Values, names: list[str], gravity: float) -> list[ThrowPlan]:
    """Every throw of the scene, random series drawn, in declaration order."""
    plans: list[ThrowPlan] = []
    for index, item in enumerate(scene.file.throws):
        base = ("throws", index)
        animal = _target_animal(scene, item.animal, names, base + ("animal",))
        size = mujoco_size(item.shape, values.items(base + ("size",), len(item.size)))
        if isinstance(item, Throw):
            shots = [(values[base + ("at",)], values[base + ("mass",)], values[base + ("speed",)], from_vector(item.from_))]
            speed_path = base + ("speed",)
        else:
            shots = random_shots(item.random, values, base + ("random",))
            speed_path = base + ("random", "speed")
        for time, mass, speed, direction in shots:
            distance, flight = _aim(speed, direction, values.get(base + ("distance",)), gravity, values.hp, scene, speed_path)
            launch = -distance * direction / flight + np.array([0.0, 0.0, gravity * flight / 2])
            plans.append(ThrowPlan(
                f"{THROWN_PREFIX}{len(plans)}", float(time), animal, resolve_point_name(item.target), item.shape, size,
                float(mass), float(speed), direction, distance, flight, launch,
            ))
    return plans


def _target_animal(scene: SceneSpec, ref: int | str, names: list[str], path: tuple[Any, ...]) -> str:
    if not _animal_exists(ref, names):
        raise QuadpipeError.single("unknown-animal-ref", f"there is no animal {ref!r} in this scene", where=scene.locate(path), hint=_animal_hint(names))
    return names[ref] if isinstance(ref, int) else ref


def from_vector(direction: str | list[float]) -> np.ndarray:
    """A throw's `from` as a unit vector in the heading frame."""
    vector = np.array(FROM_DIRECTIONS[direction] if isinstance(direction, str) else direction, dtype=float)
    return vector / np.linalg.norm(vector)


def random_shots(series: RandomThrows, values: Values, base: tuple[Any, ...]) -> list[tuple[float, float, float, np.ndarray]]:
    """The (time, mass, speed, direction) of each throw of a random series, drawn from its seed."""
    rng = np.random.default_rng(series.seed)
    start, every = values[base + ("start",)], values[base + ("every",)]
    mass_low, mass_high = _range(values, base + ("mass",))
    speed_low, speed_high = _range(values, base + ("speed",))
    shots = []
    for k in range(series.count):
        mass_draw, speed_draw = rng.random(2)
        side = series.from_[int(rng.integers(len(series.from_)))]
        mass = mass_low + mass_draw * (mass_high - mass_low)
        speed = speed_low + speed_draw * (speed_high - speed_low)
        shots.append((start + k * every, mass, speed, from_vector(side)))
    return shots


def _range(values: Values, path: tuple[Any, ...]) -> tuple[float, float]:
    low, high = values.items(path, 2)
    if low > high:
        raise QuadpipeError.single("invalid-range", f"{_dotted(path)}: the lowest value comes first: [lowest, highest]", where=values.scene.locate(path))
    return float(low), float(high)


def _aim(speed: float, direction: np.ndarray, distance: float | None, gravity: float, hp: float, scene: SceneSpec, path: tuple[Any, ...]) -> tuple[float, float]:
    """The throw's distance and flight time; it starts as fast as it arrives when level.

    Raises:
        QuadpipeError: the speed cannot carry the object that far from that direction.
    """
    lift = 1.0 + direction[2]
    reach = speed**2 / (gravity * lift) if lift > 0 else math.inf
    if distance is None:
        distance = min(THROW_DISTANCE_HP * hp, THROW_RANGE_FRACTION * reach)
    flight = flight_time(speed, distance, direction[2], gravity)
    if flight is None:
        raise QuadpipeError.single(
            "throw-out-of-reach",
            f"{_dotted(path)}: at {speed:.3g} m/s a throw reaches at most {reach:.3g} m from this direction, not {distance:.3g} m",
            where=scene.locate(path),
            hint="throw faster, or from closer (`distance`)",
        )
    return float(distance), flight


def flight_time(speed: float, distance: float, up: float, gravity: float) -> float | None:
    """Time for a ballistic throw to reach a point `distance` away and arrive at `speed`.

    The object starts at `distance` x (direction with vertical part `up`) from the target;
    the direct (flatter) of the two possible arcs is taken. With a launch velocity
    v0 = D/T - g T/2 (D the displacement) the arrival velocity is D/T + g T/2, whose squared
    length, solved for T^2, gives a quadratic; its smaller root is the direct arc.

    Returns:
        the flight time in seconds, or None if that speed cannot get there.
    """
    b = speed**2 - gravity * distance * up
    discriminant = b * b - (gravity * distance) ** 2
    if b <= 0 or discriminant < 0:
        return None
    return math.sqrt(2 * distance**2 / (b + math.sqrt(discriminant)))


# --------------------------------------------------------------------------- goals


def _goal_text(scene: SceneSpec, values: Values, name: str) -> str:
    goal = scene.file.goals[name]
    base = ("goals", name)
    if goal.point is not None:
        return vector_text(values[base + ("point",)])
    path = base + ("path",)
    waypoints = [(values[path + (i, 0)], values[path + (i, 1)]) for i in range(len(goal.path))]
    for i, ((before, _), (after, _)) in enumerate(zip(waypoints, waypoints[1:]), start=1):
        if after <= before:
            raise QuadpipeError.single("invalid-value", f"{_dotted(path + (i, 0))}: the path's times must increase", where=scene.locate(path + (i, 0)))
    return goal_expression(waypoints)


def goal_expression(waypoints: Sequence[tuple[float, np.ndarray]]) -> str:
    """A piecewise-linear point in time as controller-language text (metres, `t` in seconds).

    The point is the first waypoint plus, for each segment, its displacement times the
    fraction of the segment elapsed: `clamp((t - t0) / (t1 - t0), 0, 1)`.
    """
    terms = [vector_text(waypoints[0][1])]
    for (t0, p0), (t1, p1) in zip(waypoints, waypoints[1:]):
        terms.append(f"{vector_text(p1 - p0)} * clamp(({TIME_VARIABLE} - {number_text(t0)} s) / ({number_text(t1 - t0)} s), 0, 1)")
    return " + ".join(terms)


def vector_text(vector: np.ndarray) -> str:
    """A point in metres as controller-language text: `[13.1 m, 0 m, 0 m]`."""
    return "[" + ", ".join(f"{number_text(v)} m" for v in vector) + "]"


def number_text(value: float) -> str:
    """A number with 10 significant digits, without `-0`."""
    text = f"{float(value):.10g}"
    return "0" if text == "-0" else text


# --------------------------------------------------------------------------- events


TIME_TOLERANCE_S = 1e-9
"""An event due at t fires at the first step whose time is within this of t or past it."""


class PropStart:
    """Event: sets a prop moving at the start (MuJoCo models hold no initial velocity)."""

    def __init__(self, model: mujoco.MjModel, name: str, velocity: np.ndarray):
        self.dof = int(model.jnt_dofadr[model.body(name).jntadr[0]])
        self.velocity = np.asarray(velocity, dtype=float)
        self.first_step_end = model.opt.timestep / 2

    def __call__(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        if data.time < self.first_step_end:
            data.qvel[self.dof : self.dof + 3] = self.velocity


class ThrowEvent:
    """Event: at its time, a parked object appears and flies to its target point.

    It aims where the target point will be after the flight time if it keeps its horizontal
    velocity, from the side given relative to where the animal then faces, and is placed
    where it would be at the step's time had it left exactly on time. Going back before the
    throw time (a reset) parks the object again.

    Args:
        model: the compiled scene.
        plan: the throw.
        target_body: name of the body carrying the target point.
        offset: the point in that body's frame, metres.
        start_heading: the animal's start heading, used when it faces straight up or down.
    """

    def __init__(self, model: mujoco.MjModel, plan: ThrowPlan, target: tuple[str, np.ndarray], start_heading: float):
        self.plan = plan
        body = model.body(plan.body)
        self.body = int(body.id)
        joint = int(body.jntadr[0])
        self.qpos = int(model.jnt_qposadr[joint])
        self.dof = int(model.jnt_dofadr[joint])
        self.geoms = slice(int(body.geomadr[0]), int(body.geomadr[0] + body.geomnum[0]))
        self.target = int(model.body(target[0]).id)
        self.offset = np.asarray(target[1], dtype=float)
        self.pelvis = int(model.body(f"{plan.animal}/pelvis").id)
        self.start_heading = start_heading
        self.parked = model.qpos0[self.qpos : self.qpos + 7].copy()
        self.thrown = False
        self._park(model)

    def __call__(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        if data.time < self.plan.time - TIME_TOLERANCE_S:
            if self.thrown:
                self._park(model, data)
            return
        if not self.thrown:
            self._launch(model, data)

    def _collide(self, model: mujoco.MjModel, on: bool) -> None:
        """Switch the object's collisions (MuJoCo filters by body bits first, then by geom bits)."""
        contype, conaffinity = (WORLD_CONTYPE, WORLD_CONAFFINITY) if on else (0, 0)
        model.geom_contype[self.geoms] = contype
        model.geom_conaffinity[self.geoms] = conaffinity
        model.body_contype[self.body] = contype
        model.body_conaffinity[self.body] = conaffinity

    def _park(self, model: mujoco.MjModel, data: mujoco.MjData | None = None) -> None:
        self._collide(model, False)
        model.body_gravcomp[self.body] = 1.0
        if data is not None:
            data.qpos[self.qpos : self.qpos + 7] = self.parked
            data.qvel[self.dof : self.dof + 6] = 0.0
        self.thrown = False

    def heading(self, data: mujoco.MjData) -> float:
        """Where the target animal faces now: its pelvis's forward axis, horizontally."""
        forward = data.xmat[self.pelvis].reshape(3, 3)[:, 0]
        if math.hypot(forward[0], forward[1]) < ZERO_NORM:
            return self.start_heading
        return math.atan2(forward[1], forward[0])

    def launch_state(self, model: mujoco.MjModel, data: mujoco.MjData) -> tuple[np.ndarray, np.ndarray, float]:
        """Position, velocity and heading of the object at the current time (state must be forward-computed)."""
        plan = self.plan
        rotation = data.xmat[self.target].reshape(3, 3)
        point = data.xpos[self.target] + rotation @ self.offset
        motion = np.zeros(6)
        mujoco.mj_objectVelocity(model, data, mujoco.mjtObj.mjOBJ_XBODY, self.target, motion, 0)
        point_velocity = motion[3:] + np.cross(motion[:3], point - data.xpos[self.target])
        aim = point + plan.flight_time * np.array([point_velocity[0], point_velocity[1], 0.0])
        heading = self.heading(data)
        turn = yaw_matrix(heading)
        start = aim + turn @ (plan.distance * plan.direction)
        velocity = turn @ plan.launch_velocity
        late = data.time - plan.time
        gravity = np.asarray(model.opt.gravity)
        return start + velocity * late + gravity * late**2 / 2, velocity + gravity * late, heading

    def _launch(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        mujoco.mj_forward(model, data)
        position, velocity, heading = self.launch_state(model, data)
        data.qpos[self.qpos : self.qpos + 3] = position
        data.qpos[self.qpos + 3 : self.qpos + 7] = yaw_quat(heading)
        data.qvel[self.dof : self.dof + 3] = velocity
        data.qvel[self.dof + 3 : self.dof + 6] = 0.0
        self._collide(model, True)
        model.body_gravcomp[self.body] = 0.0
        self.thrown = True


def main() -> None:
    """Regenerate `schemas/scene.schema.json` in the repository this package sits in."""
    root = Path(__file__).resolve().parents[2]
    print(f"wrote {write_schema(root).relative_to(root)}")


if __name__ == "__main__":
    main()
