"""The whitelisted functions of expressions: their type rules and numpy implementations.

Each `Function` has a type rule, (argument types, expression text) -> result type, which
raises `ExprError` for wrong arguments, and an implementation over arrays of all animals.
`FUNCTIONS` is the table every other part reads (checking, compiling, the reference).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from fractions import Fraction

import numpy as np

from quadpipe.quantities import units
from quadpipe.quantities.nodes import (
    BOOL,
    CONDITION,
    NUMBER,
    SCALAR,
    TABLE_FUNCTION,
    VECTOR,
    ZERO_NORM,
    Expect,
    ExprError,
    Type,
)


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
        domain: for functions defined on part of the numbers only: (argument values -> whether
            each is inside, what the inside is in words). `impl` clamps a changing argument into
            it; a constant argument outside it is refused when the controller is checked.
    """

    name: str
    signature: str
    description: str
    result: Callable[[list[Type], str], Type]
    impl: Callable[..., np.ndarray] | None
    domain: tuple[Callable[[np.ndarray], np.ndarray], str] | None = None


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
            raise ExprError(
                "wrong-arguments",
                f"in {text!r}: {name}() needs at least 2 arguments",
                f"see `{FUNCTIONS[name].signature}`",
            )
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
        raise ExprError(
            "wrong-type", f"in {text!r}: mix() blends two numbers or two vectors, got {a.describe()} and {b.describe()}"
        )
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


def table_interp(x: np.ndarray, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
    """A table read at x, for each animal: linear between its breakpoints, held at its ends.

    Args:
        x: (n,) where to read it.
        xs: (n, m) breakpoints, not decreasing; a repeated breakpoint is a jump, to the value
            of its last repeat.
        ys: (n, m) values, or (n, m, 3) vector values.

    Returns:
        (n,) or (n, 3): the values at x (NaN where x is NaN), as the kernel computes them.
    """
    out = np.empty((len(x), *ys.shape[2:]))
    for i in range(len(x)):
        j = int(np.searchsorted(xs[i], x[i], side="right")) - 1
        if np.isnan(x[i]):
            out[i] = np.nan
        elif j < 0 or j >= xs.shape[1] - 1:
            out[i] = ys[i, min(max(j, 0), xs.shape[1] - 1)]
        else:
            u = (x[i] - xs[i, j]) / (xs[i, j + 1] - xs[i, j])
            out[i] = ys[i, j] + u * (ys[i, j + 1] - ys[i, j])
    return out


def _table_rule(types: list[Type], text: str) -> Type:
    """The result of a table: its values' type (the checks are `checking._Checker._table`)."""
    return types[-1]


def _mix_impl(a: np.ndarray, b: np.ndarray, w: np.ndarray) -> np.ndarray:
    w = w[..., None] if a.ndim > w.ndim else w
    return a + (b - a) * w


_UNIT_INTERVAL = (lambda x: np.abs(x) <= 1, "between -1 and 1")
"""Domain of asin and acos."""

FUNCTIONS: dict[str, Function] = {
    f.name: f
    for f in (
        Function(
            "sin", "sin(angle)", "sine; takes an angle (`30 deg`) or a plain number of radians", _trig("sin"), np.sin
        ),
        Function("cos", "cos(angle)", "cosine", _trig("cos"), np.cos),
        Function("tan", "tan(angle)", "tangent", _trig("tan"), np.tan),
        Function(
            "asin",
            "asin(number) -> angle",
            "inverse sine, an angle",
            _unary_number("asin", Type(SCALAR, units.ANGLE)),
            lambda x: np.arcsin(np.clip(x, -1, 1)),
            _UNIT_INTERVAL,
        ),
        Function(
            "acos",
            "acos(number) -> angle",
            "inverse cosine, an angle",
            _unary_number("acos", Type(SCALAR, units.ANGLE)),
            lambda x: np.arccos(np.clip(x, -1, 1)),
            _UNIT_INTERVAL,
        ),
        Function(
            "atan",
            "atan(number) -> angle",
            "inverse tangent, an angle",
            _unary_number("atan", Type(SCALAR, units.ANGLE)),
            np.arctan,
        ),
        Function(
            "atan2", "atan2(y, x) -> angle", "angle of the point (x, y); y and x in the same unit", _atan2, np.arctan2
        ),
        Function(
            "sqrt",
            "sqrt(x)",
            "square root; halves the unit's powers (`sqrt(g * HP)` is a velocity)",
            _sqrt,
            lambda x: np.sqrt(np.maximum(x, 0.0)),
            (lambda x: x >= 0, "at least 0"),
        ),
        Function("exp", "exp(number)", "exponential of a plain number", _unary_number("exp", NUMBER), np.exp),
        Function(
            "log",
            "log(number)",
            "natural logarithm of a plain number",
            _unary_number("log", NUMBER),
            lambda x: np.log(np.maximum(x, ZERO_NORM)),
            (lambda x: x > 0, "above 0"),
        ),
        Function("abs", "abs(x)", "absolute value, same unit", _same_scalar("abs", 1), np.abs),
        Function("sign", "sign(x) -> number", "-1, 0 or 1", _sign, np.sign),
        Function(
            "min",
            "min(a, b, ...)",
            "smallest of values in the same unit",
            _same_scalar("min", None),
            lambda *xs: np.minimum.reduce(xs),
        ),
        Function(
            "max",
            "max(a, b, ...)",
            "largest of values in the same unit",
            _same_scalar("max", None),
            lambda *xs: np.maximum.reduce(xs),
        ),
        Function(
            "clamp",
            "clamp(x, low, high)",
            "x kept between low and high (same unit)",
            _same_scalar("clamp", 3),
            lambda x, lo, hi: np.minimum(np.maximum(x, lo), hi),
        ),
        Function(
            "wrap",
            "wrap(number)",
            "the fractional part, 0 to 1 (`wrap(phase(gait) - 0.25)` is a phase 0.25 later)",
            _numbers("wrap", 1),
            lambda x: np.mod(x, 1.0),
        ),
        Function(
            "leg_sweep",
            "leg_sweep(phase, duty)",
            "a leg's swing back and forth over one cycle: +1 to -1 during stance (phase 0 to duty), back to +1 smoothly during the swing",
            _numbers("leg_sweep", 2),
            _leg_sweep,
        ),
        Function(
            "leg_lift",
            "leg_lift(phase, duty)",
            "0 during stance, a bump rising to 1 in mid-swing and back to 0 at landing",
            _numbers("leg_lift", 2),
            _leg_lift,
        ),
        Function(
            "step",
            "step(edge, x) -> number",
            "0 before the edge, 1 from it on (`step(2 s, t)`)",
            _edges("step", 2),
            lambda e, x: (x >= e).astype(float),
        ),
        Function(
            "smoothstep",
            "smoothstep(edge0, edge1, x) -> number",
            "0 before edge0, 1 after edge1, a smooth S between",
            _edges("smoothstep", 3),
            _smoothstep,
        ),
        Function(
            "mix", "mix(a, b, fraction)", "a blended toward b: a at 0, b at 1 (numbers or vectors)", _mix, _mix_impl
        ),
        Function(
            "norm",
            "norm(vector)",
            "length of a vector, same unit",
            _vector_rule("norm", 1, lambda t: Type(SCALAR, t[0].dim)),
            lambda v: np.linalg.norm(v, axis=-1),
        ),
        Function(
            "normalize",
            "normalize(vector)",
            "the vector scaled to length 1 (zero stays zero); no unit",
            _vector_rule("normalize", 1, lambda t: Type(VECTOR)),
            _safe_normalize,
        ),
        Function(
            "dot",
            "dot(a, b)",
            "dot product; units multiply",
            _vector_rule("dot", 2, lambda t: Type(SCALAR, t[0].dim * t[1].dim)),
            lambda a, b: np.sum(a * b, axis=-1),
        ),
        Function(
            "cross",
            "cross(a, b)",
            "cross product; units multiply",
            _vector_rule("cross", 2, lambda t: Type(VECTOR, t[0].dim * t[1].dim)),
            lambda a, b: np.cross(a, b),
        ),
        Function(
            "angle",
            "angle(a, b) -> angle",
            "unsigned angle between two vectors, 0 to 180 deg",
            _vector_rule("angle", 2, lambda t: Type(SCALAR, units.ANGLE)),
            _angle_between,
        ),
        Function(
            "horizontal",
            "horizontal(vector)",
            "the vector with its vertical (world z) part removed",
            _vector_rule("horizontal", 1, lambda t: t[0]),
            _horizontal,
        ),
        Function(
            "heading",
            "heading(vector)",
            "a vector given in the heading frame (x: where the animal faces, horizontally; z: up) turned into the world",
            _vector_rule("heading", 1, lambda t: t[0]),
            None,
        ),
        Function(
            "froude_speed",
            "froude_speed(number) -> velocity",
            "the speed at that Froude number for this animal: sqrt(Fr x g x HP)",
            _froude,
            None,
        ),
        Function(
            TABLE_FUNCTION,
            "interp(x, [x0, x1, ...], [y0, y1, ...])",
            "a table: y0 at x0, y1 at x1, ..., straight lines between, y0 before x0 and the last y after the last x; "
            "the x values (breakpoints) are constants in x's unit, not decreasing (a repeated one is a jump), the "
            "y values constants of one unit, numbers or vectors (`interp(t, [0 s, 2 s], [0 m/s, 1 m/s])`)",
            _table_rule,
            None,
        ),
        Function(
            "phase",
            "phase(cycle) -> number",
            "where a cycle element is in its period, 0 to 1",
            lambda types, text: NUMBER,
            None,
        ),
        Function(
            "contact",
            "contact(leg) -> condition",
            "whether a leg's foot (lf, rf, lh, rh) touches something",
            lambda types, text: CONDITION,
            None,
        ),
    )
}
"""Every callable function; `phase` and `contact` read the env directly (their argument is a
name), `heading` and `froude_speed` are compiled specially, and `interp` is checked as a table
(an `interp` node; see `table_interp`)."""

SPECIAL_ARGUMENT_FUNCTIONS = ("phase", "contact")
"""Functions whose argument is a name (a cycle, a leg), not a value."""

LOCAL_HELP: dict[str, str] = {
    "rest": "in the fields of a segment, the distance between its two ends in the rest pose; in those of a spring, the rest angle (0 deg)",
    "time_in_state": "in the transitions of a state machine, the time since it entered its current state",
}
"""Names that exist only in some fields, and where."""

LOCAL_NAMES: tuple[str, ...] = tuple(LOCAL_HELP)
