"""The controller file format: pydantic models of `configs/controllers/<name>.yaml`.

These models check a file's structure (keys, nesting, value shapes). The meaning of the
values — units, names, roles, references — is checked afterwards (`semantics.py`), which
finds the fields to check through the markers placed in their `Annotated` types
(`Quantity`, `BodyPoint`, `PointMap`, `RoleGlobs`, `LegSet`, `FrameName`, `ElementNames`).
The same models generate the JSON Schema (`schemas/controller.schema.json`) and the key
reference in `docs/controllers.md`, so every key's `description` is user documentation.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated, Any, Literal, Union, get_args

from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, PlainValidator, WithJsonSchema

from quadpipe.anatomy.roles import LEGS, ROLES
from quadpipe.core.yamlio import Name
from quadpipe.quantities import units
from quadpipe.quantities.expressions import BOOL, LEG_LANDMARKS, POINT_ANCHORS, SCALAR, VECTOR, Expect
from quadpipe.quantities.fields import ANGLE, LENGTH, POINT, TIME, AnyValue, Value, quantity
from quadpipe.quantities.fields import VECTOR_INPUT as _VECTOR_INPUT
from quadpipe.quantities.fields import Quantity as Quantity  # re-exported: the language code reads the marker here
from quadpipe.quantities.fields import described as _doc
from quadpipe.quantities.fields import kind_of as _kind_of

SCHEMA_VERSION = 1
"""The only `schema:` version this quadpipe reads."""

LEG_PLACEHOLDER = "{leg}"
"""Replaced by each leg prefix in elements and parameters with `for_each`."""

PAIR_PLACEHOLDER = "{pair}"
"""Replaced by `front` or `hind`, the leg's pair, in elements and parameters with `for_each`."""

FRAMES: tuple[str, ...] = ("heading", "world")
"""Frames a constant vector may be given in, besides a role's own frame."""

# Expected kinds and dimensions of the quantity fields.
FORCE = Expect(SCALAR, (units.FORCE,), "force", "0.3 bw")
NUMBER = Expect(SCALAR, (units.NONE,), "number", "1.3")
STIFFNESS = Expect(SCALAR, (units.STIFFNESS,), "stiffness (force/length)", "20 bw/HP")
DAMPING = Expect(SCALAR, (units.DAMPING,), "damping (force x time/length)", "0.5 bw*s/HP")
ANGULAR_STIFFNESS = Expect(SCALAR, (units.ANGULAR_STIFFNESS,), "angular stiffness (torque/angle)", "0.2 bw*HP/rad")
ANGULAR_DAMPING = Expect(SCALAR, (units.ANGULAR_DAMPING,), "angular damping (torque x time/angle)", "0.01 bw*HP*s/rad")
LENGTH2_FACTOR = Expect(SCALAR, (units.LENGTH2_FACTOR,), "force per squared length", "0.5 bw/HP^2")
DIRECTION = Expect(VECTOR, None, "vector", "[0, 0, -1]")
CONDITION = Expect(BOOL, None, "condition", "angle(a, b) > 20 deg")


# --------------------------------------------------------------------------- markers


@dataclass(frozen=True)
class BodyPoint:
    """Marks a field naming a point on the body: `role`, `role.start|end|mid`, `leg.top|foot`."""


@dataclass(frozen=True)
class PointMap:
    """Marks a mapping of body points to values of the `expect`ed kind."""

    expect: Expect


@dataclass(frozen=True)
class RoleGlobs:
    """Marks a list of roles or shell-style globs over roles (`spine*`, `*_hip`)."""


@dataclass(frozen=True)
class LegSet:
    """Marks a list of legs (`lf`, `rf`, `lh`, `rh`) or leg group names."""


@dataclass(frozen=True)
class FrameName:
    """Marks a frame: `heading`, `world` or a role."""


@dataclass(frozen=True)
class ElementNames:
    """Marks a list of element names (or globs over them)."""


# --------------------------------------------------------------------------- value types


def _string(value: Any) -> str:
    if not isinstance(value, str):
        raise ValueError(f"expected a name, got {_kind_of(value)}")
    return value


def _string_list(value: Any) -> list[str]:
    items = value if isinstance(value, list) else [value]
    for item in items:
        _string(item)
    return list(items)


_POINT_NAMES: list[str] = [
    *ROLES,
    *(f"{role}.{anchor}" for role in ROLES for anchor in POINT_ANCHORS),
    *(f"{leg}.{mark}" for leg in LEGS for mark in LEG_LANDMARKS),
]
_POINT_JSON = {
    "anyOf": [
        {"type": "string", "enum": _POINT_NAMES},
        {"type": "string", "pattern": r"\{leg\}"},
    ]
}

PointName = Annotated[str, PlainValidator(_string), WithJsonSchema(_POINT_JSON), BodyPoint()]
Names = Annotated[list[str], BeforeValidator(_string_list, json_schema_input_type=Union[str, list[str]])]


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", populate_by_name=True)


# --------------------------------------------------------------------------- parts


class Direction(_Model):
    """Where a force points. Give exactly one of `vector`, `toward` or `balance`."""

    vector: Annotated[
        quantity(DIRECTION),
        Field(
            None,
            description=_doc(
                "A direction given as a vector (or a vector expression) in `frame`; its length does not matter.",
                DIRECTION,
            ),
        ),
    ]
    frame: Annotated[
        str,
        FrameName(),
        Field(
            "heading",
            description="Frame of `vector`: `heading` (x where the animal faces, horizontally; y its left; z up), `world`, or a role (that bone's frame, which matches the body frame in the rest pose).",
        ),
    ]
    toward: Annotated[
        quantity(POINT),
        Field(
            None,
            description=_doc(
                "Point at a place: the force points from where it acts (a segment's `from` end, or `at`) toward this world point, usually a parameter that the scene sets.",
                POINT,
            ),
        ),
    ]
    balance: Annotated[
        PointName | None,
        Field(
            None,
            description="Point along the balance vector (gravity + velocity, thesis §4.3) measured at this body point, e.g. `lh.top`.",
        ),
    ]
    horizon: Annotated[
        quantity(TIME),
        Field(
            "1 s",
            description=_doc(
                "For `balance`: how far ahead the velocity counts; the balance vector is g + velocity / horizon (the thesis used 1 s).",
                TIME,
            ),
        ),
    ]
    horizontal: Annotated[
        bool, Field(False, description="Drop the vertical part before use, so the force only pulls along the ground.")
    ]


def _direction_shorthand(value: Any) -> Any:
    return {"vector": value} if isinstance(value, (list, str)) else value


DirectionField = Annotated[
    Direction, BeforeValidator(_direction_shorthand, json_schema_input_type=Union[Direction, _VECTOR_INPUT, str])
]


class Strength(_Model):
    """How hard a segment pushes. Give exactly one of `force` or `length2`."""

    force: Annotated[quantity(FORCE), Field(None, description=_doc("The force applied at each end.", FORCE))]
    length2: Annotated[
        quantity(LENGTH2_FACTOR),
        Field(
            None,
            description=_doc(
                "The thesis's rule (§5.1): force = (rest length of the segment)² x this factor; `bw/HP^2` keeps it the same for every animal.",
                LENGTH2_FACTOR,
            ),
        ),
    ]


def _strength_shorthand(value: Any) -> Any:
    return {"force": value} if isinstance(value, (int, float, str)) and not isinstance(value, bool) else value


StrengthField = Annotated[
    Strength, BeforeValidator(_strength_shorthand, json_schema_input_type=Union[float, str, Strength])
]


class Elastic(_Model):
    """An elastic between a segment's two ends holding a length (thesis §4.2)."""

    rest_length: Annotated[
        quantity(LENGTH),
        Field(
            "rest",
            description=_doc(
                "Length the elastic holds before `ratio`; `rest` is the distance between the two ends in the rest pose.",
                LENGTH,
            ),
        ),
    ]
    ratio: Annotated[
        quantity(NUMBER),
        Field(
            1,
            description=_doc(
                "The held length is rest_length x ratio; above 1 pushes the ends apart (the thesis needed 1.3 to stand against gravity).",
                NUMBER,
            ),
        ),
    ]
    stiffness: Annotated[
        quantity(STIFFNESS),
        Field(
            description=_doc(
                "Force per unit of length error: the ends are pulled together when too long, pushed apart when too short.",
                STIFFNESS,
            )
        ),
    ]
    damping: Annotated[
        quantity(DAMPING),
        Field("0 bw*s/HP", description=_doc("Force per unit of lengthening speed, against oscillation.", DAMPING)),
    ]


class State(_Model):
    """One state of a state machine: what changes while it is active."""

    description: Annotated[str, Field("", description="What the state means, for animators.")]
    enable: Annotated[
        Names,
        ElementNames(),
        Field([], description="Force elements switched on while in this state (names or globs, e.g. `{leg}_seek`)."),
    ]
    disable: Annotated[Names, ElementNames(), Field([], description="Force elements switched off while in this state.")]
    parameters: Annotated[
        dict[str, AnyValue],
        Field(
            {},
            description="Parameter values while in this state; every force element using them follows, while transitions keep the controller's values (the thesis's postures are three sets of leg ratios).",
        ),
    ]
    set: Annotated[
        dict[str, dict[str, Any]],
        Field(
            {},
            description='Element keys changed while in this state: element name -> the keys to change, as in the element (e.g. `{leg}_leg: {direction: {balance: "{leg}.top"}}`).',
        ),
    ]


class Transition(_Model):
    """A way out of one or more states, tried in list order every step."""

    from_: Annotated[Names, Field(alias="from", description="State(s) this transition leaves, or `*` for any state.")]
    to: Annotated[str, Field(description="State it enters.")]
    when: Annotated[
        quantity(CONDITION),
        Field(
            None,
            description=_doc(
                "Condition that fires it; `time_in_state`, `contact(leg)`, `phase(cycle)`, `angle(a, b)` and sensors are available. Without it, it fires as soon as `after` has passed.",
                CONDITION,
            ),
        ),
    ]
    after: Annotated[
        quantity(TIME),
        Field(
            "0 s",
            description=_doc(
                "Minimum time in the current state before it may fire; with two thresholds (leave above 25 deg, come back below 10 deg) this gives hysteresis.",
                TIME,
            ),
        ),
    ]


# --------------------------------------------------------------------------- elements


FOR_EACH_HELP = "legs (`lf`, `rf`, `lh`, `rh`) or groups (`all_legs`, `front_legs`, `hind_legs`, `left_legs`, `right_legs`, or your own)"
"""What `for_each` lists, for the reference."""


class _Element(_Model):
    name: Annotated[Name, Field(description="Unique name of the element; with `for_each` it must contain `{leg}`.")]
    description: Annotated[str, Field("", description="What the element does, for animators.")]
    for_each: Annotated[
        Names | None,
        LegSet(),
        Field(
            None,
            description=f"Make one copy per leg: {FOR_EACH_HELP}; `{{leg}}` in any text of the element becomes the leg, `{{pair}}` its pair (`front` or `hind`).",
        ),
    ]


class _ForceElement(_Element):
    enabled: Annotated[bool, Field(True, description="Whether it acts when no state machine says otherwise.")]


class Spring(_ForceElement):
    """Angular springs pulling joints back to their rest angle, or to a given angle (thesis §4.1)."""

    type: Annotated[Literal["spring"], Field(description="Element type.")]
    joints: Annotated[
        Names,
        RoleGlobs(),
        Field(
            description="Joints by role, one or a list, globs allowed: `spine*`, `*_hip`, `*_*` (every leg joint). A joint is named after the bone below it. A spring acts on every axis of a joint (the twist toward `target`, the swings toward 0); `lh_hip.swing1` picks one axis (`twist`, `swing1` about the forward axis, `swing2` about the vertical)."
        ),
    ]
    target: Annotated[
        quantity(ANGLE),
        Field(
            "rest",
            description=_doc(
                "Twist angle the springs pull toward, from the rest pose (`rest` = 0 deg). Positive twist lowers a forward-pointing bone and swings a downward bone's far end backward.",
                ANGLE,
            ),
        ),
    ]
    stiffness: Annotated[
        quantity(ANGULAR_STIFFNESS),
        Field(description=_doc("Torque per angle away from the target.", ANGULAR_STIFFNESS)),
    ]
    damping: Annotated[
        quantity(ANGULAR_DAMPING),
        Field("0 bw*HP*s/rad", description=_doc("Torque per angular speed, against oscillation.", ANGULAR_DAMPING)),
    ]


class Segment(_ForceElement):
    """A control segment (thesis §4.2): a force couple between two body points that turns the segment toward a direction and can hold its length with an elastic."""

    type: Annotated[Literal["segment"], Field(description="Element type.")]
    from_: Annotated[PointName, Field(alias="from", description="First end: pushed against `direction`.")]
    to: Annotated[PointName, Field(description="Second end: pushed along `direction`.")]
    direction: Annotated[
        DirectionField | None,
        Field(
            None,
            description="Direction the segment should take, from `from` to `to`: a vector `[x, y, z]` (heading frame), or `{toward: ...}`, `{balance: ...}`, `{vector: ..., frame: ...}`.",
        ),
    ]
    strength: Annotated[
        StrengthField | None,
        Field(
            None,
            description="Force applied at each end along `direction`: a force (`0.3 bw`) or `{length2: 0.5 bw/HP^2}`. Required with `direction`.",
        ),
    ]
    elastic: Annotated[Elastic | None, Field(None, description="Elastic holding the distance between the ends.")]


class ForcePair(_ForceElement):
    """A force at one point whose opposite is shared among other points, so that the forces cancel (the thesis's rudder, §5.6)."""

    type: Annotated[Literal["force_pair"], Field(description="Element type.")]
    at: Annotated[PointName, Field(description="Where the force acts.")]
    direction: Annotated[DirectionField, Field(description="Where the force points (see Direction).")]
    strength: Annotated[quantity(FORCE), Field(description=_doc("Size of the force.", FORCE))]
    reaction: Annotated[
        dict[str, Value],
        PointMap(NUMBER),
        Field(
            description="Body points taking the opposite force, with relative weights (`thorax.mid: 0.5`); weights are normalised to sum to 1."
        ),
    ]


class Pull(_ForceElement):
    """An outside force on one point, for a time window (the thesis's leash, §5.4)."""

    type: Annotated[Literal["pull"], Field(description="Element type.")]
    at: Annotated[PointName, Field(description="Where the force acts.")]
    direction: Annotated[DirectionField, Field(description="Where the force points (see Direction).")]
    strength: Annotated[quantity(FORCE), Field(description=_doc("Size of the force.", FORCE))]
    start: Annotated[quantity(TIME), Field("0 s", description=_doc("When the pull begins.", TIME))]
    stop: Annotated[quantity(TIME), Field(None, description=_doc("When it ends; never if left out.", TIME))]
    ramp: Annotated[
        quantity(TIME), Field("0 s", description=_doc("Time to fade in after `start` (and out before `stop`).", TIME))
    ]


class Cycle(_ForceElement):
    """Forces turning about an axis with a period, one per site with its own phase (the thesis's pedal at hips and shoulders, §5.6)."""

    type: Annotated[Literal["cycle"], Field(description="Element type.")]
    sites: Annotated[
        dict[str, Value],
        PointMap(NUMBER),
        Field(
            description="Body points that get a turning force -> their phase offset in cycles (0.5 = half a period later, i.e. opposite)."
        ),
    ]
    period: Annotated[
        quantity(TIME),
        Field(description=_doc("Duration of one turn; the phase follows smoothly when it changes.", TIME)),
    ]
    strength: Annotated[quantity(FORCE), Field(description=_doc("Size of each site's force.", FORCE))]
    axis: Annotated[
        quantity(DIRECTION),
        Field(
            [0, 1, 0],
            description=_doc("Axis the forces turn about, in `frame`; the default is across the spine.", DIRECTION),
        ),
    ]
    reference: Annotated[
        quantity(DIRECTION),
        Field(
            [1, 0, 0],
            description=_doc(
                "Direction of a site's force at phase 0, in `frame`; it then turns about `axis` (right-hand rule). Must not be parallel to `axis`.",
                DIRECTION,
            ),
        ),
    ]
    frame: Annotated[
        str, FrameName(), Field("heading", description="Frame of `axis` and `reference`: `heading`, `world` or a role.")
    ]


SENSOR_KINDS: dict[str, str] = {
    "balance": "gravity + velocity / horizon at `at` (thesis §4.3), a vector of accelerations",
    "contact_normal": "mean normal of the ground under the feet in contact (world, length 1; straight up when none touches)",
    "velocity": "velocity of `at`, a vector of velocities",
    "height": "height of `at` above the ground below it, a length",
}
"""What each sensor kind measures, for the reference."""


class Sensor(_Element):
    """A measurement of the simulation, usable by name in expressions."""

    type: Annotated[Literal["sensor"], Field(description="Element type.")]
    kind: Annotated[
        Literal["balance", "contact_normal", "velocity", "height"],
        Field(description="What it measures: " + "; ".join(f"`{k}`: {v}" for k, v in SENSOR_KINDS.items()) + "."),
    ]
    at: Annotated[PointName | None, Field(None, description="Body point measured (`balance`, `velocity`, `height`).")]
    feet: Annotated[
        Names | None,
        LegSet(),
        Field(None, description="For `contact_normal`: the legs whose feet count (default all legs)."),
    ]
    horizon: Annotated[
        quantity(TIME),
        Field(None, description=_doc("For `balance`: how far ahead the velocity counts (default 1 s).", TIME)),
    ]
    smoothing: Annotated[
        quantity(TIME),
        Field("0 s", description=_doc("Time constant of a low-pass filter on the value, against jitter.", TIME)),
    ]


class StateMachine(_Element):
    """Named states that switch elements on and off or change their values, with transitions between them (the thesis's leg states, §5.4-5.5)."""

    type: Annotated[Literal["state_machine"], Field(description="Element type.")]
    initial: Annotated[str, Field(description="State at the start.")]
    states: Annotated[dict[str, State], Field(description="State name -> what it changes.")]
    transitions: Annotated[
        list[Transition], Field([], description="Transitions, tried in order each step; the first that fires wins.")
    ]


ELEMENT_TYPES: tuple[type[_Element], ...] = (Spring, Segment, ForcePair, Pull, Cycle, Sensor, StateMachine)
"""Every element model, in the order the reference documents them."""

ELEMENT_TYPE_NAMES: tuple[str, ...] = tuple(
    get_args(model.model_fields["type"].annotation)[0] for model in ELEMENT_TYPES
)

FORCE_ELEMENT_TYPES: tuple[str, ...] = ("spring", "segment", "force_pair", "pull", "cycle")
"""Element types that can be switched on and off."""

Element = Annotated[Spring | Segment | ForcePair | Pull | Cycle | Sensor | StateMachine, Field(discriminator="type")]
"""Any element, told apart by its `type`."""

MODEL_OF_TYPE: dict[str, type[_Element]] = dict(zip(ELEMENT_TYPE_NAMES, ELEMENT_TYPES))


class Parameter(_Model):
    """A parameter with a description (the short form is just `name: value`): a derived value or a formula the elements use."""

    value: Annotated[AnyValue, Field(description="The value: a number with a unit, a vector or an expression.")]
    description: Annotated[str, Field("", description="What it controls, for animators.")]
    for_each: Annotated[
        Names | None,
        Field(
            None,
            description=f"Make one parameter per leg: {FOR_EACH_HELP}; its name must contain `{{leg}}`, which becomes the leg in the name, the value and the description, as does `{{pair}}` (`front` or `hind`).",
        ),
    ]


class Tunable(Parameter):
    """A knob an animator turns: a constant with a range, listed by `quadpipe controllers NAME` (the short form `name: value` changes the value of a tunable of the extended controller)."""

    description: Annotated[
        str,
        Field(
            "",
            description="What it changes in the motion, for animators; may be left out where the extended controller's tunable of the same name has one.",
        ),
    ]
    min: Annotated[
        Value | None,
        Field(
            None,
            description="Smallest value allowed, in the value's kind of unit (`0.1 bw`; a bare `0` is zero in any unit); may be left out where the extended controller's tunable of the same name has one. A value below it is an error.",
        ),
    ]
    max: Annotated[Value | None, Field(None, description="Largest value allowed (`1 bw`), likewise.")]


def _parameter_shorthand(value: Any) -> Any:
    return value if isinstance(value, dict) else {"value": value}


ParameterField = Annotated[
    Parameter, BeforeValidator(_parameter_shorthand, json_schema_input_type=Union[float, str, _VECTOR_INPUT, Parameter])
]
TunableField = Annotated[
    Tunable, BeforeValidator(_parameter_shorthand, json_schema_input_type=Union[float, str, Tunable])
]


class ControllerFile(_Model):
    """A controller: parameters and the elements that push the animal around."""

    schema_: Annotated[
        int, Field(alias="schema", description=f"Version of this file format; write `{SCHEMA_VERSION}`.")
    ]
    name: Annotated[Name, Field(description="Name of the controller, as used on the command line.")]
    description: Annotated[str, Field("", description="What the controller does, for animators.")]
    extends: Annotated[
        str | None,
        Field(
            None,
            description="Controller to start from (a name like `rigid`, or a path relative to this file); this file's tunables, parameters and elements are added to its, replacing those with the same name.",
        ),
    ]
    tunables: Annotated[
        dict[Name, TunableField],
        Field(
            {},
            description="The knobs of the controller: named constants with a description and a range, used by the elements like parameters and set like them (`--set name=value`, a scene's `parameters:`).",
        ),
    ]
    parameters: Annotated[
        dict[Name, ParameterField],
        Field(
            {},
            description="Named values used by the elements: derived values and formulas (tune the controller with its `tunables`). A value is a number with a unit, a vector or an expression.",
        ),
    ]
    groups: Annotated[dict[str, Names], Field({}, description="Your own leg groups for `for_each`: name -> legs.")]
    remove: Annotated[
        Names, ElementNames(), Field([], description="Elements of the extended controller to drop (names or globs).")
    ]
    override: Annotated[
        dict[str, dict[str, Any]],
        Field(
            {},
            description="Keys to change in elements of the extended controller: element name -> keys, as in the element; `null` deletes a key.",
        ),
    ]
    elements: Annotated[list[Element], Field([], description="The forces, sensors and state machines.")]
