"""The scene file format: pydantic models of `configs/scenes/<name>.yaml`.

These models check a file's structure (keys, nesting, value shapes). Their quantities carry
the markers of `quadpipe.quantities.fields` (`Quantity`, `Items`, `Bounds`) and this
module's `Waypoints`, which `iter_quantities` finds to check units (`quadpipe.world.loading`)
and evaluate values for the scene's animals (`quadpipe.world.values`). The same models
generate the JSON Schema (`quadpipe.world.schema`), so every key's `description` is user
documentation.
"""

from __future__ import annotations

import math
import re
import types
import typing
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Annotated, Any, Literal, Union

import pydantic
from pydantic import BaseModel, BeforeValidator, ConfigDict, Discriminator, Field, Tag, field_validator, model_validator

from quadpipe.core.yamlio import Name
from quadpipe.quantities import fields, units
from quadpipe.quantities.expressions import SCALAR, VECTOR, Expect
from quadpipe.quantities.fields import (
    NON_NEGATIVE,
    POSITIVE,
    Bounds,
    Items,
    Quantity,
    Value,
    described,
    quantities,
    quantity,
)
from quadpipe.world.direction_format import DirectionField
from quadpipe.world.set_format import TerrainMesh

SCHEMA_VERSION = 1
"""The only `schema:` version this quadpipe reads."""

NAME_PATTERN = r"^[A-Za-z][A-Za-z0-9_]*$"
"""Animal and prop names: they prefix MuJoCo element names (`dog/pelvis`)."""

THROWN_PREFIX = "thrown"
"""Thrown bodies are named `thrown0`, `thrown1`, ... in declaration order (series drawn in place)."""

RESERVED_PROP_NAMES = re.compile(rf"^(world|floor|{THROWN_PREFIX}\d+|terrain\d+_\w*)$")
"""Names the scene's own elements take: a prop (body and geom of that name) cannot use them."""

# Expected kinds and dimensions of scene quantities (examples are shown in hints).
LENGTH = fields.with_example(fields.LENGTH, "3 HP")
ANGLE = fields.with_example(fields.ANGLE, "10 deg")
TIME = fields.with_example(fields.TIME, "3 s")
MASS = Expect(SCALAR, (units.MASS,), "mass", "0.1 bm")
SPEED = Expect(SCALAR, (units.VELOCITY,), "velocity", "4 m/s")
POINT = fields.with_example(fields.POINT, "[20 HP, 0, 0]")
ANGLES = Expect(VECTOR, (units.ANGLE,), "vector of angles", "[0, 0, 30 deg]")
VELOCITY = Expect(VECTOR, (units.VELOCITY,), "vector of velocities", "[1 m/s, 0, 0]")

SHAPE_SIZES: dict[str, tuple[str, ...]] = {
    "sphere": ("radius",),
    "box": ("length (x)", "width (y)", "height (z)"),
    "capsule": ("radius", "length of the straight part"),
}
"""The `size` items of each shape, in order."""

MAX_RAMP_ANGLE_DEG = 60.0
"""Steepest ramp or hill side, degrees; steeper is a wall: use a `box`."""

THROW_DISTANCE_HP = 2.0
"""Default distance a throw starts from its target, in pelvis heights of the scene."""

RAMP_ANGLE = Bounds(high=math.radians(MAX_RAMP_ANGLE_DEG), high_text=f"{MAX_RAMP_ANGLE_DEG:g} deg")


@dataclass(frozen=True)
class Waypoints:
    """Marks a list of `[time, point]` pairs."""


# --------------------------------------------------------------------------- models


EULER_TEXT = "Orientation: MuJoCo's `xyz` Euler sequence (about x, then the new y, then the new z)."


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", populate_by_name=True)


class Ground(_Model):
    """The floor: an endless plane at z = 0."""

    friction: Annotated[
        float,
        Field(
            1.0,
            gt=0,
            description="Sliding friction of the floor and the terrain. MuJoCo lets the bones decide their contacts (so that each animal keeps its own softness), so the animals' bones take this friction too.",
        ),
    ]


def _ground_shorthand(value: Any) -> Any:
    return None if value == "none" else value


GroundField = Annotated[
    Ground | None, BeforeValidator(_ground_shorthand, json_schema_input_type=Union[Ground, Literal["none"]])
]


class _Strip(_Model):
    start: Annotated[
        quantity(LENGTH), Field(description=described("Where it begins along x (forward) from the origin.", LENGTH))
    ]
    width: Annotated[
        quantity(LENGTH, POSITIVE),
        Field("8 HP", description=described("Its extent across (along y), centred on y = 0.", LENGTH)),
    ]


class Slope(_Strip):
    """A ramp rising along +x, then a flat top."""

    type: Annotated[Literal["slope"], Field(description="Terrain type.")]
    angle: Annotated[
        quantity(ANGLE, RAMP_ANGLE),
        Field(description=described(f"How steep it is (0 to {MAX_RAMP_ANGLE_DEG:g} deg).", ANGLE)),
    ]
    length: Annotated[
        quantity(LENGTH, POSITIVE),
        Field(description=described("Horizontal length of the ramp; it rises length x tan(angle).", LENGTH)),
    ]
    top: Annotated[
        quantity(LENGTH, NON_NEGATIVE),
        Field(
            "2 HP", description=described("Length of the flat top after the ramp (0: the ramp ends in a drop).", LENGTH)
        ),
    ]


class Hill(_Strip):
    """A ramp up, a flat top, the same ramp down."""

    type: Annotated[Literal["hill"], Field(description="Terrain type.")]
    angle: Annotated[
        quantity(ANGLE, RAMP_ANGLE),
        Field(description=described(f"How steep both sides are (0 to {MAX_RAMP_ANGLE_DEG:g} deg).", ANGLE)),
    ]
    height: Annotated[quantity(LENGTH, POSITIVE), Field(description=described("Height of the top.", LENGTH))]
    top: Annotated[
        quantity(LENGTH, NON_NEGATIVE), Field("2 HP", description=described("Length of the flat top.", LENGTH))
    ]


class Stairs(_Strip):
    """Steps along +x: up from the ground to a landing, or down from a landing to the ground."""

    type: Annotated[Literal["stairs"], Field(description="Terrain type.")]
    step_height: Annotated[quantity(LENGTH, POSITIVE), Field(description=described("Rise of each step.", LENGTH))]
    step_depth: Annotated[
        quantity(LENGTH, POSITIVE), Field(description=described("Depth (tread) of each step.", LENGTH))
    ]
    steps: Annotated[int, Field(ge=1, description="Number of steps.")]
    direction: Annotated[
        Literal["up", "down"],
        Field(
            "up",
            description="`up`: the stairs climb from `start`, with the landing after them; `down`: the landing ends at `start` (an animal can start on it) and the stairs descend from there.",
        ),
    ]
    landing: Annotated[
        quantity(LENGTH, NON_NEGATIVE),
        Field("4 HP", description=described("Length of the flat landing at the top.", LENGTH)),
    ]


class TerrainBox(_Model):
    """Any static block."""

    type: Annotated[Literal["box"], Field(description="Terrain type.")]
    at: Annotated[
        quantity(POINT),
        Field(description=described("Centre of the box, in world coordinates (x forward, y left, z up).", POINT)),
    ]
    size: Annotated[
        quantities(LENGTH, 3, POSITIVE),
        Field(description="Full length (x), width (y) and height (z), e.g. `[2 HP, 8 HP, 0.3 HP]`."),
    ]
    euler: Annotated[quantity(ANGLES), Field([0, 0, 0], description=described(EULER_TEXT, ANGLES))]


TERRAIN_TYPES: dict[str, type[BaseModel]] = {
    "slope": Slope,
    "hill": Hill,
    "stairs": Stairs,
    "box": TerrainBox,
    "mesh": TerrainMesh,
}

Terrain = Annotated[Slope | Hill | Stairs | TerrainBox | TerrainMesh, Field(discriminator="type")]


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
    at: Annotated[quantity(POINT), Field(description=described("Centre at the start, in world coordinates.", POINT))]
    size: Annotated[
        quantities(LENGTH, (1, 3), POSITIVE),
        Field(
            description="sphere: `[radius]`; box: `[length, width, height]` (full sizes); capsule: `[radius, length of the straight part]` (its axis is z before `euler`)."
        ),
    ]
    mass: Annotated[quantity(MASS, POSITIVE), Field(description=described("Its mass.", MASS))]
    euler: Annotated[quantity(ANGLES), Field([0, 0, 0], description=described(EULER_TEXT, ANGLES))]
    velocity: Annotated[quantity(VELOCITY), Field([0, 0, 0], description=described("Velocity at the start.", VELOCITY))]

    @field_validator("size")
    @classmethod
    def _size_fits_type(cls, size: list[Any], info: pydantic.ValidationInfo) -> list[Any]:
        return _check_size(info.data.get("type"), size)


FromDirection = Union[
    Literal["left", "right", "front", "back"], Annotated[list[float], Field(min_length=3, max_length=3)]
]


class _ThrowBase(_Model):
    shape: Annotated[Literal["box", "sphere", "capsule"], Field(description="Shape of the thrown object.")]
    size: Annotated[
        quantities(LENGTH, (1, 3), POSITIVE),
        Field(
            description="As a prop's `size`: sphere `[radius]`, box `[length, width, height]`, capsule `[radius, length]`."
        ),
    ]
    target: Annotated[
        str,
        Field(
            "pelvis",
            description="Body point aimed at: a role (its joint), `role.start|mid|end`, or `leg.top|foot` (e.g. `thorax.mid`, `lf.foot`).",
        ),
    ]
    animal: Annotated[
        int | str, Field(0, description="The animal aimed at: its index in the scene (0 is the first) or its name.")
    ]
    distance: Annotated[
        quantity(LENGTH, POSITIVE) | None,
        Field(
            None,
            description=described(
                f"How far from the target the object appears. Default: {THROW_DISTANCE_HP:g} HP, or half the farthest the speed can carry if that is shorter, "
                "but always clear of the animal's rest pose (a throw too slow to come from there arrives faster).",
                LENGTH,
            ),
        ),
    ]

    @field_validator("size")
    @classmethod
    def _size_fits_shape(cls, size: list[Any], info: pydantic.ValidationInfo) -> list[Any]:
        return _check_size(info.data.get("shape"), size)


def _nonzero(vector: Any) -> Any:
    """A `from:` vector: finite, and not [0, 0, 0]."""
    if isinstance(vector, list) and not all(math.isfinite(v) for v in vector):
        raise ValueError("a direction vector must hold finite numbers")
    if isinstance(vector, list) and not any(vector):
        raise ValueError("a direction vector cannot be [0, 0, 0]")
    return vector


class Throw(_ThrowBase):
    """One object thrown at an animal: it reaches the target point at `speed`, `at` + the flight time."""

    at: Annotated[
        quantity(TIME, NON_NEGATIVE),
        Field(description=described("When it is thrown (it appears, already flying).", TIME)),
    ]
    mass: Annotated[
        quantity(MASS, POSITIVE), Field(description=described("Its mass; `bm` is the first animal's body mass.", MASS))
    ]
    speed: Annotated[
        quantity(SPEED, POSITIVE),
        Field(
            description=described(
                "Its speed when it reaches the target (and when thrown, from the same height); `froude_speed(2.5)` scales with the animal.",
                SPEED,
            )
        ),
    ]
    from_: Annotated[
        FromDirection,
        Field(
            "left",
            alias="from",
            description="Where it comes from, relative to where the target animal faces when it is thrown: `left`, `right`, `front`, `back`, or a vector `[forward, left, up]` pointing from the target toward the thrower.",
        ),
    ]

    _direction_is_nonzero = field_validator("from_")(_nonzero)


class RandomThrows(_Model):
    """A seeded random series of throws: same seed, same series."""

    count: Annotated[int, Field(ge=1, description="Number of throws.")]
    seed: Annotated[int, Field(description="Random seed.")]
    start: Annotated[
        quantity(TIME, NON_NEGATIVE), Field("2 s", description=described("Time of the first throw.", TIME))
    ]
    every: Annotated[quantity(TIME, POSITIVE), Field("2 s", description=described("Time between throws.", TIME))]
    mass: Annotated[
        quantities(MASS, 2, POSITIVE),
        Field(description="Range `[lowest, highest]` the masses are drawn from, uniformly, e.g. `[0.05 bm, 0.15 bm]`."),
    ]
    speed: Annotated[
        quantities(SPEED, 2, POSITIVE),
        Field(description="Range `[lowest, highest]` the speeds are drawn from, uniformly, e.g. `[3 m/s, 5 m/s]`."),
    ]
    from_: Annotated[
        list[Literal["left", "right", "front", "back"]],
        Field(
            ["left", "right", "front", "back"],
            alias="from",
            min_length=1,
            description="Directions drawn from, uniformly.",
        ),
    ]


class ThrowSeries(_ThrowBase):
    """Throws drawn at random (see `random`), all of one shape and size."""

    random: Annotated[RandomThrows, Field(description="The series.")]


def _throw_tag(value: Any) -> str:
    has_random = "random" in value if isinstance(value, dict) else isinstance(value, ThrowSeries)
    return "random" if has_random else "throw"


ThrowItem = Annotated[Annotated[Throw, Tag("throw")] | Annotated[ThrowSeries, Tag("random")], Discriminator(_throw_tag)]


class _AnimalBase(_Model):
    species: Annotated[
        str | None,
        Field(
            None,
            description="Animal name (`configs/animals`) or config path relative to this file; default: the animal given on the command line.",
        ),
    ]
    at: Annotated[
        quantities(LENGTH, 2),
        Field(
            [0, 0],
            description="Start position on the ground `[x, y]`; the animal is lifted to stand on whatever is below it.",
        ),
    ]
    heading: Annotated[
        quantity(ANGLE),
        Field(
            "0 deg",
            description=described(
                "Direction it faces, counter-clockwise from +x (90 deg faces +y, its left at the start).", ANGLE
            ),
        ),
    ]


class AnimalEntry(_AnimalBase):
    """One animal."""

    name: Annotated[
        str, Field(pattern=NAME_PATTERN, description="Unique name: its MuJoCo elements are `<name>/<role>`.")
    ]


class Grid(_Model):
    """Animals in rows (one behind the other, along -x) and columns (side by side, along -y)."""

    rows: Annotated[int, Field(ge=1, description="Number of rows.")]
    columns: Annotated[int, Field(ge=1, description="Number of animals in a row.")]
    spacing: Annotated[
        quantities(LENGTH, 2, POSITIVE), Field(description="`[between rows, between columns]`, e.g. `[3 HP, 1 HP]`.")
    ]


class AnimalGrid(_AnimalBase):
    """A grid of animals of one species: the first at `at`, then row by row."""

    grid: Annotated[Grid, Field(description="The grid's shape.")]
    name: Annotated[
        str,
        Field(pattern=NAME_PATTERN, description="Name prefix: the animals are `<name>1`, `<name>2`, ... row by row."),
    ]


def _animal_tag(value: Any) -> str:
    has_grid = "grid" in value if isinstance(value, dict) else isinstance(value, AnimalGrid)
    return "grid" if has_grid else "animal"


AnimalItem = Annotated[
    Annotated[AnimalEntry, Tag("animal")] | Annotated[AnimalGrid, Tag("grid")], Discriminator(_animal_tag)
]


Waypoint = tuple[Value, quantity(POINT)]  # type: ignore[misc]  # a pydantic field type built by a call


class Goal(_Model):
    """A controller parameter set by the scene: a fixed point, or a path through timed points."""

    point: Annotated[
        quantity(POINT) | None, Field(None, description=described("A fixed point, in world coordinates.", POINT))
    ]
    path: Annotated[
        list[Waypoint] | None,
        Waypoints(),
        Field(
            None,
            min_length=1,
            description="`[[time, point], ...]`: the goal moves in straight lines between the points, at times in increasing order, and stays at the first before its time and at the last after.",
        ),
    ]

    @model_validator(mode="after")
    def _one_kind(self) -> Goal:
        if (self.point is None) == (self.path is None):
            raise ValueError("give either a point or a `path`")
        return self


def _goal_shorthand(value: Any) -> Any:
    return value if isinstance(value, dict) else {"point": value}


GoalField = Annotated[
    Goal,
    BeforeValidator(
        _goal_shorthand,
        json_schema_input_type=Union[Goal, str, Annotated[list[float | str], Field(min_length=3, max_length=3)]],
    ),
]


class SceneFile(_Model):
    """Schema of `configs/scenes/<name>.yaml`."""

    schema_: Annotated[
        int, Field(alias="schema", description=f"Format version; this quadpipe reads `{SCHEMA_VERSION}`.")
    ]
    name: Annotated[Name, Field(description="Name of the scene, as used on the command line.")]
    description: Annotated[str, Field("", description="One line for `quadpipe scenes`.")]
    ground: Annotated[
        GroundField, Field(default_factory=Ground, description="The floor (`{friction: 1.0}`), or `none` for no floor.")
    ]
    terrain: Annotated[
        list[Terrain],
        Field([], description="Static terrain: `slope`, `hill`, `stairs`, `box` or `mesh` (a set file) items."),
    ]
    props: Annotated[list[Prop], Field([], description="Loose objects present from the start.")]
    throws: Annotated[
        list[ThrowItem], Field([], description="Objects thrown at animals: single throws, or `random:` series.")
    ]
    goals: Annotated[
        dict[str, GoalField],
        Field(
            {},
            description="Controller parameters the scene sets, by name (usually `goal` or `target`): a point, or `{path: [[time, point], ...]}`.",
        ),
    ]
    animals: Annotated[
        list[AnimalItem] | None,
        Field(
            None,
            description="Where the animals start; default: one animal (the command line's) at the origin, facing +x. `HP`, `bw` and `bm` in the whole scene are those of the first.",
        ),
    ]
    animals_collide: Annotated[
        bool,
        Field(
            False,
            description="`true`: the animals' bodies touch each other (each still passes through its own); `false`: they pass through each other.",
        ),
    ]
    direction: DirectionField


TAGGED_LISTS: dict[str, tuple[Callable[[dict[str, Any]], str | None], dict[str, type[BaseModel]], str]] = {
    "terrain": (lambda item: item.get("type"), TERRAIN_TYPES, "terrain"),
    "props": (lambda item: "prop", {"prop": Prop}, "prop"),
    "throws": (_throw_tag, {"throw": Throw, "random": ThrowSeries}, "throw"),
    "animals": (_animal_tag, {"animal": AnimalEntry, "grid": AnimalGrid}, "animal"),
}
"""Lists whose items are validated one by one, so that errors point inside the right item:
list key -> (item -> its type tag, tag -> model, what an item is called)."""


# --------------------------------------------------------------------------- quantities in a scene


_MARKERS = (Quantity, Items, Waypoints, Bounds)


def _markers(info: Any) -> list[Any]:
    """The markers of a field, on the field itself or inside an optional type (`X | None`)."""
    found = [m for m in info.metadata if isinstance(m, _MARKERS)]
    for arm in (
        typing.get_args(info.annotation) if typing.get_origin(info.annotation) in (Union, types.UnionType) else ()
    ):
        found += [m for m in getattr(arm, "__metadata__", ()) if isinstance(m, _MARKERS)]
    return found


def iter_quantities(
    model: BaseModel, path: tuple[Any, ...] = ()
) -> Iterator[tuple[tuple[Any, ...], Any, Expect, Bounds | None]]:
    """Every quantity in a validated scene: (path in the file, value as written, expected kind, bounds)."""
    for name, info in type(model).model_fields.items():
        value = getattr(model, name)
        if value is None:
            continue
        here = path + (info.alias or name,)
        marks = _markers(info)
        bounds = next((m for m in marks if isinstance(m, Bounds)), None)
        for mark in marks:
            if isinstance(mark, Quantity):
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


def is_zero(value: Any) -> bool:
    """Plain 0 (or a vector of them) needs no unit: it is zero in every unit."""
    if isinstance(value, list):
        return all(is_zero(item) for item in value)
    return isinstance(value, (int, float)) and not isinstance(value, bool) and value == 0
