"""Checks of the constant parts of an expression: finite numbers, function domains, division
by zero, and the points of tables (finite, breakpoints not decreasing).

A part is constant when it needs nothing from the simulation; one that needs neither the
animal is evaluated once, and one that depends on the animal is tried on sample animals from
a mouse's size to beyond an elephant's (`SAMPLE_SCALE`).
"""

from __future__ import annotations

import math
import sys
from typing import Any

import numpy as np

from quadpipe.quantities import units
from quadpipe.quantities.evaluation import compile_expr, evaluate_constant, table_arrays
from quadpipe.quantities.functions import FUNCTIONS
from quadpipe.quantities.nodes import BOOL, REST_PREFIX, Expr, ExprError

NON_FINITE_WORDS = frozenset({"nan", "inf", "infinity"})
"""Names that read as numbers which are not finite (`--set froude=nan`, `inf * m/s`)."""


def finite_number(value: Any, text: str) -> float:
    """A literal number as a float; infinite or NaN ones (`1e309`, `.inf`, `.nan`) are refused.

    Raises:
        ExprError: `non-finite-number`.
    """
    try:
        number = float(value)
    except OverflowError:
        number = math.inf
    if not math.isfinite(number):
        raise ExprError(
            "non-finite-number",
            f"{text if len(text) <= 40 else text[:20] + '...' + text[-8:]!r} is not a finite number",
            f"write a number between -{sys.float_info.max:.3g} and {sys.float_info.max:.3g}",
        )
    return number


def refuse_bad_constants(expr: Expr, text: str) -> None:
    """Refuse a division by a constant zero, and a constant part whose value is not finite.

    A part is constant when it needs neither the simulation nor the animal (`10^10^10`,
    `1e308 * 1e308`); each is evaluated once, innermost first. Parts that depend on the
    animal (`0.5 bw / 0`) are only checked for a zero divisor.

    Raises:
        ExprError: `division-by-zero` or `non-finite-number`.
    """
    seen: set[int] = set()
    stack = [expr]
    order: list[Expr] = []
    while stack:
        node = stack.pop()
        if id(node) not in seen:
            seen.add(id(node))
            order.append(node)
            stack.extend(node.args[:1] if node.op == "interp" else node.args)  # a table checks its points
    with np.errstate(all="ignore"):
        for node in reversed(order):
            if node.op == "div" and _is_fixed(node.args[1]) and np.all(evaluate_constant(node.args[1]) == 0):
                raise ExprError(
                    "division-by-zero",
                    f"in {text!r}: this divides by zero",
                    "a divisor that is always zero is a mistake: check the number after '/'",
                )
            if node.op not in ("num", "unit") and _is_fixed(node) and node.type.kind != BOOL:
                need_finite(evaluate_constant(node), text)
            if node.op == "call" and FUNCTIONS[node.value].domain is not None:
                _need_in_domain(node, text)


def need_finite(value: np.ndarray, text: str) -> None:
    """Refuse the value of a constant part of `text` when it is not finite (it overflowed)."""
    if not np.all(np.isfinite(value)):
        raise ExprError(
            "non-finite-number",
            f"in {text!r}: a constant part overflows: its value is not a finite number",
            f"keep every value between -{sys.float_info.max:.3g} and {sys.float_info.max:.3g}",
        )


SAMPLE_SCALE = units.Scale.of([0.01, 1.0, 100.0], [0.001, 1.0, 1000.0])
"""Animals from a mouse's size to beyond an elephant's: a part that depends on the animal is
refused only when it is wrong for every one of them."""


def _need_in_domain(call: Expr, text: str) -> None:
    """Refuse a constant argument outside its function's domain (`sqrt(-HP / g)`, `acos(2)`).

    An argument that depends on the animal is refused when it is outside for every animal of
    `SAMPLE_SCALE`; one that reads rest lengths or the simulation is left to the runtime.
    """
    function = FUNCTIONS[call.value]
    argument = call.args[0]
    if function.domain is None or not argument.is_constant or _reads_rest(argument):
        return
    inside, words = function.domain
    value = evaluate_constant(argument) if _is_fixed(argument) else compile_expr(argument, SAMPLE_SCALE)({})
    if not np.any(inside(value)):
        raise ExprError(
            "non-finite-number",
            f"in {text!r}: {function.name}() is given a constant that is not {words}: its value is not a number",
            "check the sign and the units of what it is given",
        )


def need_finite_order(table: Expr, text: str) -> None:
    """Refuse a table whose points are not finite or whose breakpoints decrease, for any animal
    of `SAMPLE_SCALE` (a repeat is a jump, allowed); tables reading rest lengths are left to
    the runtime.

    Raises:
        ExprError: `non-finite-number`, `table-order`.
    """
    if _reads_rest(table):
        return
    with np.errstate(all="ignore"):
        breakpoints, values = table_arrays(table, SAMPLE_SCALE)
    need_finite(breakpoints, text)
    need_finite(values, text)
    falls = np.nonzero(np.any(np.diff(breakpoints, axis=1) < 0, axis=0))[0]
    if falls.size:
        raise ExprError(
            "table-order",
            f"in {text!r}: the breakpoints of a table must not decrease, "
            f"but breakpoint {falls[0] + 2} is below breakpoint {falls[0] + 1}",
            "sort the table's points by their breakpoint (repeat a breakpoint for a jump)",
        )


def is_literal(expr: Expr) -> bool:
    """Whether a node is a number with a unit, or a vector of them (no division, nothing that
    can overflow but what `need_finite_order` finds)."""
    return expr.op in ("num", "unit", "neg", "mul", "vec") and all(is_literal(arg) for arg in expr.args)


def _reads_rest(expr: Expr) -> bool:
    """Whether an expression reads a rest length (known only with the animal's skeleton)."""
    return (expr.op == "var" and str(expr.value).startswith(REST_PREFIX)) or any(_reads_rest(a) for a in expr.args)


def _is_fixed(expr: Expr) -> bool:
    """Whether a node's value is known without the simulation or the animal."""
    return expr.is_constant and not expr.uses_scale
