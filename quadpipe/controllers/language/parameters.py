"""Typing a controller's parameters, and the names expressions see.

Parameters are checked in dependency order (each after the parameters it uses), so a
problem is reported once, where it is, and the parameters using a broken one are skipped
rather than reported again. The namespaces of element fields add their local names.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from quadpipe.anatomy.roles import LEGS, ROLES
from quadpipe.controllers.language import schema
from quadpipe.quantities import expressions, units

SENSOR_TYPES: dict[str, expressions.Type] = {
    "balance": expressions.Type(expressions.VECTOR, units.ACCELERATION),
    "contact_normal": expressions.Type(expressions.VECTOR),
    "velocity": expressions.Type(expressions.VECTOR, units.VELOCITY),
    "height": expressions.Type(expressions.SCALAR, units.LENGTH),
}
"""The type of each sensor kind's value in expressions."""


@dataclass
class ParameterTyping:
    """Parameters typed in dependency order.

    Attributes:
        exprs: name -> checked expression, for those that passed.
        errors: name -> its own problem (syntax, names, a dependency loop).
        skipped: names not checked because they use a parameter with a problem.
        deps: name -> the parameters it uses directly.
    """

    exprs: dict[str, expressions.Expr] = field(default_factory=dict)
    errors: dict[str, expressions.ExprError] = field(default_factory=dict)
    skipped: set[str] = field(default_factory=set)
    deps: dict[str, set[str]] = field(default_factory=dict)

    def closure(self, names: set[str]) -> set[str]:
        """`names` and every parameter they use, directly or not."""
        result, todo = set(), list(names)
        while todo:
            name = todo.pop()
            if name in result or name not in self.deps:
                continue
            result.add(name)
            todo.extend(self.deps[name])
        return result


def _dependency_order(deps: Mapping[str, set[str]]) -> tuple[list[str], dict[str, list[str]]]:
    """Names with dependencies first, and the loops found (name -> loop path)."""
    order: list[str] = []
    loops: dict[str, list[str]] = {}
    state: dict[str, int] = {}

    def visit(name: str, stack: list[str]) -> None:
        if state.get(name) == 2:
            return
        if state.get(name) == 1:
            loop = stack[stack.index(name) :] + [name]
            for member in loop[:-1]:
                loops.setdefault(member, loop)
            return
        state[name] = 1
        for dep in sorted(deps[name]):
            visit(dep, stack + [name])
        state[name] = 2
        if name not in loops:
            order.append(name)

    for name in deps:
        visit(name, [])
    return order, loops


def type_parameters(
    values: Mapping[str, Any], sensors: Mapping[str, expressions.Type], cycles: set[str]
) -> ParameterTyping:
    """Check every parameter value, each after the parameters it uses."""
    result = ParameterTyping()
    result.deps = {name: expressions.referenced_names(value) & set(values) for name, value in values.items()}
    order, loops = _dependency_order(result.deps)
    for name, loop in loops.items():
        result.errors[name] = expressions.ExprError(
            "parameter-cycle",
            f"parameter {name!r} depends on itself: {' -> '.join(loop)}",
            "break the loop by giving one of them a plain value",
        )
    texts = {name: str(value) for name, value in values.items()}
    for name in order:
        if result.deps[name] & (set(result.errors) | result.skipped):
            result.skipped.add(name)
            continue
        namespace = expressions.Namespace(dict(result.exprs), sensors, cycles, parameter_texts=texts)
        try:
            result.exprs[name] = expressions.check(values[name], namespace)
        except expressions.ExprError as exc:
            result.errors[name] = exc
    return result


def element_namespace(element: schema._Element, namespace: expressions.Namespace) -> expressions.Namespace:
    """The namespace of an element's fields: adds `rest` (segments, springs), `time_in_state`."""
    if isinstance(element, schema.Segment):
        try:
            ends = expressions.resolve_point_name(element.from_), expressions.resolve_point_name(element.to)
        except expressions.ExprError:
            ends = element.from_, element.to
        return namespace.with_locals(
            rest=expressions.Expr(
                "var", expressions.Type(expressions.SCALAR, units.LENGTH), value=expressions.rest_distance_key(*ends)
            )
        )
    if isinstance(element, schema.Spring):
        return namespace.with_locals(
            rest=expressions.Expr("num", expressions.Type(expressions.SCALAR, units.ANGLE), value=0.0)
        )
    if isinstance(element, schema.StateMachine):
        return namespace.with_locals(
            time_in_state=expressions.Expr(
                "var", expressions.Type(expressions.SCALAR, units.TIME), value=f"time_in_state:{element.name}"
            )
        )
    return namespace


def sensor_types(elements: Mapping[str, Any]) -> dict[str, expressions.Type]:
    """Sensor name -> type of its value."""
    return {name: SENSOR_TYPES[model.kind] for name, model in elements.items() if isinstance(model, schema.Sensor)}


def cycle_names(elements: Mapping[str, Any]) -> set[str]:
    """Names of the cycle elements."""
    return {name for name, model in elements.items() if isinstance(model, schema.Cycle)}


def clash(name: str) -> str | None:
    """What a reserved name already means, or None if it is free."""
    for label, names in (
        ("a unit", units.UNITS),
        ("a function", expressions.FUNCTIONS),
        ("a role", ROLES),
        ("a leg", LEGS),
        ("a built-in name", (expressions.TIME_VARIABLE, *expressions.CONSTANTS, *expressions.LOCAL_NAMES)),
    ):
        if name in names:
            return label
    return None
