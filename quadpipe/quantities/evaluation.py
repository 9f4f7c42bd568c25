"""Compiling checked expressions to numpy callables over all animals at once.

Compiling for a `Scale` (one value per animal) gives a `Compiled` callable `f(env) -> array`:
scalars are arrays of shape (n,), vectors (n, 3), conditions boolean (n,). Sub-expressions
that need nothing from the simulation are folded to constants at compile time.

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
yields no force rather than a NaN (which would make MuJoCo reset silently). A divisor that is
always zero, and constant parts that overflow, are refused when the expression is checked.
"""

from __future__ import annotations

import weakref
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np

from quadpipe.quantities import units
from quadpipe.quantities.functions import FUNCTIONS, table_interp
from quadpipe.quantities.nodes import BOOL, HEADING_FRAME_KEY, REST_PREFIX, SCALAR, VECTOR, Expr, Type

Env = Mapping[str, np.ndarray]
"""What a compiled expression reads: env key -> array over animals (see module docstring)."""


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


_Built = dict[int, Callable[[Env], np.ndarray]]
"""Nodes already built in one compilation, by `id`: a parameter used twice is one shared node
(`p2: p1 + p1`), so a chain of them is built (and its constants folded) once per node, not
once per path through it."""


def _build(expr: Expr, scale: units.Scale, built: _Built) -> Callable[[Env], np.ndarray]:
    if id(expr) not in built:
        built[id(expr)] = _build_unshared(expr, scale, built)
    return built[id(expr)]


def _build_unshared(expr: Expr, scale: units.Scale, built: _Built) -> Callable[[Env], np.ndarray]:
    n = scale.n
    if not expr.needs:
        value = _build_node(expr, scale, n, built)({})
        fixed = np.broadcast_to(
            np.asarray(value, dtype=bool if expr.type.kind == BOOL else float), _shape(expr.type, n)
        )
        return lambda env: fixed
    return _build_node(expr, scale, n, built)


def _build_node(expr: Expr, scale: units.Scale, n: int, built: _Built) -> Callable[[Env], np.ndarray]:
    op = expr.op
    if op == "num":
        value = np.full(n, expr.value)
        return lambda env: value
    if op == "unit":
        unit_value = scale.unit_value(units.UNITS[expr.value])
        return lambda env: unit_value
    if op == "var":
        return _build_var(expr, scale, n)
    if op == "interp":
        x, (breakpoints, values) = _build(expr.args[0], scale, built), table_arrays(expr, scale, built)
        return lambda env: table_interp(x(env), breakpoints, values)
    args = [_build(arg, scale, built) for arg in expr.args]
    types = [arg.type for arg in expr.args]
    if op == "call":
        return _build_call(expr, args, types, scale)
    if op == "cmp":
        return _compare(args, expr.value)
    if op == "comp":
        (vector,), index = args, expr.value
        return lambda env: vector(env)[..., index]
    return _OPERATORS[op](args, types)


def table_arrays(expr: Expr, scale: units.Scale, built: _Built | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The breakpoints (n, m) and the values ((n, m) or (n, m, 3)) of a table node (`interp`,
    whose arguments are x, the m breakpoints and the m values, all constants) for the animals
    of `scale`."""
    kept = _TABLES.setdefault(expr, {})
    if id(scale) not in kept:
        built = {} if built is None else built
        columns = [_constant_value(arg, scale, built) for arg in expr.args[1:]]
        kept[id(scale)] = (scale, np.stack(columns[: expr.value], axis=1), np.stack(columns[expr.value :], axis=1))
    return kept[id(scale)][1:]


_TABLES: weakref.WeakKeyDictionary[Expr, dict[int, tuple[units.Scale, np.ndarray, np.ndarray]]] = (
    weakref.WeakKeyDictionary()
)
"""The arrays of each table node, by scale (`table_arrays`): a path's table is compiled into
every value that uses it, and each of its thousands of points is folded once per scale (the
scale is kept with them, so that its `id` is not reused while they are)."""


def _constant_value(expr: Expr, scale: units.Scale, built: _Built) -> np.ndarray:
    """The value of a constant node for the animals of `scale`, (n,) or (n, 3): numbers with
    units (and vectors of them) directly, a table's thousands of points at a few microseconds
    each; any other node through `_build`."""
    if expr.op == "num":
        return np.full(scale.n, expr.value)
    if expr.op == "unit":
        return scale.unit_value(units.UNITS[expr.value])
    if expr.op == "vec":
        return np.stack([_constant_value(arg, scale, built) for arg in expr.args], axis=-1)
    if expr.op == "neg":
        return -_constant_value(expr.args[0], scale, built)
    if expr.op == "mul" and expr.args[0].type.kind == expr.args[1].type.kind == SCALAR:
        return _constant_value(expr.args[0], scale, built) * _constant_value(expr.args[1], scale, built)
    return np.broadcast_to(_build(expr, scale, built)({}), _shape(expr.type, scale.n))


def table_rows(expr: Expr, scale: units.Scale) -> tuple[np.ndarray, np.ndarray]:
    """The breakpoints and the values of a table node as rows of registers, (m, n, 3) each (a
    number in all three components): what the kernel reads (see `lowering`)."""
    breakpoints, values = table_arrays(expr, scale)
    values = values if values.ndim == 3 else np.repeat(values[..., None], 3, axis=2)
    return np.ascontiguousarray(np.repeat(breakpoints.T[..., None], 3, axis=2)), np.ascontiguousarray(
        values.transpose(1, 0, 2)
    )


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
    assert impl is not None, f"{name}() has no plain implementation but is not compiled specially above"
    return lambda env: impl(*(arg(env) for arg in args))


def _arith(
    fn: Callable[[np.ndarray, np.ndarray], np.ndarray],
) -> Callable[[list[Callable], list[Type]], Callable[[Env], np.ndarray]]:
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
    "neg": lambda args, types: lambda env: -args[0](env),
    "not": lambda args, types: lambda env: ~args[0](env),
    "and": lambda args, types: lambda env: np.logical_and.reduce([arg(env) for arg in args]),
    "or": lambda args, types: lambda env: np.logical_or.reduce([arg(env) for arg in args]),
    "vec": lambda args, types: lambda env: np.stack([arg(env) for arg in args], axis=-1),
    "if": _if,
}


def compile_expr(expr: Expr, scale: units.Scale) -> Compiled:
    """Compile a checked expression for the animals of `scale`."""
    fn = _build(expr, scale, {})
    constant = np.asarray(fn({})) if not expr.needs else None
    return Compiled(expr.type, expr.needs, fn, constant, expr.text, expr)
