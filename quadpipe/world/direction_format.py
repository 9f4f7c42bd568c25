"""The direction format: an animal's path and its beats along it, as an animator blocks a shot.

A scene's `direction:` section and a direction file (`--direction FILE`, `DirectionFile`)
hold the same thing: animal name -> `AnimalDirection`. The models follow the scene format's
conventions (`quadpipe.world.format`): quantities carry their markers, so units are checked
and values evaluated like every other scene value, and every `description` is user
documentation in the JSON Schema.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Discriminator, Field, Tag, model_validator

from quadpipe.core.yamlio import Name
from quadpipe.quantities import fields, units
from quadpipe.quantities.expressions import SCALAR, Expect
from quadpipe.quantities.fields import NON_NEGATIVE, POSITIVE, Items, described, quantity

LENGTH = fields.with_example(fields.LENGTH, "3 HP")
ANGLE = fields.with_example(fields.ANGLE, "180 deg")
POINT = fields.with_example(fields.POINT, "[4 HP, 0, 0]")
SPEED = Expect(SCALAR, (units.VELOCITY,), "velocity", "froude_speed(0.15)")
TIME = Expect(SCALAR, (units.TIME,), "time", "6 s")
MAX_PATH_POINTS = 1000
"""Most points one path may have (an animator's curve has 50 to 500; each becomes a few points
of the controller's tables, up to 6 for a smooth path, twice that in its tangent's: see
`MAX_TABLE_POINTS`)."""


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", populate_by_name=True)


class DirectionPath(_Model):
    """The line the animal's pelvis follows over the ground: points, or a curve file."""

    points: Annotated[
        list[quantity(POINT)] | None,
        Items(POINT),
        Field(
            None,
            min_length=2,
            max_length=MAX_PATH_POINTS,
            description=f"The path's points `[x, y, z]` in world coordinates (z is ignored: the animal walks on whatever is below), from where the animal starts; 2 to {MAX_PATH_POINTS} points. Each is a point a move can end at (`to`, counted from 0).",
        ),
    ]
    file: Annotated[
        str | None,
        Field(
            None,
            description="Instead of `points`: a curve drawn in the set, relative to this file: an OBJ polyline (its vertices in the order its first `l` line joins them, metres), a glTF/GLB file's first line (a LINE_STRIP or LINES primitive, with its node's world transform) or a USD file's first `BasisCurves` (its first curve's points, in world metres). Its axes are read as a set file's of the same format (see `up`), so a path and a set drawn in one scene line up. Its points are the path's points.",
        ),
    ]
    up: Annotated[
        Literal["y", "z"] | None,
        Field(
            None,
            description="The curve file's up axis, as a set's `up:`. `y`: the file's x is quadpipe's left, y up, z forward (as the .glb and .bvh exports); `z`: the file's axes are quadpipe's. Default: y for glTF and OBJ (Blender's OBJ export), a USD stage's `upAxis`.",
        ),
    ]
    smooth: Annotated[
        bool,
        Field(
            False,
            description="`true`: a smooth curve through the points (a Catmull-Rom spline); `false`: straight lines between them.",
        ),
    ]

    @model_validator(mode="after")
    def _points_or_file(self) -> DirectionPath:
        if (self.points is None) == (self.file is None):
            raise ValueError("give either `points` or a curve `file`")
        return self


class Move(_Model):
    """Go along the path to one of its points, at a speed or arriving at a time."""

    to: Annotated[int, Field(ge=1, description="The path point this move ends at (counted from 0; 0 is the start).")]
    speed: Annotated[
        quantity(SPEED, POSITIVE) | None,
        Field(None, description=described("The speed along the path.", SPEED)),
    ]
    froude: Annotated[
        float | None,
        Field(None, gt=0, le=5, description="The speed as a Froude number, speed^2 / (g HP): 0.15 a walk, 0.6 a trot."),
    ]
    at: Annotated[
        quantity(TIME, NON_NEGATIVE) | None,
        Field(None, description=described("When the animal arrives at `to`, from the start of the shot.", TIME)),
    ]

    gait: Annotated[
        Literal["auto", "walk", "trot", "gallop"],
        Field(
            "auto",
            description="`auto`: the species' gait for the speed (its walk, trot or amble, gallop); or the gait to use whatever the speed: `walk`, `trot` (the species' running gait: an amble for a species that does not trot) or `gallop` (a trot for a species that does not gallop).",
        ),
    ]

    look_at: Annotated[
        quantity(POINT) | None,
        Field(
            None,
            description=described(
                "A point the head and neck turn to during this beat, in world coordinates (z up from the ground).",
                POINT,
            ),
        ),
    ]

    @model_validator(mode="after")
    def _one_pace(self) -> Move:
        if sum(value is not None for value in (self.speed, self.froude, self.at)) != 1:
            raise ValueError("give exactly one of `speed`, `froude` and `at`")
        return self


class Hold(_Model):
    """Come to a stand where the animal is, all four feet down, and stay for a while."""

    hold: Annotated[
        quantity(TIME, POSITIVE), Field(description=described("How long it stands, from the start of the stop.", TIME))
    ]
    pose: Annotated[
        Literal["stand", "sit", "lie"],
        Field(
            "stand",
            description="How it holds: `stand` on four feet, `sit` (hind legs folded under it, front legs straight), or `lie` (all four folded); it stands up again before the next move.",
        ),
    ]
    look_at: Annotated[
        quantity(POINT) | None,
        Field(
            None,
            description=described(
                "A point the head and neck turn to during this beat, in world coordinates (z up from the ground).",
                POINT,
            ),
        ),
    ]


class Turn(_Model):
    """Turn where the animal is, stepping on the spot (on a tight radius), by an angle."""

    turn: Annotated[
        quantity(ANGLE),
        Field(description=described("How far it turns: positive to its left, negative to its right.", ANGLE)),
    ]
    for_: Annotated[
        quantity(TIME, POSITIVE),
        Field(alias="for", description=described("How long the turn takes.", TIME)),
    ]


def _beat_tag(value: Any) -> str:
    if value == "stop" or isinstance(value, str):
        return "stop"
    if isinstance(value, dict):
        return "hold" if "hold" in value else "turn" if "turn" in value else "move"
    return "hold" if isinstance(value, Hold) else "turn" if isinstance(value, Turn) else "move"


Beat = Annotated[
    Annotated[Move, Tag("move")]
    | Annotated[Hold, Tag("hold")]
    | Annotated[Turn, Tag("turn")]
    | Annotated[Literal["stop"], Tag("stop")],
    Discriminator(_beat_tag),
]


class AnimalDirection(_Model):
    """One animal's shot: its own path and beats, played in order from the start; or another
    animal's followed (`follow`): its path shifted back and to the side, and its beats."""

    path: Annotated[DirectionPath | None, Field(None, description="The path (with `beats`).")]
    beats: Annotated[
        list[Beat] | None,
        Field(
            None,
            min_length=1,
            description="What the animal does, in order: moves (`{to: 2, speed: froude_speed(0.15)}`, `{to: 3, at: 8 s}`), holds (`{hold: 2 s}`), turns (`{turn: 180 deg, for: 3 s}`), and `stop` (stand still to the end; the shot also ends standing after its last move).",
        ),
    ]
    follow: Annotated[
        str | None,
        Field(
            None,
            description="Instead of a path and beats: the animal followed, one with a `path` and `beats` of its own in this direction.",
        ),
    ]
    behind: Annotated[
        quantity(LENGTH, NON_NEGATIVE),
        Field("3 HP", description=described("With `follow`: how far behind it, along its path.", LENGTH)),
    ]
    aside: Annotated[
        quantity(LENGTH),
        Field(
            0,
            description=described(
                "With `follow`: how far to its left (negative: to its right), across its path.", LENGTH
            ),
        ),
    ]

    @model_validator(mode="after")
    def _one_kind(self) -> AnimalDirection:
        if self.follow is None and (self.path is None or self.beats is None):
            raise ValueError("give a `path` and `beats`, or `follow` (an animal to follow)")
        if self.follow is not None and (self.path is not None or self.beats is not None):
            raise ValueError("a follower takes its leader's path and beats: give `follow`, or a `path` and `beats`")
        return self


DIRECTION_DESCRIPTION = "How the animals are directed, by animal name (the default animal is named after its species, e.g. `dog`): a path and beats along it, or another animal followed (docs/direction.md)."

DirectionField = Annotated[dict[str, AnimalDirection], Field({}, description=DIRECTION_DESCRIPTION)]
"""The `direction:` mapping, in a scene or a direction file."""


class DirectionFile(_Model):
    """Schema of a direction file (`--direction FILE` on `simulate` and `bake`)."""

    schema_: Annotated[int, Field(alias="schema", description="Format version; this quadpipe reads `1`.")]
    name: Annotated[Name | None, Field(None, description="Name of the shot.")]
    description: Annotated[str, Field("", description="One line about the shot.")]
    direction: DirectionField
