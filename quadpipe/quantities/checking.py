"""Checking expressions: resolving names and giving every node a `Type`.

`check(value, namespace)` parses a field value (a number, an expression text or a list of
three) and types it, rejecting unknown names, wrong argument types and mixed dimensions;
`check_expected` also tests it against what the field accepts (an `Expect`). Parameters are
inlined where they are used, so a checked expression is self-contained.
"""

from __future__ import annotations

import ast
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any

import numpy as np

from quadpipe.anatomy.roles import LEGS, PARENT, ROLES
from quadpipe.core.errors import did_you_mean
from quadpipe.core.limits import MAX_EXPRESSION_DEPTH
from quadpipe.quantities import units
from quadpipe.quantities.constants import (
    NON_FINITE_WORDS,
    finite_number,
    is_literal,
    need_finite,
    need_finite_order,
    refuse_bad_constants,
)
from quadpipe.quantities.evaluation import Compiled, compile_expr, evaluate_constant
from quadpipe.quantities.functions import FUNCTIONS, LOCAL_HELP, LOCAL_NAMES, SPECIAL_ARGUMENT_FUNCTIONS
from quadpipe.quantities.nodes import (
    BOOL,
    COMPONENTS,
    CONDITION,
    CONSTANTS,
    LEG_LANDMARKS,
    LEG_REST_LENGTH,
    NUMBER,
    POINT_ANCHORS,
    POINT_TYPE,
    SCALAR,
    TABLE_FUNCTION,
    TIME_VARIABLE,
    VECTOR,
    Expect,
    Expr,
    ExprError,
    Type,
    limit_error,
    nesting_depth,
    point_key,
    rest_distance_key,
)
from quadpipe.quantities.parsing import parse


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

    def with_locals(self, **local: Expr) -> Namespace:
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


_BINARY = {ast.Add: "add", ast.Sub: "sub", ast.Mult: "mul", ast.Div: "div", ast.Pow: "pow"}
_COMPARE = {ast.Lt: "<", ast.LtE: "<=", ast.Gt: ">", ast.GtE: ">="}


class _Checker:
    """Walks a parsed expression, resolving names and typing every node."""

    def __init__(self, namespace: Namespace, text: str) -> None:
        self.ns = namespace
        self.text = text
        self.units: dict[str, Expr] = {}
        """The node of each unit a table's points use (one shared node per unit)."""

    def fail(self, code: str, message: str, hint: str | None = None) -> ExprError:
        return ExprError(code, f"in {self.text!r}: {message}", hint)

    def check(self, node: ast.expr) -> Expr:
        method = getattr(self, f"_{type(node).__name__.lower()}")
        return method(node)

    def _constant(self, node: ast.Constant) -> Expr:
        return Expr("num", NUMBER, value=finite_number(node.value, self.text))

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
        if name.lower() in NON_FINITE_WORDS:  # a number Python's float() reads: refused as one
            return Expr("num", NUMBER, value=finite_number(name, self.text))
        if name in units.UNITS:
            return Expr("unit", Type(SCALAR, units.UNITS[name].dim), value=name)
        if name in PARENT:
            return Expr("var", POINT_TYPE, value=point_key(f"{name}.start"))
        if name in LEGS:
            raise self.fail(
                "wrong-type",
                f"{name!r} is a leg, not a value",
                f"use a point such as {name}.top or {name}.foot, or contact({name})",
            )
        if name in self.ns.cycles:
            raise self.fail("wrong-type", f"{name!r} is a cycle, not a value", f"use phase({name})")
        if name in FUNCTIONS:
            raise self.fail("wrong-type", f"{name!r} is a function", f"call it: `{FUNCTIONS[name].signature}`")
        if name in LOCAL_NAMES:
            raise self.fail("unknown-name", f"{name!r} does not exist here", f"`{name}` only exists {LOCAL_HELP[name]}")
        raise self.fail(
            "unknown-name",
            f"unknown name {name!r}",
            did_you_mean(name, self.ns.known_names(), listing=False)
            or "names are parameters, sensors, units, t, roles and functions",
        )

    def _attribute(self, node: ast.Attribute) -> Expr:
        base = node.value
        if isinstance(base, ast.Name) and base.id in LEGS and node.attr == LEG_REST_LENGTH:
            return leg_rest_length(base.id)
        if isinstance(base, ast.Name) and (base.id in PARENT or base.id in LEGS):
            return Expr("var", POINT_TYPE, value=point_key(resolve_point_name(f"{base.id}.{node.attr}")))
        inner = self.check(base)
        if inner.type.kind == VECTOR and node.attr in COMPONENTS:
            return Expr("comp", Type(SCALAR, inner.type.dim), (inner,), COMPONENTS[node.attr])
        if inner.type.kind == VECTOR:
            raise self.fail(
                "unknown-name",
                f"vectors have components .x .y .z, not .{node.attr}",
                did_you_mean(node.attr, COMPONENTS, listing=False) or None,
            )
        raise self.fail(
            "wrong-type", f".{node.attr} needs a role, a leg or a vector before it, got {inner.type.describe()}"
        )

    def _subscript(self, node: ast.Subscript) -> Expr:
        inner = self.check(node.value)
        index = node.slice
        if inner.type.kind != VECTOR or not (
            isinstance(index, ast.Constant) and type(index.value) is int and 0 <= index.value <= 2
        ):
            raise self.fail(
                "forbidden-syntax", "indexing is only v[0], v[1] or v[2] on a vector", "or write v.x, v.y, v.z"
            )
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
            raise self.fail(
                "wrong-type",
                f"{where} needs a number or a vector, got a condition",
                "turn a condition into a number with `1 if cond else 0`",
            )

    def need_bool(self, expr: Expr, where: str) -> None:
        if expr.type.kind != BOOL:
            raise self.fail(
                "wrong-type", f"{where} needs a condition, got {expr.type.describe()}", "compare values with < <= > >="
            )

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
            raise self.fail(
                "wrong-type",
                "powers need a number raised to a plain number",
                "write x^2, not a vector or a unit in the exponent",
            )
        if base.type.dim.is_none:
            return Expr("pow", NUMBER, (base, exponent))
        if exponent.needs or exponent.uses_scale:
            raise self.fail(
                "wrong-type",
                "a quantity with a unit can only be raised to a constant power",
                "write HP^2, not HP^k with k changing",
            )
        with np.errstate(all="ignore"):
            value = evaluate_constant(exponent)
        need_finite(value, self.text)
        power = Fraction(float(value)).limit_denominator(1000)
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
                raise self.fail(
                    "forbidden-syntax",
                    "== and != are not allowed: measured values are never exactly equal",
                    "compare with < <= > >=",
                )
            ops.append(_COMPARE[type(op)])
        for operand in operands:
            if operand.type.kind != SCALAR:
                raise self.fail(
                    "wrong-type",
                    f"only numbers can be compared, got {operand.type.describe()}",
                    "compare norm(v), v.z or angle(a, b)",
                )
        dims = {operand.type.dim for operand in operands}
        if len(dims) > 1:
            listed = " and ".join(operand.type.describe() for operand in operands)
            raise self.fail(
                "dimension-mismatch",
                f"cannot compare {listed}",
                "both sides need the same kind of unit (20 deg, not 20)",
            )
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
            raise self.fail(
                "unknown-function",
                f"unknown function {name!r}",
                did_you_mean(name, FUNCTIONS, listing=False) or "see the function list in docs/controllers.md",
            )
        if node.keywords:
            raise self.fail("forbidden-syntax", f"{name}() takes no named arguments")
        if name in SPECIAL_ARGUMENT_FUNCTIONS:
            return self._named_argument_call(name, node.args)
        if name == TABLE_FUNCTION:
            return self._table(node.args)
        args = [self.check(arg) for arg in node.args]
        for arg in args:
            if arg.type.kind == BOOL:
                raise self.fail("wrong-type", f"{name}() takes values, got a condition")
        return Expr("call", FUNCTIONS[name].result([arg.type for arg in args], self.text), tuple(args), name)

    def _table(self, args: list[ast.expr]) -> Expr:
        """`interp(x, [x0, x1, ...], [y0, y1, ...])`: a table node, `interp`, whose arguments are
        x, the breakpoints, then the values, and whose value is the number of breakpoints."""
        hint = f"see `{FUNCTIONS[TABLE_FUNCTION].signature}`"
        if len(args) != 3:
            raise self.fail("wrong-arguments", f"{TABLE_FUNCTION}() takes 3 arguments, got {len(args)}", hint)
        if not (isinstance(args[1], ast.List) and isinstance(args[2], ast.List)):
            raise self.fail(
                "wrong-arguments", f"{TABLE_FUNCTION}() takes its breakpoints and its values as lists [...]", hint
            )
        x = self.check(args[0])
        breakpoints, values = self._table_list(args[1], "breakpoints"), self._table_list(args[2], "values")
        if len(breakpoints) != len(values):
            raise self.fail(
                "table-lengths",
                f"the table has {len(breakpoints)} breakpoints but {len(values)} values",
                "give one value per breakpoint",
            )
        if len(breakpoints) < 2:
            raise self.fail(
                "table-size", f"a table needs at least 2 points, got {len(breakpoints)}", "a constant needs no table"
            )
        if x.type.kind != SCALAR or breakpoints[0].type.kind != SCALAR:
            raise self.fail(
                "wrong-type",
                f"a table is read at a number, with numbers as breakpoints, got {x.type.describe()} "
                f"and {breakpoints[0].type.describe()}",
                hint,
            )
        if x.type.dim != breakpoints[0].type.dim:
            raise self.fail(
                "dimension-mismatch",
                f"a table whose breakpoints are {units.dimension_name(breakpoints[0].type.dim, plural=True)} "
                f"is read at {x.type.describe()}",
                "give the breakpoints the unit of the first argument (`interp(t, [0 s, 2 s], ...)`)",
            )
        table = Expr("interp", values[0].type, (x, *breakpoints, *values), len(breakpoints))
        need_finite_order(table, self.text)
        return table

    def _table_list(self, node: ast.List, what: str) -> list[Expr]:
        """The checked items of one list of a table: constants of one type (a plain 0 takes the
        unit of the others, as in vectors)."""
        items = _zeros_take_unit([self._table_item(item) for item in node.elts])
        for item in items:
            if item.type.kind == BOOL:
                raise self.fail("wrong-type", f"the {what} of a table are values, got a condition")
            if item.needs:
                raise self.fail(
                    "table-not-constant",
                    f"the {what} of a table are constants, but one reads the simulation ({sorted(item.needs)[0]})",
                    "a table holds numbers with units; compute with its result instead",
                )
            if not is_literal(item):
                refuse_bad_constants(item, self.text)
        other = next((item.type for item in items if item.type != items[0].type), None)
        if other is not None:
            listed = " and ".join(sorted((items[0].type.describe(), other.describe())))
            raise self.fail(
                "table-units", f"the {what} of a table mix {listed}", f"give all the {what} one kind of unit"
            )
        return items

    def _table_item(self, node: ast.expr) -> Expr:
        """One point of a table: a number with a unit (`-1.5 m`), or a vector of them, read
        straight from its syntax (a table may have thousands), sharing each unit's node; any
        other value checked as usual."""
        if isinstance(node, ast.List) and len(node.elts) == 3:
            items = [self._table_item(item) for item in node.elts]
            if items[0].type is items[1].type is items[2].type and items[0].type.kind == SCALAR:
                return Expr("vec", Type(VECTOR, items[0].type.dim), tuple(items))
            return make_vector(items, self.text)
        sign, inner = (
            (-1.0, node.operand) if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub) else (1.0, node)
        )
        number = inner.left if isinstance(inner, ast.BinOp) and isinstance(inner.op, ast.Mult) else inner
        unit = inner.right if isinstance(inner, ast.BinOp) and isinstance(inner.op, ast.Mult) else None
        if not isinstance(number, ast.Constant) or not (unit is None or isinstance(unit, ast.Name)):
            return self.check(node)
        if unit is not None and (
            unit.id not in units.UNITS or unit.id in self.ns.parameters or unit.id in self.ns.locals
        ):
            return self.check(node)
        value = Expr("num", NUMBER, value=sign * finite_number(number.value, self.text))
        if unit is None:
            return value
        if unit.id not in self.units:
            self.units[unit.id] = self._name(unit)
        scaled = self.units[unit.id]
        return Expr("mul", scaled.type, (value, scaled))

    def _named_argument_call(self, name: str, args: list[ast.expr]) -> Expr:
        if len(args) != 1 or not isinstance(args[0], ast.Name):
            raise self.fail("wrong-arguments", f"{name}() takes one name", f"see `{FUNCTIONS[name].signature}`")
        target = args[0].id
        if name == "phase" and target not in self.ns.cycles:
            hint = did_you_mean(target, self.ns.cycles) if self.ns.cycles else "add a `type: cycle` element"
            raise self.fail(
                "unknown-cycle", f"phase() needs a cycle element, and there is no cycle named {target!r}", hint
            )
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
        raise ExprError(
            "dimension-mismatch",
            f"vector components mix units in {text!r}",
            "give all three components the same kind of unit, or 0",
        )
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


def leg_rest_length(leg: str) -> Expr:
    """`<leg>.rest_length`: the rest-pose distance from the leg's top to its foot (a length)."""
    ends = (resolve_point_name(f"{leg}.{landmark}") for landmark in ("top", "foot"))
    return Expr("var", Type(SCALAR, units.LENGTH), value=rest_distance_key(*ends))


def resolve_point_name(text: str) -> str:
    """Turn a body point into its canonical `role.anchor` form.

    Accepts `role`, `role.start|end|mid` and the leg landmarks `lf.top`, `lf.foot`.

    Raises:
        ExprError: unknown role, leg or anchor (`unknown-role`, `bad-point`).
    """
    base, dot, anchor = text.strip().partition(".")
    if base in LEGS:
        if anchor not in LEG_LANDMARKS:
            raise ExprError(
                "bad-point",
                f"{text!r}: a leg has the points .top and .foot (and the length .{LEG_REST_LENGTH})",
                did_you_mean(anchor, [*LEG_LANDMARKS, LEG_REST_LENGTH], listing=False) or None,
            )
        return f"{base}_{LEG_LANDMARKS[anchor][base.endswith('f')]}"
    if base not in PARENT:
        raise ExprError(
            "unknown-role",
            f"{base!r} is not a role",
            did_you_mean(base, [*ROLES, *LEGS], listing=False) or "see the roles in docs/controllers.md",
        )
    if not dot:
        return f"{base}.start"
    if anchor not in POINT_ANCHORS:
        raise ExprError(
            "bad-point",
            f"{text!r}: a bone has the points .start, .end and .mid",
            did_you_mean(anchor, POINT_ANCHORS, listing=False) or None,
        )
    return f"{base}.{anchor}"


def check(value: Any, namespace: Namespace) -> Expr:
    """Parse and type a field value: a number, a string expression, or a list of 3 of them.

    Raises:
        ExprError: any syntax, name, type or dimension problem.
    """
    if isinstance(value, bool):
        raise ExprError("wrong-type", f"expected a value, got {str(value).lower()}", "write a number, e.g. 1 or 20 deg")
    if isinstance(value, (int, float)):
        return Expr("num", NUMBER, value=finite_number(value, str(value)), text=str(value))
    if isinstance(value, list):
        items = [check(item, namespace) for item in value]
        vector = make_vector(items, str(value))
        return Expr(vector.op, vector.type, vector.args, text=_list_text(value))
    if not isinstance(value, str):
        raise ExprError("wrong-type", f"expected a value, got {type(value).__name__}")
    node = _Checker(namespace, value).check(parse(value))
    depth = nesting_depth(node, _nested)
    if depth > MAX_EXPRESSION_DEPTH.value:
        raise limit_error(MAX_EXPRESSION_DEPTH, depth)
    refuse_bad_constants(node, value)
    return Expr(node.op, node.type, node.args, node.value, text=value)


def _nested(expr: Expr) -> tuple[Expr, ...]:
    """The nodes inside a node, for its nesting depth: a table's are its x only (its points are
    numbers with units, a few levels deep, and there may be thousands)."""
    return expr.args[:1] if expr.op == "interp" else expr.args


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
