"""Safe quantity expressions: parsing, type and dimension checking, compiling to numpy.

Controller values are numbers with units (`38/30 s`, `0.5 bw`), vectors (`[0, 0, -1]`) or
expressions over them (`0.3 bw * smoothstep(1 s, 2 s, t)`). Text is parsed with Python's
`ast` after two rewrites: a unit written after a number binds to it (`38/30 s` is
`(38/30)*s`, `x / 2 s` is `x / (2*s)`), and `^` means a power. Only a whitelist of syntax
is accepted (arithmetic, comparisons, `and`/`or`/`not`, `a if c else b`, vector literals,
calls of the functions in `FUNCTIONS`, `role.start`-style points and `.x/.y/.z` components);
anything else is refused before evaluation, so no Python object is ever reached.

Checking gives every node a `Type` (scalar, vector or condition, with a `Dim`) and rejects
mixed dimensions. Compiling for a `Scale` (one value per animal) gives a `Compiled`
callable `f(env) -> array` evaluated for all animals at once: scalars are arrays of shape
(n,), vectors (n, 3), conditions boolean (n,). Sub-expressions that need nothing from the
simulation are folded to constants at compile time.

The simulation state reaches an expression through `env`, a mapping of keys to arrays:

- `t`: time since the controller started, in seconds.
- `point:<role>.<start|end|mid>`: world position of a body point, in metres.
- `sensor:<name>`: a sensor's value (see the `sensor` element).
- `phase:<cycle>`: a cycle element's phase, in cycles, in [0, 1).
- `contact:<leg>`: whether that leg's foot touches something (boolean).
- `time_in_state:<machine>`: time since that state machine entered its current state, in s.
- `frame:heading`: rotation matrices (n, 3, 3) from the heading frame to the world.

`Compiled.needs` lists the keys an expression reads, so a runtime computes only those.
Division by zero gives 0 and `normalize` of a zero vector gives zero: a degenerate pose
yields no force rather than a NaN (which would make MuJoCo reset silently).
"""

from __future__ import annotations

import ast
import io
import math
import tokenize
from dataclasses import dataclass, field
from fractions import Fraction
from functools import cached_property
from typing import Any, Callable, Collection, Mapping, Sequence

import numpy as np

from quadpipe.anatomy.roles import LEGS, PARENT, ROLES
from quadpipe.quantities import units
from quadpipe.core.errors import did_you_mean

Env = Mapping[str, np.ndarray]
"""What a compiled expression reads: env key -> array over animals (see module docstring)."""

SCALAR, VECTOR, BOOL = "scalar", "vector", "bool"

POINT_ANCHORS: tuple[str, ...] = ("start", "end", "mid")
"""Where on a bone a point lies: its proximal joint, its far end, halfway."""

LEG_LANDMARKS: dict[str, dict[bool, str]] = {
    "top": {True: "scapula.start", False: "hip.start"},
    "foot": {True: "fpha1.end", False: "hpha2.end"},
}
"""Leg points usable on every leg: `<leg>.top` (where the leg meets the trunk) and
`<leg>.foot` (the tip of the toes); keyed by landmark, then by "is a front leg"."""

COMPONENTS: dict[str, int] = {"x": 0, "y": 1, "z": 2}
"""Vector components: `v.x` (forward in the body frame), `v.y` (left), `v.z` (up)."""

CONSTANTS: dict[str, float] = {"pi": math.pi}
"""Named pure numbers."""

TIME_VARIABLE = "t"
"""The variable holding the time since the controller started."""

ZERO_NORM = 1e-12
"""Vectors shorter than this have no direction: `normalize` returns zero for them."""


class ExprError(Exception):
    """A problem in one expression, with a stable code and an optional hint."""

    def __init__(self, code: str, message: str, hint: str | None = None) -> None:
        super().__init__(message)
        self.code = code
        self.message = message
        self.hint = hint


@dataclass(frozen=True)
class Type:
    """The type of a value: `scalar`, `vector` (3 components) or `bool`, with a dimension."""

    kind: str
    dim: units.Dim = units.NONE

    def describe(self) -> str:
        """Name it for a message: `a time`, `a vector of lengths`, `a condition`."""
        if self.kind == BOOL:
            return "a condition (true/false)"
        if self.kind == VECTOR:
            return "a direction vector (no unit)" if self.dim.is_none else f"a vector of {units.dimension_name(self.dim, plural=True)}"
        return units.dimension_name(self.dim)


NUMBER = Type(SCALAR)
CONDITION = Type(BOOL)
POINT_TYPE = Type(VECTOR, units.LENGTH)


@dataclass(frozen=True)
class Expect:
    """What a field accepts: a kind and one of some dimensions (None: any dimension).

    Attributes:
        kind: `scalar`, `vector` or `bool`.
        dims: accepted dimensions, or None for any.
        label: short name for documentation (`time`, `force`).
        example: a valid value, shown in documentation and hints.
    """

    kind: str
    dims: tuple[units.Dim, ...] | None
    label: str
    example: str

    def describe(self) -> str:
        """Name the expectation for a message."""
        if self.dims is None:
            return {VECTOR: "a vector", SCALAR: "a number", BOOL: "a condition (true/false)"}[self.kind]
        names = [Type(self.kind, dim).describe() for dim in self.dims]
        return " or ".join(names)

    def accepts(self, typ: Type) -> bool:
        """Whether a value of type `typ` fits."""
        return typ.kind == self.kind and (self.dims is None or typ.dim in self.dims)


@dataclass(frozen=True, eq=False)
class Expr:
    """A checked expression node.

    Attributes:
        op: what the node does (`num`, `unit`, `var`, `add`, `call`, ...).
        type: its type.
        args: child nodes.
        value: the op's datum: a number in SI (`num`), a unit symbol (`unit`), an env key
            (`var`), a function name (`call`), comparison operators (`cmp`), an index (`comp`).
        text: the source text, for the top node of a field or parameter.
    """

    op: str
    type: Type
    args: tuple["Expr", ...] = ()
    value: Any = None
    text: str = ""

    @cached_property
    def needs(self) -> frozenset[str]:
        """Env keys this expression reads (compile-time keys like `rest:` excluded)."""
        own = {self.value} if self.op == "var" and not str(self.value).startswith(REST_PREFIX) else set()
        if self.op == "call" and self.value in CALL_NEEDS:
            own.add(CALL_NEEDS[self.value])
        return frozenset(own).union(*(arg.needs for arg in self.args))

    @cached_property
    def uses_scale(self) -> bool:
        """Whether the value depends on the animal (units like HP, or rest lengths)."""
        here = (self.op == "unit" and units.UNITS[self.value].scale_key is not None) or (
            self.op == "var" and str(self.value).startswith(REST_PREFIX)
        )
        return here or any(arg.uses_scale for arg in self.args)

    @property
    def is_constant(self) -> bool:
        """Whether it is known before the simulation starts (for one animal)."""
        return not self.needs


HEADING_FRAME_KEY = "frame:heading"
"""Env key of the heading frame's rotation matrices."""

CALL_NEEDS: dict[str, str] = {"heading": HEADING_FRAME_KEY}
"""Functions that read the env, and the key they read."""

REST_PREFIX = "rest:"
"""Env keys resolved at compile time from `Scale.rest_points`: `rest:<point a>|<point b>`."""


def point_key(point: str) -> str:
    """The env key of a canonical body point: `point:lf_hip.start`."""
    return f"point:{point}"


def rest_distance_key(a: str, b: str) -> str:
    """The compile-time key of the rest-pose distance between two canonical points."""
    return f"{REST_PREFIX}{a}|{b}"


# --------------------------------------------------------------------------- names


@dataclass
class Namespace:
    """The names an expression may use beyond units, functions, constants, `t` and points.

    Attributes:
        parameters: parameter name -> its checked value (inlined where used).
        sensors: sensor name -> the type of its value.
        cycles: names of cycle elements, for `phase(name)`.
        locals: names that only exist in one field (`rest`, `time_in_state`) -> their node.
        parameter_texts: parameter name -> its source text, for hints.
    """

    parameters: Mapping[str, Expr] = field(default_factory=dict)
    sensors: Mapping[str, Type] = field(default_factory=dict)
    cycles: Collection[str] = ()
    locals: Mapping[str, Expr] = field(default_factory=dict)
    parameter_texts: Mapping[str, str] = field(default_factory=dict)

    def with_locals(self, **local: Expr) -> "Namespace":
        """A copy with extra local names."""
        return Namespace(self.parameters, self.sensors, self.cycles, {**self.locals, **local}, self.parameter_texts)

    def known_names(self) -> list[str]:
        """Every name valid on its own, for "did you mean" hints."""
        return [
            *self.locals,
            *self.parameters,
            *self.sensors,
            TIME_VARIABLE,
            *CONSTANTS,
            *units.UNITS,
            *ROLES,
            *FUNCTIONS,
        ]


# --------------------------------------------------------------------------- functions


@dataclass(frozen=True)
class Function:
    """A whitelisted function.

    Attributes:
        name: how it is called.
        signature: how the reference documents it.
        description: one line for the reference.
        result: (argument types, expression text) -> result type; raises `ExprError`.
        impl: numpy implementation over arrays of all animals; None for the functions that
            read the env or the scale and are compiled specially (see `_build_call`).
    """

    name: str
    signature: str
    description: str
    result: Callable[[list[Type], str], Type]
    impl: Callable[..., np.ndarray] | None


def _arity(types: list[Type], name: str, count: int, text: str) -> None:
    if len(types) != count:
        raise ExprError(
            "wrong-arguments",
            f"in {text!r}: {name}() takes {count} argument{'s' if count != 1 else ''}, got {len(types)}",
            f"see `{FUNCTIONS[name].signature}`",
        )


def _need(typ: Type, kinds: str, dims: Sequence[units.Dim] | None, name: str, text: str) -> None:
    if typ.kind not in kinds.split("|") or (dims is not None and typ.dim not in dims):
        expected = Expect(kinds.split("|")[0], tuple(dims) if dims is not None else None, "", "").describe()
        raise ExprError(
            "wrong-type",
            f"in {text!r}: {name}() expects {expected}, got {typ.describe()}",
            f"see `{FUNCTIONS[name].signature}`",
        )


def _same_dims(types: list[Type], name: str, text: str) -> units.Dim:
    dims = {typ.dim for typ in types}
    if len(dims) > 1:
        listed = ", ".join(typ.describe() for typ in types)
        raise ExprError("dimension-mismatch", f"in {text!r}: the arguments of {name}() mix {listed}")
    return types[0].dim


def _trig(name: str) -> Callable[[list[Type], str], Type]:
    def rule(types: list[Type], text: str) -> Type:
        _arity(types, name, 1, text)
        _need(types[0], SCALAR, (units.ANGLE, units.NONE), name, text)
        return NUMBER

    return rule


def _unary_number(name: str, result: Type) -> Callable[[list[Type], str], Type]:
    def rule(types: list[Type], text: str) -> Type:
        _arity(types, name, 1, text)
        _need(types[0], SCALAR, (units.NONE,), name, text)
        return result

    return rule


def _atan2(types: list[Type], text: str) -> Type:
    _arity(types, "atan2", 2, text)
    for typ in types:
        _need(typ, SCALAR, None, "atan2", text)
    _same_dims(types, "atan2", text)
    return Type(SCALAR, units.ANGLE)


def _sqrt(types: list[Type], text: str) -> Type:
    _arity(types, "sqrt", 1, text)
    _need(types[0], SCALAR, None, "sqrt", text)
    return Type(SCALAR, types[0].dim ** Fraction(1, 2))


def _same_scalar(name: str, count: int | None) -> Callable[[list[Type], str], Type]:
    def rule(types: list[Type], text: str) -> Type:
        if count is None and len(types) < 2:
            raise ExprError("wrong-arguments", f"in {text!r}: {name}() needs at least 2 arguments", f"see `{FUNCTIONS[name].signature}`")
        if count is not None:
            _arity(types, name, count, text)
        for typ in types:
            _need(typ, SCALAR, None, name, text)
        return Type(SCALAR, _same_dims(types, name, text))

    return rule


def _sign(types: list[Type], text: str) -> Type:
    _arity(types, "sign", 1, text)
    _need(types[0], SCALAR, None, "sign", text)
    return NUMBER


def _edges(name: str, count: int) -> Callable[[list[Type], str], Type]:
    def rule(types: list[Type], text: str) -> Type:
        _arity(types, name, count, text)
        for typ in types:
            _need(typ, SCALAR, None, name, text)
        _same_dims(types, name, text)
        return NUMBER

    return rule


def _mix(types: list[Type], text: str) -> Type:
    _arity(types, "mix", 3, text)
    a, b, weight = types
    _need(weight, SCALAR, (units.NONE,), "mix", text)
    if a.kind != b.kind or a.kind == BOOL:
        raise ExprError("wrong-type", f"in {text!r}: mix() blends two numbers or two vectors, got {a.describe()} and {b.describe()}")
    return Type(a.kind, _same_dims([a, b], "mix", text))


def _vector_rule(name: str, count: int, make: Callable[[list[Type]], Type]) -> Callable[[list[Type], str], Type]:
    def rule(types: list[Type], text: str) -> Type:
        _arity(types, name, count, text)
        for typ in types:
            _need(typ, VECTOR, None, name, text)
        return make(types)

    return rule


def _froude(types: list[Type], text: str) -> Type:
    _arity(types, "froude_speed", 1, text)
    _need(types[0], SCALAR, (units.NONE,), "froude_speed", text)
    return Type(SCALAR, units.VELOCITY)


def _safe_normalize(v: np.ndarray) -> np.ndarray:
    length = np.sqrt(np.einsum("...i,...i->...", v, v))[..., None]
    return np.where(length > ZERO_NORM, v / np.maximum(length, ZERO_NORM), 0.0)


def _angle_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    cosine = np.sum(_safe_normalize(a) * _safe_normalize(b), axis=-1)
    return np.arccos(np.clip(cosine, -1.0, 1.0))


def _smoothstep(e0: np.ndarray, e1: np.ndarray, x: np.ndarray) -> np.ndarray:
    width = np.where(e1 == e0, 1.0, e1 - e0)
    u = np.clip((x - e0) / width, 0.0, 1.0)
    return np.where(e1 == e0, (x >= e0).astype(float), u * u * (3.0 - 2.0 * u))


def _numbers(name: str, count: int) -> Callable[[list[Type], str], Type]:
    """Type rule of a function of `count` plain numbers returning a plain number."""

    def rule(types: list[Type], text: str) -> Type:
        _arity(types, name, count, text)
        for typ in types:
            _need(typ, SCALAR, (units.NONE,), name, text)
        return NUMBER

    return rule


def _leg_sweep(p: np.ndarray, duty: np.ndarray) -> np.ndarray:
    """+1 -> -1 linearly while 0 <= p < duty (stance), then -1 -> +1 smoothly (swing)."""
    duty = np.clip(duty, 1e-6, 1.0 - 1e-6)
    stance = 1.0 - 2.0 * p / duty
    swing = 2.0 * _smoothstep(duty, np.ones_like(duty), p) - 1.0
    return np.where(p < duty, stance, swing)


def _leg_lift(p: np.ndarray, duty: np.ndarray) -> np.ndarray:
    """0 in stance (p < duty), a half sine bump 0 -> 1 -> 0 across the swing."""
    duty = np.clip(duty, 1e-6, 1.0 - 1e-6)
    progress = np.clip((p - duty) / (1.0 - duty), 0.0, 1.0)
    return np.where(p < duty, 0.0, np.sin(np.pi * progress))


def _horizontal(v: np.ndarray) -> np.ndarray:
    out = np.array(v, dtype=float, copy=True)
    out[..., 2] = 0.0
    return out


def _mix_impl(a: np.ndarray, b: np.ndarray, w: np.ndarray) -> np.ndarray:
    w = w[..., None] if a.ndim > w.ndim else w
    return a + (b - a) * w


FUNCTIONS: dict[str, Function] = {
    f.name: f
    for f in (
        Function("sin", "sin(angle)", "sine; takes an angle (`30 deg`) or a plain number of radians", _trig("sin"), np.sin),
        Function("cos", "cos(angle)", "cosine", _trig("cos"), np.cos),
        Function("tan", "tan(angle)", "tangent", _trig("tan"), np.tan),
        Function("asin", "asin(number) -> angle", "inverse sine, an angle", _unary_number("asin", Type(SCALAR, units.ANGLE)), lambda x: np.arcsin(np.clip(x, -1, 1))),
        Function("acos", "acos(number) -> angle", "inverse cosine, an angle", _unary_number("acos", Type(SCALAR, units.ANGLE)), lambda x: np.arccos(np.clip(x, -1, 1))),
        Function("atan", "atan(number) -> angle", "inverse tangent, an angle", _unary_number("atan", Type(SCALAR, units.ANGLE)), np.arctan),
        Function("atan2", "atan2(y, x) -> angle", "angle of the point (x, y); y and x in the same unit", _atan2, np.arctan2),
        Function("sqrt", "sqrt(x)", "square root; halves the unit's powers (`sqrt(g * HP)` is a velocity)", _sqrt, lambda x: np.sqrt(np.maximum(x, 0.0))),
        Function("exp", "exp(number)", "exponential of a plain number", _unary_number("exp", NUMBER), np.exp),
        Function("log", "log(number)", "natural logarithm of a plain number", _unary_number("log", NUMBER), lambda x: np.log(np.maximum(x, ZERO_NORM))),
        Function("abs", "abs(x)", "absolute value, same unit", _same_scalar("abs", 1), np.abs),
        Function("sign", "sign(x) -> number", "-1, 0 or 1", _sign, np.sign),
        Function("min", "min(a, b, ...)", "smallest of values in the same unit", _same_scalar("min", None), lambda *xs: np.minimum.reduce(xs)),
        Function("max", "max(a, b, ...)", "largest of values in the same unit", _same_scalar("max", None), lambda *xs: np.maximum.reduce(xs)),
        Function("clamp", "clamp(x, low, high)", "x kept between low and high (same unit)", _same_scalar("clamp", 3), lambda x, lo, hi: np.minimum(np.maximum(x, lo), hi)),
        Function("wrap", "wrap(number)", "the fractional part, 0 to 1 (`wrap(phase(gait) - 0.25)` is a phase 0.25 later)", _numbers("wrap", 1), lambda x: np.mod(x, 1.0)),
        Function("leg_sweep", "leg_sweep(phase, duty)", "a leg's swing back and forth over one cycle: +1 to -1 during stance (phase 0 to duty), back to +1 smoothly during the swing", _numbers("leg_sweep", 2), _leg_sweep),
        Function("leg_lift", "leg_lift(phase, duty)", "0 during stance, a bump rising to 1 in mid-swing and back to 0 at landing", _numbers("leg_lift", 2), _leg_lift),
        Function("step", "step(edge, x) -> number", "0 before the edge, 1 from it on (`step(2 s, t)`)", _edges("step", 2), lambda e, x: (x >= e).astype(float)),
        Function("smoothstep", "smoothstep(edge0, edge1, x) -> number", "0 before edge0, 1 after edge1, a smooth S between", _edges("smoothstep", 3), _smoothstep),
        Function("mix", "mix(a, b, fraction)", "a blended toward b: a at 0, b at 1 (numbers or vectors)", _mix, _mix_impl),
        Function("norm", "norm(vector)", "length of a vector, same unit", _vector_rule("norm", 1, lambda t: Type(SCALAR, t[0].dim)), lambda v: np.linalg.norm(v, axis=-1)),
        Function("normalize", "normalize(vector)", "the vector scaled to length 1 (zero stays zero); no unit", _vector_rule("normalize", 1, lambda t: Type(VECTOR)), _safe_normalize),
        Function("dot", "dot(a, b)", "dot product; units multiply", _vector_rule("dot", 2, lambda t: Type(SCALAR, t[0].dim * t[1].dim)), lambda a, b: np.sum(a * b, axis=-1)),
        Function("cross", "cross(a, b)", "cross product; units multiply", _vector_rule("cross", 2, lambda t: Type(VECTOR, t[0].dim * t[1].dim)), lambda a, b: np.cross(a, b)),
        Function("angle", "angle(a, b) -> angle", "unsigned angle between two vectors, 0 to 180 deg", _vector_rule("angle", 2, lambda t: Type(SCALAR, units.ANGLE)), _angle_between),
        Function("horizontal", "horizontal(vector)", "the vector with its vertical (world z) part removed", _vector_rule("horizontal", 1, lambda t: t[0]), _horizontal),
        Function("heading", "heading(vector)", "a vector given in the heading frame (x: where the animal faces, horizontally; z: up) turned into the world", _vector_rule("heading", 1, lambda t: t[0]), None),
        Function("froude_speed", "froude_speed(number) -> velocity", "the speed at that Froude number for this animal: sqrt(Fr x g x HP)", _froude, None),
        Function("phase", "phase(cycle) -> number", "where a cycle element is in its period, 0 to 1", lambda types, text: NUMBER, None),
        Function("contact", "contact(leg) -> condition", "whether a leg's foot (lf, rf, lh, rh) touches something", lambda types, text: CONDITION, None),
    )
}
"""Every callable function; `phase` and `contact` read the env directly (their argument is a
name), `heading` and `froude_speed` are compiled specially."""

SPECIAL_ARGUMENT_FUNCTIONS = ("phase", "contact")
"""Functions whose argument is a name (a cycle, a leg), not a value."""

LOCAL_HELP: dict[str, str] = {
    "rest": "in the fields of a segment, the distance between its two ends in the rest pose; in those of a spring, the rest angle (0 deg)",
    "time_in_state": "in the transitions of a state machine, the time since it entered its current state",
}
"""Names that exist only in some fields, and where."""

LOCAL_NAMES: tuple[str, ...] = tuple(LOCAL_HELP)



# --------------------------------------------------------------------------- parsing


def _is_unit_token(tokens: list[tokenize.TokenInfo], i: int) -> bool:
    token = tokens[i]
    if token.type != tokenize.NAME or token.string not in units.UNITS:
        return False
    after = tokens[i + 1] if i + 1 < len(tokens) else None
    return after is None or after.string not in ("(", ".")


def _unit_run(tokens: list[tokenize.TokenInfo], i: int) -> tuple[list[str], int]:
    """Unit tokens starting at `i` (`bw`, `*`, `HP`, `/`, `rad`, `^`, `2`); returns them and the next index."""
    out = [tokens[i].string]
    i += 1
    while i < len(tokens):
        token = tokens[i]
        if token.string in ("**", "^") and i + 1 < len(tokens):
            j = i + 1
            sign = ""
            if tokens[j].string == "-" and j + 1 < len(tokens):
                sign, j = "-", j + 1
            if tokens[j].type == tokenize.NUMBER:
                out += ["**", f"({sign}{tokens[j].string})"]
                i = j + 1
                continue
            break
        if token.string in ("*", "/") and i + 1 < len(tokens) and _is_unit_token(tokens, i + 1):
            out += [token.string, tokens[i + 1].string]
            i += 2
            continue
        break
    return out, i


def _numeric_run_start(out: list[str], kinds: list[int]) -> int:
    """Index in `out` where the run of numbers joined by * and / ending at the last token starts."""
    start = len(out) - 1
    while start >= 2 and out[start - 1] in ("*", "/") and kinds[start - 2] == tokenize.NUMBER:
        if start >= 3 and out[start - 3] in ("**",):
            break
        start -= 2
    return start


def rewrite(text: str) -> str:
    """Turn quadpipe's expression syntax into Python syntax (unit binding, `^` powers).

    Raises:
        ExprError: the text cannot be split into tokens.
    """
    try:
        tokens = [
            t
            for t in tokenize.generate_tokens(io.StringIO(text).readline)
            if t.type not in (tokenize.NEWLINE, tokenize.NL, tokenize.ENDMARKER, tokenize.INDENT, tokenize.DEDENT)
        ]
    except (tokenize.TokenError, IndentationError, SyntaxError) as exc:
        raise ExprError("expression-syntax", f"cannot read the expression {text!r}: {exc.args[0]}") from None
    out: list[str] = []
    kinds: list[int] = []
    i = 0
    while i < len(tokens):
        token = tokens[i]
        if token.type == tokenize.ERRORTOKEN and not token.string.isspace():
            raise ExprError("expression-syntax", f"cannot read the expression {text!r}: unexpected character {token.string!r}")
        if _is_unit_token(tokens, i) and kinds and kinds[-1] == tokenize.NUMBER:
            start = _numeric_run_start(out, kinds)
            unit_tokens, i = _unit_run(tokens, i)
            number = out[start:]
            del out[start:], kinds[start:]
            out += ["(", "(", *number, ")", "*", *unit_tokens, ")"]
            kinds += [tokenize.OP] * (len(number) + len(unit_tokens) + 4)
            continue
        out.append("**" if token.string == "^" else token.string)
        kinds.append(token.type)
        i += 1
    return " ".join(out)


def _syntax_hint(text: str) -> str:
    """A hint for a syntax error, from common mistakes."""
    try:
        tokens = [t for t in tokenize.generate_tokens(io.StringIO(text).readline) if t.type in (tokenize.NAME, tokenize.NUMBER, tokenize.OP)]
    except (tokenize.TokenError, SyntaxError):
        return "check brackets and operators"
    for a, b in zip(tokens, tokens[1:]):
        if a.type == tokenize.NAME and b.type == tokenize.NAME:
            return f"two names side by side ({a.string} {b.string}): to give a name a unit, multiply: `{a.string} * {b.string}`"
        if a.string == ")" and b.type == tokenize.NAME:
            return f"a unit goes right after a number (`2 cm`); after brackets multiply: `(...) * 1 {b.string}`"
    if "{" in text:
        return "placeholders like {leg} only work in elements with `for_each`"
    return "check brackets and operators; units go right after a number (`2 cm`, `38/30 s`)"


_ALLOWED_NODES = (
    ast.Expression, ast.BinOp, ast.UnaryOp, ast.BoolOp, ast.Compare, ast.IfExp, ast.Call, ast.Name,
    ast.Attribute, ast.Constant, ast.List, ast.Subscript, ast.Load,
    ast.Add, ast.Sub, ast.Mult, ast.Div, ast.Pow, ast.USub, ast.UAdd, ast.Not, ast.And, ast.Or,
    ast.Lt, ast.LtE, ast.Gt, ast.GtE, ast.Eq, ast.NotEq,
)  # fmt: skip


def parse(text: str) -> ast.expr:
    """Parse expression text into a whitelisted Python AST.

    Raises:
        ExprError: syntax errors (`expression-syntax`) and refused syntax (`forbidden-syntax`).
    """
    if not text.strip():
        raise ExprError("expression-syntax", "the expression is empty", "write a number with a unit, like `2 cm`")
    code = rewrite(text)
    try:
        tree = ast.parse(code, mode="eval")
    except SyntaxError as exc:
        raise ExprError("expression-syntax", f"cannot read the expression {text!r}: {exc.msg}", _syntax_hint(text)) from None
    for node in ast.walk(tree):
        if not isinstance(node, _ALLOWED_NODES):
            raise ExprError(
                "forbidden-syntax",
                f"{type(node).__name__.lower()} is not allowed in expressions: {text!r}",
                "expressions may use numbers with units, + - * / ^, comparisons, and/or/not, `a if c else b`, [x, y, z] and the listed functions",
            )
        if isinstance(node, ast.Constant) and (isinstance(node.value, bool) or not isinstance(node.value, (int, float))):
            raise ExprError("forbidden-syntax", f"only numbers may appear literally in {text!r}", "remove the quotes or the text value")
    return tree.body


def referenced_names(value: Any) -> set[str]:
    """Bare names an expression value mentions (to order parameters); empty if it does not parse."""
    texts = value if isinstance(value, list) else [value]
    names: set[str] = set()
    for text in texts:
        if isinstance(text, str):
            try:
                tree = parse(text)
            except ExprError:
                continue
            names |= {node.id for node in ast.walk(tree) if isinstance(node, ast.Name)}
    return names


# --------------------------------------------------------------------------- checking


_BINARY = {ast.Add: "add", ast.Sub: "sub", ast.Mult: "mul", ast.Div: "div", ast.Pow: "pow"}
_COMPARE = {ast.Lt: "<", ast.LtE: "<=", ast.Gt: ">", ast.GtE: ">="}


class _Checker:
    """Walks a parsed expression, resolving names and typing every node."""

    def __init__(self, namespace: Namespace, text: str) -> None:
        self.ns = namespace
        self.text = text

    def fail(self, code: str, message: str, hint: str | None = None) -> ExprError:
        return ExprError(code, f"in {self.text!r}: {message}", hint)

    def check(self, node: ast.expr) -> Expr:
        method = getattr(self, f"_{type(node).__name__.lower()}")
        return method(node)

    def _constant(self, node: ast.Constant) -> Expr:
        return Expr("num", NUMBER, value=float(node.value))

    def _name(self, node: ast.Name) -> Expr:
        name = node.id
        if name in self.ns.locals:
            return self.ns.locals[name]
        if name in self.ns.parameters:
            return self.ns.parameters[name]
        if name in self.ns.sensors:
            return Expr("var", self.ns.sensors[name], value=f"sensor:{name}")
        if name == TIME_VARIABLE:
            return Expr("var", Type(SCALAR, units.TIME), value=TIME_VARIABLE)
        if name in CONSTANTS:
            return Expr("num", NUMBER, value=CONSTANTS[name])
        if name in units.UNITS:
            return Expr("unit", Type(SCALAR, units.UNITS[name].dim), value=name)
        if name in PARENT:
            return Expr("var", POINT_TYPE, value=point_key(f"{name}.start"))
        if name in LEGS:
            raise self.fail("wrong-type", f"{name!r} is a leg, not a value", f"use a point such as {name}.top or {name}.foot, or contact({name})")
        if name in self.ns.cycles:
            raise self.fail("wrong-type", f"{name!r} is a cycle, not a value", f"use phase({name})")
        if name in FUNCTIONS:
            raise self.fail("wrong-type", f"{name!r} is a function", f"call it: `{FUNCTIONS[name].signature}`")
        if name in LOCAL_NAMES:
            raise self.fail("unknown-name", f"{name!r} does not exist here", f"`{name}` only exists {LOCAL_HELP[name]}")
        raise self.fail("unknown-name", f"unknown name {name!r}", did_you_mean(name, self.ns.known_names(), listing=False) or "names are parameters, sensors, units, t, roles and functions")

    def _attribute(self, node: ast.Attribute) -> Expr:
        base = node.value
        if isinstance(base, ast.Name) and (base.id in PARENT or base.id in LEGS):
            return Expr("var", POINT_TYPE, value=point_key(resolve_point_name(f"{base.id}.{node.attr}")))
        inner = self.check(base)
        if inner.type.kind == VECTOR and node.attr in COMPONENTS:
            return Expr("comp", Type(SCALAR, inner.type.dim), (inner,), COMPONENTS[node.attr])
        if inner.type.kind == VECTOR:
            raise self.fail("unknown-name", f"vectors have components .x .y .z, not .{node.attr}", did_you_mean(node.attr, COMPONENTS, listing=False) or None)
        raise self.fail("wrong-type", f".{node.attr} needs a role, a leg or a vector before it, got {inner.type.describe()}")

    def _subscript(self, node: ast.Subscript) -> Expr:
        inner = self.check(node.value)
        index = node.slice
        if inner.type.kind != VECTOR or not (isinstance(index, ast.Constant) and type(index.value) is int and 0 <= index.value <= 2):
            raise self.fail("forbidden-syntax", "indexing is only v[0], v[1] or v[2] on a vector", "or write v.x, v.y, v.z")
        return Expr("comp", Type(SCALAR, inner.type.dim), (inner,), index.value)

    def _list(self, node: ast.List) -> Expr:
        items = [self.check(item) for item in node.elts]
        return make_vector(items, self.text)

    def _unaryop(self, node: ast.UnaryOp) -> Expr:
        operand = self.check(node.operand)
        if isinstance(node.op, ast.Not):
            self.need_bool(operand, "not")
            return Expr("not", CONDITION, (operand,))
        self.need_number(operand, "a sign")
        return Expr("neg", operand.type, (operand,)) if isinstance(node.op, ast.USub) else operand

    def need_number(self, expr: Expr, where: str) -> None:
        if expr.type.kind == BOOL:
            raise self.fail("wrong-type", f"{where} needs a number or a vector, got a condition", "turn a condition into a number with `1 if cond else 0`")

    def need_bool(self, expr: Expr, where: str) -> None:
        if expr.type.kind != BOOL:
            raise self.fail("wrong-type", f"{where} needs a condition, got {expr.type.describe()}", "compare values with < <= > >=")

    def _binop(self, node: ast.BinOp) -> Expr:
        op = _BINARY[type(node.op)]
        left, right = self.check(node.left), self.check(node.right)
        for side in (left, right):
            self.need_number(side, f"'{_OP_WORDS[op]}'")
        if op in ("add", "sub"):
            return self._additive(op, left, right)
        if op == "pow":
            return self._power(left, right)
        return self._multiplicative(op, left, right)

    def _additive(self, op: str, left: Expr, right: Expr) -> Expr:
        if left.type.kind != right.type.kind:
            raise self.fail("wrong-type", f"cannot {_OP_WORDS[op]} {left.type.describe()} and {right.type.describe()}")
        if left.type.dim != right.type.dim:
            raise self.fail(
                "dimension-mismatch",
                f"cannot {_OP_WORDS[op]} {left.type.describe()} and {right.type.describe()}",
                "both sides need the same kind of unit (a length plus a length)",
            )
        return Expr(op, left.type, (left, right))

    def _multiplicative(self, op: str, left: Expr, right: Expr) -> Expr:
        if left.type.kind == VECTOR and right.type.kind == VECTOR:
            raise self.fail("wrong-type", f"cannot {_OP_WORDS[op]} two vectors", "use dot(a, b) or cross(a, b)")
        if op == "div" and right.type.kind == VECTOR:
            raise self.fail("wrong-type", "cannot divide by a vector")
        dim = left.type.dim * right.type.dim if op == "mul" else left.type.dim / right.type.dim
        kind = VECTOR if VECTOR in (left.type.kind, right.type.kind) else SCALAR
        return Expr(op, Type(kind, dim), (left, right))

    def _power(self, base: Expr, exponent: Expr) -> Expr:
        if base.type.kind != SCALAR or exponent.type != NUMBER:
            raise self.fail("wrong-type", "powers need a number raised to a plain number", "write x^2, not a vector or a unit in the exponent")
        if base.type.dim.is_none:
            return Expr("pow", NUMBER, (base, exponent))
        if exponent.needs or exponent.uses_scale:
            raise self.fail("wrong-type", "a quantity with a unit can only be raised to a constant power", "write HP^2, not HP^k with k changing")
        power = Fraction(float(evaluate_constant(exponent))).limit_denominator(1000)
        return Expr("pow", Type(SCALAR, base.type.dim**power), (base, Expr("num", NUMBER, value=float(power))))

    def _boolop(self, node: ast.BoolOp) -> Expr:
        values = [self.check(value) for value in node.values]
        word = "and" if isinstance(node.op, ast.And) else "or"
        for value in values:
            self.need_bool(value, f"'{word}'")
        return Expr(word, CONDITION, tuple(values))

    def _compare(self, node: ast.Compare) -> Expr:
        operands = [self.check(node.left), *(self.check(c) for c in node.comparators)]
        ops = []
        for op in node.ops:
            if type(op) not in _COMPARE:
                raise self.fail("forbidden-syntax", "== and != are not allowed: measured values are never exactly equal", "compare with < <= > >=")
            ops.append(_COMPARE[type(op)])
        for operand in operands:
            if operand.type.kind != SCALAR:
                raise self.fail("wrong-type", f"only numbers can be compared, got {operand.type.describe()}", "compare norm(v), v.z or angle(a, b)")
        dims = {operand.type.dim for operand in operands}
        if len(dims) > 1:
            listed = " and ".join(operand.type.describe() for operand in operands)
            raise self.fail("dimension-mismatch", f"cannot compare {listed}", "both sides need the same kind of unit (20 deg, not 20)")
        return Expr("cmp", CONDITION, tuple(operands), tuple(ops))

    def _ifexp(self, node: ast.IfExp) -> Expr:
        test, body, orelse = self.check(node.test), self.check(node.body), self.check(node.orelse)
        self.need_bool(test, "the test after 'if'")
        if body.type != orelse.type:
            raise self.fail(
                "dimension-mismatch" if body.type.kind == orelse.type.kind else "wrong-type",
                f"the two branches of 'if/else' differ: {body.type.describe()} and {orelse.type.describe()}",
            )
        return Expr("if", body.type, (test, body, orelse))

    def _call(self, node: ast.Call) -> Expr:
        if not isinstance(node.func, ast.Name):
            raise self.fail("forbidden-syntax", "only named functions can be called")
        name = node.func.id
        if name not in FUNCTIONS:
            raise self.fail("unknown-function", f"unknown function {name!r}", did_you_mean(name, FUNCTIONS, listing=False) or "see the function list in docs/controllers.md")
        if node.keywords:
            raise self.fail("forbidden-syntax", f"{name}() takes no named arguments")
        if name in SPECIAL_ARGUMENT_FUNCTIONS:
            return self._named_argument_call(name, node.args)
        args = [self.check(arg) for arg in node.args]
        for arg in args:
            if arg.type.kind == BOOL:
                raise self.fail("wrong-type", f"{name}() takes values, got a condition")
        return Expr("call", FUNCTIONS[name].result([arg.type for arg in args], self.text), tuple(args), name)

    def _named_argument_call(self, name: str, args: list[ast.expr]) -> Expr:
        if len(args) != 1 or not isinstance(args[0], ast.Name):
            raise self.fail("wrong-arguments", f"{name}() takes one name", f"see `{FUNCTIONS[name].signature}`")
        target = args[0].id
        if name == "phase" and target not in self.ns.cycles:
            hint = did_you_mean(target, self.ns.cycles) if self.ns.cycles else "add a `type: cycle` element"
            raise self.fail("unknown-cycle", f"phase() needs a cycle element, and there is no cycle named {target!r}", hint)
        if name == "contact" and target not in LEGS:
            raise self.fail("unknown-leg", f"contact() needs a leg, got {target!r}", did_you_mean(target, LEGS))
        return Expr("var", FUNCTIONS[name].result([], self.text), value=f"{name}:{target}")


_OP_WORDS = {"add": "add", "sub": "subtract", "mul": "multiply", "div": "divide", "pow": "raise"}


def make_vector(items: Sequence[Expr], text: str) -> Expr:
    """A vector node from three scalar nodes of one dimension."""
    if len(items) != 3:
        raise ExprError("wrong-type", f"a vector has 3 components [x, y, z], got {len(items)} in {text!r}")
    for item in items:
        if item.type.kind != SCALAR:
            raise ExprError("wrong-type", f"vector components must be numbers, got {item.type.describe()} in {text!r}")
    items = _zeros_take_unit(items)
    dims = {item.type.dim for item in items}
    if len(dims) > 1:
        raise ExprError("dimension-mismatch", f"vector components mix units in {text!r}", "give all three components the same kind of unit, or 0")
    return Expr("vec", Type(VECTOR, items[0].type.dim), tuple(items))


def _is_plain_zero(item: Expr) -> bool:
    return item.op == "num" and item.value == 0.0 and item.type == NUMBER


def _zeros_take_unit(items: Sequence[Expr]) -> list[Expr]:
    """Plain 0 components take the unit of the others: `[20 HP, 0, 0]` is a vector of lengths."""
    dims = {item.type.dim for item in items if not _is_plain_zero(item)}
    if len(dims) != 1:
        return list(items)
    (dim,) = dims
    return [Expr("num", Type(SCALAR, dim), value=0.0) if _is_plain_zero(item) else item for item in items]


def resolve_point_name(text: str) -> str:
    """Turn a body point into its canonical `role.anchor` form.

    Accepts `role`, `role.start|end|mid` and the leg landmarks `lf.top`, `lf.foot`.

    Raises:
        ExprError: unknown role, leg or anchor (`unknown-role`, `bad-point`).
    """
    base, dot, anchor = text.strip().partition(".")
    if base in LEGS:
        if anchor not in LEG_LANDMARKS:
            raise ExprError("bad-point", f"{text!r}: a leg has the points .top and .foot", did_you_mean(anchor, LEG_LANDMARKS, listing=False) or None)
        return f"{base}_{LEG_LANDMARKS[anchor][base.endswith('f')]}"
    if base not in PARENT:
        raise ExprError("unknown-role", f"{base!r} is not a role", did_you_mean(base, [*ROLES, *LEGS], listing=False) or "see the roles in docs/controllers.md")
    if not dot:
        return f"{base}.start"
    if anchor not in POINT_ANCHORS:
        raise ExprError("bad-point", f"{text!r}: a bone has the points .start, .end and .mid", did_you_mean(anchor, POINT_ANCHORS, listing=False) or None)
    return f"{base}.{anchor}"


def check(value: Any, namespace: Namespace) -> Expr:
    """Parse and type a field value: a number, a string expression, or a list of 3 of them.

    Raises:
        ExprError: any syntax, name, type or dimension problem.
    """
    if isinstance(value, bool):
        raise ExprError("wrong-type", f"expected a value, got {str(value).lower()}", "write a number, e.g. 1 or 20 deg")
    if isinstance(value, (int, float)):
        return Expr("num", NUMBER, value=float(value), text=str(value))
    if isinstance(value, list):
        items = [check(item, namespace) for item in value]
        vector = make_vector(items, str(value))
        return Expr(vector.op, vector.type, vector.args, text=_list_text(value))
    if not isinstance(value, str):
        raise ExprError("wrong-type", f"expected a value, got {type(value).__name__}")
    node = _Checker(namespace, value).check(parse(value))
    return Expr(node.op, node.type, node.args, node.value, text=value)


def _list_text(value: list[Any]) -> str:
    return "[" + ", ".join(str(item) for item in value) + "]"


def check_expected(value: Any, expect: Expect, namespace: Namespace) -> Expr:
    """`check` plus a test that the value has the expected kind and dimension.

    Raises:
        ExprError: as `check`, or `wrong-dimension` / `wrong-type` when it does not fit.
    """
    expr = check(value, namespace)
    if expect.accepts(expr.type):
        return expr
    code = "wrong-dimension" if expr.type.kind == expect.kind else "wrong-type"
    hint = f"for example `{expect.example}`"
    if isinstance(value, str) and value.strip() in namespace.parameters:
        name = value.strip()
        hint = f"parameter {name!r} is {namespace.parameter_texts.get(name, '?')!r}; {hint}"
    raise ExprError(code, f"expected {expect.describe()}, got {expr.type.describe()}", hint)


def evaluate_constant(expr: Expr) -> np.ndarray:
    """Value of an expression that needs neither the simulation nor the animal (one value)."""
    return compile_expr(expr, _UNIT_SCALE)({})[0]


_UNIT_SCALE = units.Scale.of(1.0, 1.0 / units.STANDARD_GRAVITY)
"""A scale where HP = 1 m and bw = 1 N: evaluates animal-free constants."""


# --------------------------------------------------------------------------- compiling


@dataclass(frozen=True)
class Compiled:
    """An expression compiled for n animals.

    Call it with an env (see module docstring) to get an array shaped (n,) or (n, 3);
    `constant` holds that array already when the expression needs nothing from the env.
    `expr` is the checked expression it was compiled from (the kernel lowers that).
    """

    type: Type
    needs: frozenset[str]
    fn: Callable[[Env], np.ndarray]
    constant: np.ndarray | None
    text: str = ""
    expr: Expr | None = None

    def __call__(self, env: Env) -> np.ndarray:
        return self.constant if self.constant is not None else self.fn(env)


def _shape(typ: Type, n: int) -> tuple[int, ...]:
    return (n, 3) if typ.kind == VECTOR else (n,)


def _lift(value: np.ndarray, typ: Type) -> np.ndarray:
    """Give a scalar array a trailing axis so it broadcasts against vectors."""
    return value[..., None] if typ.kind == SCALAR else value


def _build(expr: Expr, scale: units.Scale) -> Callable[[Env], np.ndarray]:
    n = scale.n
    if not expr.needs:
        value = _build_node(expr, scale, n)({})
        fixed = np.broadcast_to(np.asarray(value, dtype=bool if expr.type.kind == BOOL else float), _shape(expr.type, n))
        return lambda env: fixed
    return _build_node(expr, scale, n)


def _build_node(expr: Expr, scale: units.Scale, n: int) -> Callable[[Env], np.ndarray]:
    op = expr.op
    if op == "num":
        value = np.full(n, expr.value)
        return lambda env: value
    if op == "unit":
        unit_value = scale.unit_value(units.UNITS[expr.value])
        return lambda env: unit_value
    if op == "var":
        return _build_var(expr, scale, n)
    args = [_build(arg, scale) for arg in expr.args]
    types = [arg.type for arg in expr.args]
    if op == "call":
        return _build_call(expr, args, types, scale)
    if op == "cmp":
        return _compare(args, expr.value)
    if op == "comp":
        (vector,), index = args, expr.value
        return lambda env: vector(env)[..., index]
    return _OPERATORS[op](args, types)


def _build_var(expr: Expr, scale: units.Scale, n: int) -> Callable[[Env], np.ndarray]:
    key = str(expr.value)
    if key.startswith(REST_PREFIX):
        a, b = key[len(REST_PREFIX) :].split("|")
        missing = [p for p in (a, b) if p not in scale.rest_points]
        if missing:
            raise ValueError(f"the scale has no rest position for {missing}; build it with scale_for_animals()")
        distance = np.linalg.norm(scale.rest_points[b] - scale.rest_points[a], axis=-1)
        return lambda env: distance
    shape = _shape(expr.type, n)
    dtype = bool if expr.type.kind == BOOL else float

    def read(env: Env) -> np.ndarray:
        value = env[key]
        if isinstance(value, np.ndarray) and value.shape == shape and value.dtype == dtype:
            return value
        return np.broadcast_to(np.asarray(value, dtype=dtype), shape)

    return read


def _build_call(expr: Expr, args: list[Callable], types: list[Type], scale: units.Scale) -> Callable[[Env], np.ndarray]:
    name = expr.value
    if name == "heading":
        (vector,) = args
        return lambda env: np.einsum("nij,nj->ni", env[HEADING_FRAME_KEY], vector(env))
    if name == "froude_speed":
        (froude,) = args
        reference = units.STANDARD_GRAVITY * scale.hp
        return lambda env: np.sqrt(np.maximum(froude(env), 0.0) * reference)
    impl = FUNCTIONS[name].impl
    return lambda env: impl(*(arg(env) for arg in args))


def _arith(fn: Callable[[np.ndarray, np.ndarray], np.ndarray]) -> Callable[[list[Callable], list[Type]], Callable[[Env], np.ndarray]]:
    def build(args: list[Callable], types: list[Type]) -> Callable[[Env], np.ndarray]:
        (a, b), (ta, tb) = args, types
        if ta.kind == tb.kind:
            return lambda env: fn(a(env), b(env))
        return lambda env: fn(_lift(a(env), ta), _lift(b(env), tb))

    return build


def _compare(args: list[Callable], ops: tuple[str, ...]) -> Callable[[Env], np.ndarray]:
    funcs = {"<": np.less, "<=": np.less_equal, ">": np.greater, ">=": np.greater_equal}

    def run(env: Env) -> np.ndarray:
        values = [arg(env) for arg in args]
        result = np.ones(values[0].shape, dtype=bool)
        for op, left, right in zip(ops, values, values[1:]):
            result &= funcs[op](left, right)
        return result

    return run


def _if(args: list[Callable], types: list[Type]) -> Callable[[Env], np.ndarray]:
    test, body, orelse = args
    vector = types[1].kind == VECTOR
    return lambda env: np.where(test(env)[..., None] if vector else test(env), body(env), orelse(env))


_OPERATORS: dict[str, Callable[..., Callable[[Env], np.ndarray]]] = {
    "add": _arith(np.add),
    "sub": _arith(np.subtract),
    "mul": _arith(np.multiply),
    "div": _arith(lambda a, b: np.divide(a, np.where(b == 0, 1.0, b)) * (b != 0)),
    "pow": _arith(np.power),
    "neg": lambda args, types: (lambda env: -args[0](env)),
    "not": lambda args, types: (lambda env: ~args[0](env)),
    "and": lambda args, types: (lambda env: np.logical_and.reduce([arg(env) for arg in args])),
    "or": lambda args, types: (lambda env: np.logical_or.reduce([arg(env) for arg in args])),
    "vec": lambda args, types: (lambda env: np.stack([arg(env) for arg in args], axis=-1)),
    "if": _if,
}


def compile_expr(expr: Expr, scale: units.Scale) -> Compiled:
    """Compile a checked expression for the animals of `scale`."""
    fn = _build(expr, scale)
    constant = np.asarray(fn({})) if not expr.needs else None
    return Compiled(expr.type, expr.needs, fn, constant, expr.text, expr)


def compile_quantity(
    value: Any,
    scale: units.Scale,
    expect: Expect | None = None,
    namespace: Namespace | None = None,
) -> Compiled:
    """Check and compile one value (`"38/30 s"`, `0.5`, `[0, 0, -1]`) for some animals.

    Args:
        value: the value as written in YAML.
        scale: the animals' unit values.
        expect: the kind and dimension it must have, if any.
        namespace: parameters, sensors and cycles it may use.

    Raises:
        ExprError: the value does not parse, type or fit `expect`.
    """
    namespace = namespace or Namespace()
    expr = check_expected(value, expect, namespace) if expect else check(value, namespace)
    return compile_expr(expr, scale)
