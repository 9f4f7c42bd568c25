"""Compiling a `ControllerSpec` for a set of animals: every value becomes a numpy callable.

`compile_controller(spec, scale)` resolves units per animal (HP, bw, bm, rest lengths) and
returns a `CompiledController`. For each element, `values` maps the key path of every
quantity in it to a `Compiled` (see `expressions.py`): `("strength",)`,
`("direction", "vector")`, `("elastic", "ratio")`, `("reaction", "thorax.mid")`,
`("sites", "lh_hip.start")`. A runtime reads the element's structure (direction kind, frame,
points) from `element.spec` and its numbers from `values`.

Conventions settled here so the runtime need not:

- a segment's strength is always under `("strength",)` as a force: `length2: k` has been
  turned into k x (rest distance of its ends)²;
- force-pair reaction weights are normalised to sum to 1;
- each state of a machine carries compiled variants of the elements it changes.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from quadpipe.controllers.language import schema
from quadpipe.controllers.language.marked import iter_marked
from quadpipe.controllers.language.parameters import cycle_names, element_namespace, sensor_types, type_parameters
from quadpipe.controllers.language.spec import ControllerSpec
from quadpipe.quantities import expressions
from quadpipe.quantities.units import FORCE, LENGTH, Scale

Path = tuple[str, ...]


@dataclass(frozen=True)
class CompiledElement:
    """One element compiled: its canonical spec and its values.

    Attributes:
        name: the element's name.
        type: its `type` (`segment`, ...).
        enabled: whether it acts (in this form).
        spec: the canonical pydantic model (points, frames, direction kind).
        values: key path -> compiled value (see module docstring).
    """

    name: str
    type: str
    enabled: bool
    spec: Any
    values: Mapping[Path, expressions.Compiled]

    def value(self, *path: str) -> expressions.Compiled:
        """The compiled value at a key path, e.g. `element.value("elastic", "ratio")`."""
        return self.values[tuple(path)]


@dataclass(frozen=True)
class CompiledTransition:
    """A transition: states left, state entered, its condition (None: always) and delay."""

    sources: tuple[str, ...]
    target: str
    when: expressions.Compiled | None
    after: expressions.Compiled


@dataclass(frozen=True)
class CompiledState:
    """A state: the compiled form of each element it changes while active."""

    name: str
    elements: Mapping[str, CompiledElement]


@dataclass(frozen=True)
class CompiledMachine:
    """A state machine: initial state, states, transitions in priority order, owned elements."""

    name: str
    initial: str
    states: Mapping[str, CompiledState]
    transitions: tuple[CompiledTransition, ...]
    owned: tuple[str, ...]


@dataclass(frozen=True)
class CompiledController:
    """A controller compiled for `scale.n` animals.

    Attributes:
        name: the controller's name.
        scale: the animals' unit values.
        parameters: name -> compiled value.
        elements: name -> base form of every element but state machines.
        machines: name -> state machine.
        needs: every env key any value reads (see `expressions.py`).
    """

    name: str
    scale: Scale
    parameters: Mapping[str, expressions.Compiled]
    elements: Mapping[str, CompiledElement]
    machines: Mapping[str, CompiledMachine]
    needs: frozenset[str]


def namespace_for(spec: ControllerSpec, overrides: Mapping[str, Any] | None = None) -> expressions.Namespace:
    """The expression namespace of a spec, with some parameters set to other values."""
    values = {name: parameter.value for name, parameter in spec.parameters.items()} | dict(overrides or {})
    sensors, cycles = sensor_types(spec.elements), cycle_names(spec.elements)
    typed = type_parameters(values, sensors, cycles)
    if typed.errors:
        name, exc = next(iter(typed.errors.items()))
        raise ValueError(f"parameter {name!r} of a checked spec does not compile: {exc.message}")
    return expressions.Namespace(typed.exprs, sensors, cycles)


def _constant(value: np.ndarray, typ: expressions.Type, text: str) -> expressions.Compiled:
    return expressions.Compiled(typ, frozenset(), lambda env: value, value, text)


def compile_element(element: Any, namespace: expressions.Namespace, scale: Scale) -> CompiledElement:
    """Compile every quantity of one canonical element (see module docstring)."""
    local = element_namespace(element, namespace)
    values: dict[Path, expressions.Compiled] = {}
    for path, value, marker in iter_marked(element):
        if isinstance(marker, schema.Quantity):
            values[path] = expressions.compile_expr(expressions.check_expected(value, marker.expect, local), scale)
        elif isinstance(marker, schema.PointMap):
            for point, item in value.items():
                values[path + (point,)] = expressions.compile_expr(
                    expressions.check_expected(item, marker.expect, local), scale
                )
    if isinstance(element, schema.Segment) and element.strength is not None:
        values[("strength",)] = _segment_strength(element.strength, values, local, scale)
        values.pop(("strength", "force"), None)
        values.pop(("strength", "length2"), None)
    if isinstance(element, schema.ForcePair):
        _normalise_weights(values, tuple(element.reaction))
    return CompiledElement(element.name, element.type, getattr(element, "enabled", True), element, values)


def _segment_strength(
    strength: schema.Strength,
    values: Mapping[Path, expressions.Compiled],
    namespace: expressions.Namespace,
    scale: Scale,
) -> expressions.Compiled:
    if strength.force is not None:
        return values[("strength", "force")]
    factor = expressions.check_expected(strength.length2, schema.LENGTH2_FACTOR, namespace)
    rest = namespace.locals["rest"]
    force = expressions.Expr(
        "mul",
        expressions.Type(expressions.SCALAR, FORCE),
        (factor, expressions.Expr("mul", expressions.Type(expressions.SCALAR, LENGTH**2), (rest, rest))),
    )
    return expressions.compile_expr(
        expressions.Expr(force.op, force.type, force.args, text=f"({strength.length2}) x rest²"), scale
    )


def _normalise_weights(values: dict[Path, expressions.Compiled], points: tuple[str, ...]) -> None:
    keys = [("reaction", point) for point in points]
    constants = {key: _plain_number(values[key]) for key in keys}
    total = sum(constants.values())
    for key in keys:
        weight = values[key]
        values[key] = _constant(constants[key] / total, weight.type, f"{weight.text} (normalised)")


def _plain_number(compiled: expressions.Compiled) -> np.ndarray:
    """The value of a compiled plain number (the element checks allow only those as reaction weights)."""
    assert compiled.constant is not None, "a plain number compiles to a constant"
    return compiled.constant


def compile_controller(spec: ControllerSpec, scale: Scale) -> CompiledController:
    """Compile a checked controller for the animals of `scale`."""
    namespace = namespace_for(spec)
    parameters = {name: expressions.compile_expr(expr, scale) for name, expr in namespace.parameters.items()}
    elements = {
        name: compile_element(element, namespace, scale)
        for name, element in spec.elements.items()
        if not isinstance(element, schema.StateMachine)
    }
    machines = {}
    for name, machine in spec.machines.items():
        local = element_namespace(spec.elements[name], namespace)
        states = {}
        for state in machine.states.values():
            state_namespace = namespace_for(spec, state.parameters) if state.parameters else namespace
            compiled = {
                target: compile_element(variant, state_namespace, scale) for target, variant in state.elements.items()
            }
            states[state.name] = CompiledState(state.name, compiled)
        transitions = tuple(
            CompiledTransition(
                t.sources,
                t.target,
                expressions.compile_expr(expressions.check_expected(t.when, schema.CONDITION, local), scale)
                if t.when is not None
                else None,
                expressions.compile_expr(expressions.check_expected(t.after, schema.TIME, local), scale),
            )
            for t in machine.transitions
        )
        machines[name] = CompiledMachine(name, machine.initial, states, transitions, machine.owned)
    return CompiledController(spec.name, scale, parameters, elements, machines, _all_needs(elements, machines))


def _all_needs(elements: Mapping[str, CompiledElement], machines: Mapping[str, CompiledMachine]) -> frozenset[str]:
    needs: set[str] = set()
    forms = list(elements.values()) + [
        e for m in machines.values() for s in m.states.values() for e in s.elements.values()
    ]
    for form in forms:
        for value in form.values.values():
            needs |= value.needs
    for machine in machines.values():
        for transition in machine.transitions:
            needs |= transition.after.needs | (transition.when.needs if transition.when else frozenset())
    return frozenset(needs)
