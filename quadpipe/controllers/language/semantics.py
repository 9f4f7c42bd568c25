"""Checking what a merged controller means, and building its `ControllerSpec`.

After `loader.merge_controller` has checked the structure, this module checks the values:
expressions (syntax, names, types, dimensions), body points, role globs, legs, frames,
references between parts (parameters, sensors, cycles, states, elements), the rules of each
element type, and state machines. Every problem becomes a located `Issue`; warnings
(unused parameters and sensors, unreachable states) do not stop loading.

Fields are found through the markers of `schema.py` (`iter_marked`), so a new field with a
`Quantity(...)` marker is checked without touching this module.
"""

from __future__ import annotations

import re
import types
import typing
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterator, Mapping

import numpy as np
import pydantic

from quadpipe.core import configs
from quadpipe.anatomy.roles import LEGS, PARENT, ROLES, match_roles
from quadpipe.quantities import expressions
from quadpipe.controllers.language import schema
from quadpipe.quantities import units
from quadpipe.controllers.language.loader import (
    CONTROLLER_KIND,
    ElementEntry,
    MergedController,
    Origin,
    deep_merge,
    match_names,
    merge_controller,
    pydantic_issues,
    resolve_legs,
)
from quadpipe.controllers.language.spec import ControllerSpec, MachineSpec, ParameterSpec, StateSpec, TransitionSpec
from quadpipe.core.errors import Issue, Location, QuadpipeError, did_you_mean

IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")
"""Parameters, sensors and cycles are used in expressions, so their names must be identifiers."""

PARALLEL_SINE = 1e-6
"""Below this sine of the angle between them, a cycle's axis and reference are parallel."""

MARKERS = (schema.Quantity, schema.BodyPoint, schema.PointMap, schema.RoleGlobs, schema.LegSet, schema.FrameName, schema.ElementNames)

SENSOR_TYPES: dict[str, expressions.Type] = {
    "balance": expressions.Type(expressions.VECTOR, units.ACCELERATION),
    "contact_normal": expressions.Type(expressions.VECTOR),
    "velocity": expressions.Type(expressions.VECTOR, units.VELOCITY),
    "height": expressions.Type(expressions.SCALAR, units.LENGTH),
}
"""The type of each sensor kind's value in expressions."""

SENSOR_KEYS: dict[str, tuple[set[str], set[str]]] = {
    "balance": ({"at"}, {"feet"}),
    "contact_normal": (set(), {"at", "horizon"}),
    "velocity": ({"at"}, {"feet", "horizon"}),
    "height": ({"at"}, {"feet", "horizon"}),
}
"""Sensor kind -> (keys it needs, keys it does not take)."""


# --------------------------------------------------------------------------- marked fields


def _markers_in(annotation: Any) -> list[Any]:
    found = []
    if hasattr(annotation, "__metadata__"):
        found += [m for m in annotation.__metadata__ if isinstance(m, MARKERS)]
        annotation = typing.get_args(annotation)[0]
    if typing.get_origin(annotation) in (typing.Union, types.UnionType):
        for arm in typing.get_args(annotation):
            found += _markers_in(arm)
    return found


def field_markers(info: Any) -> list[Any]:
    """The markers of a pydantic field (on the field itself or inside its union arms)."""
    return [m for m in info.metadata if isinstance(m, MARKERS)] + _markers_in(info.annotation)


def iter_marked(model: pydantic.BaseModel, path: tuple[Any, ...] = ()) -> Iterator[tuple[tuple[Any, ...], Any, Any]]:
    """Every marked field value inside a model, as (key path, value, marker); None values skipped."""
    for name, info in type(model).model_fields.items():
        value = getattr(model, name)
        if value is None:
            continue
        here = path + (info.alias or name,)
        for marker in field_markers(info):
            yield here, value, marker
        if isinstance(value, pydantic.BaseModel):
            yield from iter_marked(value, here)
        elif isinstance(value, dict):
            for key, item in value.items():
                if isinstance(item, pydantic.BaseModel):
                    yield from iter_marked(item, here + (key,))
        elif isinstance(value, list):
            for index, item in enumerate(value):
                if isinstance(item, pydantic.BaseModel):
                    yield from iter_marked(item, here + (index,))


# --------------------------------------------------------------------------- parameters


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


def type_parameters(values: Mapping[str, Any], sensors: Mapping[str, expressions.Type], cycles: set[str]) -> ParameterTyping:
    """Check every parameter value, each after the parameters it uses."""
    result = ParameterTyping()
    result.deps = {name: expressions.referenced_names(value) & set(values) for name, value in values.items()}
    order, loops = _dependency_order(result.deps)
    for name, loop in loops.items():
        result.errors[name] = expressions.ExprError("parameter-cycle", f"parameter {name!r} depends on itself: {' -> '.join(loop)}", "break the loop by giving one of them a plain value")
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
        return namespace.with_locals(rest=expressions.Expr("var", expressions.Type(expressions.SCALAR, units.LENGTH), value=expressions.rest_distance_key(*ends)))
    if isinstance(element, schema.Spring):
        return namespace.with_locals(rest=expressions.Expr("num", expressions.Type(expressions.SCALAR, units.ANGLE), value=0.0))
    if isinstance(element, schema.StateMachine):
        return namespace.with_locals(time_in_state=expressions.Expr("var", expressions.Type(expressions.SCALAR, units.TIME), value=f"time_in_state:{element.name}"))
    return namespace


def sensor_types(elements: Mapping[str, Any]) -> dict[str, expressions.Type]:
    """Sensor name -> type of its value."""
    return {name: SENSOR_TYPES[model.kind] for name, model in elements.items() if isinstance(model, schema.Sensor)}


def cycle_names(elements: Mapping[str, Any]) -> set[str]:
    """Names of the cycle elements."""
    return {name for name, model in elements.items() if isinstance(model, schema.Cycle)}


def _clash(name: str) -> str | None:
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


# --------------------------------------------------------------------------- analysis


@dataclass
class _Checked:
    """What checking one element produced: canonical values and names it uses."""

    replacements: dict[tuple[Any, ...], Any] = field(default_factory=dict)
    names: set[str] = field(default_factory=set)


class _Analysis:
    """Checks one merged controller; `run` returns the spec (None when there are errors)."""

    def __init__(self, merged: MergedController, issues: list[Issue], overrides: Mapping[str, Any], override_where: Callable[[str], Location]) -> None:
        self.merged = merged
        self.issues = issues
        self.entries = merged.elements
        self.models = {name: entry.model for name, entry in self.entries.items()}
        self.overrides = overrides
        self.override_where = override_where
        self.sensors = sensor_types(self.models)
        self.cycles = cycle_names(self.models)
        self.used: set[str] = set()
        self.clashing: set[str] = set()
        """Names whose value cannot be trusted (a name clash, a bad override): uses are not checked."""
        self.element_parameters: dict[str, set[str]] = {}

    def error(self, code: str, message: str, where: Location | None, hint: str | None = None) -> None:
        self.issues.append(Issue(code, message, where, hint))

    def warn(self, code: str, message: str, where: Location | None, hint: str | None = None) -> None:
        self.issues.append(Issue(code, message, where, hint, severity="warning"))

    # -- names and parameters

    def check_names(self) -> None:
        for name, entry in self.entries.items():
            if entry.raw["type"] not in ("sensor", "cycle"):
                continue
            self._check_name(name, f"{entry.raw['type']} {name!r}", entry.origin.locate(("name",)))
        for name, parameter in self.merged.parameters.items():
            self._check_name(name, f"parameter {name!r}", parameter.where)
            if name in self.sensors or name in self.cycles:
                self.error("name-clash", f"parameter {name!r} has the name of an element used in expressions", parameter.where, "rename one of them")

    def _check_name(self, name: str, what: str, where: Location) -> None:
        if not IDENTIFIER.match(name):
            self.error("bad-name", f"{what} is used in expressions, so its name may only hold letters, digits and _", where, "e.g. hip_pedal")
        elif (meaning := _clash(name)) is not None:
            self.error("name-clash", f"{what} has the name of {meaning}", where, "choose another name")
            self.clashing.add(name)

    def type_parameters(self) -> ParameterTyping:
        values = {name: entry.value for name, entry in self.merged.parameters.items()}
        typing_ = type_parameters(values, self.sensors, self.cycles)
        for name, exc in typing_.errors.items():
            if not expressions.referenced_names(values[name]) & self.clashing:
                self.error(exc.code, exc.message, self.merged.parameters[name].where, exc.hint)
        for name in self.merged.parameters:
            self.used |= expressions.referenced_names(values[name]) - {name}
        if not self.overrides:
            return typing_
        for name, value in self.overrides.items():
            if name not in values:
                self.error("unknown-parameter", f"the controller has no parameter {name!r}", self.override_where(name), did_you_mean(name, values))
        known = {name: value for name, value in self.overrides.items() if name in values}
        changed = type_parameters({**values, **known}, self.sensors, self.cycles)
        for name in known:
            self._compare_override(name, typing_, changed)
        return changed

    def _compare_override(self, name: str, before: ParameterTyping, after: ParameterTyping) -> None:
        where = self.override_where(name)
        if name in after.errors:
            exc = after.errors[name]
            self.error(exc.code, exc.message, where, exc.hint)
            self.clashing.add(name)
        elif name in before.exprs and name in after.exprs and before.exprs[name].type != after.exprs[name].type:
            old, new = before.exprs[name].type, after.exprs[name].type
            self.error(
                "wrong-dimension" if old.kind == new.kind else "wrong-type",
                f"parameter {name!r} is {old.describe()} in the controller, the new value is {new.describe()}",
                where,
                f"the controller has {self.merged.parameters[name].value!r}",
            )
            self.clashing.add(name)

    # -- elements

    def check_element(self, entry: ElementEntry, model: Any, origin: Origin, namespace: expressions.Namespace, failed: set[str]) -> _Checked:
        checked = _Checked()
        local = element_namespace(model, namespace)
        for path, value, marker in iter_marked(model):
            self._check_marked(path, value, marker, origin, local, failed, checked)
        rule = getattr(self, f"_rules_{model.type}", None)
        if rule is not None:
            rule(model, origin, local, entry.label)
        return checked

    def _check_marked(self, path: tuple, value: Any, marker: Any, origin: Origin, namespace: expressions.Namespace, failed: set[str], checked: _Checked) -> None:
        if isinstance(marker, schema.Quantity):
            checked.names |= expressions.referenced_names(value)
            self._quantity(value, marker.expect, origin.locate(path), namespace, failed)
        elif isinstance(marker, schema.BodyPoint):
            point = self._point(value, origin.locate(path))
            if point is not None:
                checked.replacements[path] = point
        elif isinstance(marker, schema.PointMap):
            checked.replacements[path] = self._point_map(path, value, marker.expect, origin, namespace, failed, checked)
        elif isinstance(marker, schema.RoleGlobs):
            checked.replacements[path] = self._joints(path, value, origin)
        elif isinstance(marker, schema.LegSet):
            legs, unknown = resolve_legs(value, self.merged.groups)
            for bad in unknown:
                self.error("unknown-leg", f"{bad!r} is neither a leg nor a group", origin.locate(path), did_you_mean(bad, [*LEGS, *self.merged.groups]))
            checked.replacements[path] = legs
        elif isinstance(marker, schema.FrameName) and value not in schema.FRAMES and value not in PARENT:
            self.error("unknown-frame", f"there is no frame {value!r}", origin.locate(path), did_you_mean(value, [*schema.FRAMES, *ROLES], listing=False) or "use heading, world or a role")

    def _quantity(self, value: Any, expect: expressions.Expect, where: Location, namespace: expressions.Namespace, failed: set[str]) -> None:
        if expressions.referenced_names(value) & failed:
            return
        try:
            expressions.check_expected(value, expect, namespace)
        except expressions.ExprError as exc:
            self.error(exc.code, exc.message, where, exc.hint)

    def _point(self, text: str, where: Location) -> str | None:
        try:
            return expressions.resolve_point_name(text)
        except expressions.ExprError as exc:
            self.error(exc.code, exc.message, where, exc.hint)
            return None

    def _point_map(self, path: tuple, mapping: dict, expect: expressions.Expect, origin: Origin, namespace: expressions.Namespace, failed: set[str], checked: _Checked) -> dict:
        canonical = {}
        for key, value in mapping.items():
            point = self._point(key, origin.locate(path + (key,), key=True))
            checked.names |= expressions.referenced_names(value)
            self._quantity(value, expect, origin.locate(path + (key,)), namespace, failed)
            if point in canonical:
                self.error("duplicate-point", f"{key!r} is the same point as another key here ({point})", origin.locate(path + (key,), key=True), "merge their values")
            canonical[point or key] = value
        if not mapping:
            self.error("invalid-value", f"`{path[-1]}` needs at least one body point", origin.locate(path))
        return canonical

    def _joints(self, path: tuple, patterns: list[str], origin: Origin) -> list[str]:
        roles: list[str] = []
        for index, pattern in enumerate(patterns):
            where = origin.locate(path + (index,))
            if pattern == "pelvis":
                self.error("no-joint", "the pelvis is the root of the skeleton: it has no joint to put a spring on", where, "springs on the spine start at spine0")
                continue
            matched = [role for role in match_roles(pattern) if PARENT[role] is not None]
            if not matched and not any(ch in pattern for ch in "*?["):
                self.error("unknown-role", f"{pattern!r} is not a role", where, did_you_mean(pattern, ROLES, listing=False) or "see the roles in docs/controllers.md")
            elif not matched:
                self.error("glob-matches-nothing", f"{pattern!r} matches no joint", where, "globs match roles: spine*, *_hip, lf_*, *_* (all leg joints)")
            roles.extend(role for role in matched if role not in roles)
        return roles

    # -- per-type rules

    def _direction(self, direction: schema.Direction | None, path: tuple, origin: Origin, namespace: expressions.Namespace) -> None:
        if direction is None:
            return
        given = [key for key in ("vector", "toward", "balance") if getattr(direction, key) is not None]
        if len(given) != 1:
            got = " and ".join(given) if given else "none"
            self.error("direction-kind", f"a direction needs exactly one of vector, toward or balance; got {got}", origin.locate(path))
        if "horizon" in direction.model_fields_set and direction.balance is None:
            self.error("unused-key", "`horizon` only applies to a `balance` direction", origin.locate(path + ("horizon",), key=True))
        if direction.vector is not None:
            self._nonzero(direction.vector, origin.locate(path + ("vector",)), namespace)

    def _constant_vector(self, value: Any, namespace: expressions.Namespace) -> np.ndarray | None:
        try:
            expr = expressions.check(value, namespace)
        except expressions.ExprError:
            return None
        if expr.type.kind != expressions.VECTOR or not expr.is_constant:
            return None
        return np.asarray(expressions.evaluate_constant(expr), dtype=float)

    def _nonzero(self, value: Any, where: Location, namespace: expressions.Namespace) -> None:
        vector = self._constant_vector(value, namespace)
        if vector is not None and not np.linalg.norm(vector) > 0:
            self.error("zero-vector", f"the vector {value!r} has no direction", where, "give at least one non-zero component")

    def _rules_segment(self, model: schema.Segment, origin: Origin, namespace: expressions.Namespace, label: str) -> None:
        self._direction(model.direction, ("direction",), origin, namespace)
        if model.direction is not None and model.strength is None:
            self.error("missing-key", f"{label} has a direction but no `strength`", origin.locate(("direction",), key=True), "add e.g. `strength: {length2: 0.5 bw/HP^2}`")
        if model.strength is not None and model.direction is None:
            self.error("missing-key", f"{label} has a strength but no `direction` to push along", origin.locate(("strength",), key=True), "add e.g. `direction: [0, 0, -1]`")
        if model.direction is None and model.elastic is None:
            self.error("nothing-to-do", f"{label} has neither a direction nor an elastic", origin.locate(("name",)), "give it `direction` + `strength`, or `elastic`")
        if model.strength is not None and (model.strength.force is None) == (model.strength.length2 is None):
            self.error("strength-kind", "a strength is either a force or `length2: factor`, not both", origin.locate(("strength",)))
        try:
            same = expressions.resolve_point_name(model.from_) == expressions.resolve_point_name(model.to)
        except expressions.ExprError:
            same = False
        if same:
            self.error("same-point", f"{label} starts and ends at the same point", origin.locate(("to",)), "a segment joins two different points")

    def _rules_force_pair(self, model: schema.ForcePair, origin: Origin, namespace: expressions.Namespace, label: str) -> None:
        self._direction(model.direction, ("direction",), origin, namespace)
        weights = []
        for key, value in model.reaction.items():
            try:
                expr = expressions.check(value, namespace)
            except expressions.ExprError:
                return
            if not expr.is_constant or expr.uses_scale or expr.type != expressions.NUMBER:
                self.error("bad-weights", f"reaction weight {value!r} must be a plain number", origin.locate(("reaction", key)))
                return
            weights.append(float(expressions.evaluate_constant(expr)))
        if any(weight < 0 for weight in weights) or (weights and sum(weights) <= 0):
            self.error("bad-weights", "reaction weights must be positive (they are shares of the opposite force)", origin.locate(("reaction",)))

    def _rules_pull(self, model: schema.Pull, origin: Origin, namespace: expressions.Namespace, label: str) -> None:
        self._direction(model.direction, ("direction",), origin, namespace)

    def _rules_cycle(self, model: schema.Cycle, origin: Origin, namespace: expressions.Namespace, label: str) -> None:
        self._nonzero(model.axis, origin.locate(("axis",)), namespace)
        axis, reference = self._constant_vector(model.axis, namespace), self._constant_vector(model.reference, namespace)
        if axis is None or reference is None or not np.linalg.norm(axis) > 0 or not np.linalg.norm(reference) > 0:
            return
        sine = np.linalg.norm(np.cross(axis, reference)) / (np.linalg.norm(axis) * np.linalg.norm(reference))
        if sine < PARALLEL_SINE:
            self.error("parallel-axis", f"{label}: `reference` is parallel to `axis`, so the force cannot turn about it", origin.locate(("reference",)), "give a reference across the axis, e.g. [1, 0, 0] for axis [0, 1, 0]")

    def _rules_sensor(self, model: schema.Sensor, origin: Origin, namespace: expressions.Namespace, label: str) -> None:
        needed, refused = SENSOR_KEYS[model.kind]
        for key in sorted(needed):
            if getattr(model, key) is None:
                self.error("missing-key", f"a {model.kind} sensor needs `{key}`", origin.locate(("kind",)))
        for key in sorted(refused):
            if getattr(model, key) is not None:
                self.error("unused-key", f"a {model.kind} sensor does not take `{key}`", origin.locate((key,), key=True))

    # -- state machines

    def check_machine(self, name: str, entry: ElementEntry, typing_: ParameterTyping, failed: set[str]) -> MachineSpec | None:
        model: schema.StateMachine = entry.model
        origin = entry.origin
        states = model.states
        ok = True
        if model.initial not in states:
            self.error("unknown-state", f"initial state {model.initial!r} is not one of the states", origin.locate(("initial",)), did_you_mean(model.initial, states))
            ok = False
        transitions = []
        for index, transition in enumerate(model.transitions):
            sources = tuple(states) if "*" in transition.from_ else tuple(transition.from_)
            for position, source in enumerate(transition.from_):
                if source != "*" and source not in states:
                    where = origin.locate(("transitions", index, "from", position))
                    self.error("unknown-state", f"transition {index + 1} leaves {source!r}, which is not a state", where, did_you_mean(source, states))
                    ok = False
            if transition.to not in states:
                self.error("unknown-state", f"transition {index + 1} goes to {transition.to!r}, which is not a state", origin.locate(("transitions", index, "to")), did_you_mean(transition.to, states))
                ok = False
            self.used |= expressions.referenced_names(transition.when) | expressions.referenced_names(transition.after)
            transitions.append(TransitionSpec(sources, transition.to, transition.when, transition.after))
        reachable = {model.initial} | {transition.to for transition in model.transitions}
        for state in states if model.initial in states else ():
            if state not in reachable:
                self.warn("unreachable-state", f"no transition enters state {state!r}", origin.locate(("states", state), key=True), f"add a transition `to: {state}`")
        built = {state_name: self._state(state_name, state, entry, typing_, failed) for state_name, state in states.items()}
        if not ok or any(state is None for state in built.values()):
            return None
        owned = sorted({element for state in built.values() for element in state.elements})
        return MachineSpec(name, model.initial, built, tuple(transitions), tuple(owned))

    def _state(self, state_name: str, state: schema.State, entry: ElementEntry, typing_: ParameterTyping, failed: set[str]) -> StateSpec | None:
        origin, base = entry.origin, ("states", state_name)
        switches: dict[str, bool] = {}
        for key, flag in (("enable", True), ("disable", False)):
            for index, pattern in enumerate(getattr(state, key)):
                for target in self._targets(pattern, origin.locate(base + (key, index)), state_name):
                    switches[target] = flag
        changed = self._state_parameters(state, origin, base, typing_)
        if changed is None:
            return None
        affected = set(switches) | {name for name, params in self.element_parameters.items() if params & set(changed)}
        patches: dict[str, tuple[dict, Origin]] = {}
        for pattern, patch in state.set.items():
            where = origin.locate(base + ("set", pattern), key=True)
            if any(key in patch for key in ("type", "name", "for_each")):
                self.error("bad-override", "a state cannot change an element's type, name or for_each", where)
                continue
            for target in self._targets(pattern, where, state_name):
                layer = origin.sublayer(base + ("set", pattern), patch)
                patches[target] = (patch, self.entries[target].origin.patched(layer))
                affected.add(target)
        namespace = expressions.Namespace(typing_.exprs if not changed else self._state_exprs(changed), self.sensors, self.cycles)
        variants = {}
        for target in sorted(affected, key=list(self.entries).index):
            variant = self._variant(target, switches.get(target), patches.get(target), namespace, failed)
            if variant is not None:
                variants[target] = variant
        return StateSpec(state_name, state.description, {name: state.parameters[name] for name in state.parameters}, variants)

    def _targets(self, pattern: str, where: Location, state_name: str) -> list[str]:
        matched = match_names(pattern, self.entries)
        if not matched:
            self.error("unknown-element", f"state {state_name!r} names {pattern!r}, but no element matches", where, did_you_mean(pattern, self.entries))
        switchable = [name for name in matched if self.entries[name].raw["type"] in schema.FORCE_ELEMENT_TYPES]
        for name in matched:
            if name not in switchable:
                self.error("not-switchable", f"{name!r} is a {self.entries[name].raw['type']}; states only switch and change force elements", where, f"force elements: {', '.join(schema.FORCE_ELEMENT_TYPES)}")
        return switchable

    def _state_parameters(self, state: schema.State, origin: Origin, base: tuple, typing_: ParameterTyping) -> dict[str, Any] | None:
        known = {name: value for name, value in state.parameters.items() if name in self.merged.parameters}
        for name in state.parameters:
            self.used |= expressions.referenced_names(state.parameters[name])
            if name not in known:
                self.error("unknown-parameter", f"there is no parameter {name!r} to set", origin.locate(base + ("parameters", name), key=True), did_you_mean(name, self.merged.parameters))
        if not known:
            return {} if len(known) == len(state.parameters) else None
        values = {name: entry.value for name, entry in self.merged.parameters.items()} | {name: self.overrides[name] for name in self.overrides if name in self.merged.parameters}
        changed = type_parameters({**values, **known}, self.sensors, self.cycles)
        ok = len(known) == len(state.parameters)
        for name in known:
            where = origin.locate(base + ("parameters", name))
            if name in changed.errors:
                exc = changed.errors[name]
                self.error(exc.code, exc.message, where, exc.hint)
                ok = False
            elif name in typing_.exprs and name in changed.exprs and typing_.exprs[name].type != changed.exprs[name].type:
                self.error("wrong-dimension", f"parameter {name!r} is {typing_.exprs[name].type.describe()}, but this state gives {changed.exprs[name].type.describe()}", where, f"the parameter is {self.merged.parameters[name].value!r}")
                ok = False
        return known if ok else None

    def _state_exprs(self, changed: Mapping[str, Any]) -> dict[str, expressions.Expr]:
        values = {name: entry.value for name, entry in self.merged.parameters.items()} | dict(self.overrides) | dict(changed)
        return type_parameters({k: v for k, v in values.items() if k in self.merged.parameters}, self.sensors, self.cycles).exprs

    def _variant(self, name: str, switch: bool | None, patch: tuple[dict, Origin] | None, namespace: expressions.Namespace, failed: set[str]) -> Any:
        entry = self.entries[name]
        raw, origin = (deep_merge(entry.raw, patch[0]), patch[1]) if patch else (entry.raw, entry.origin)
        if switch is not None:
            raw = {**raw, "enabled": switch}
        model_type = schema.MODEL_OF_TYPE[raw["type"]]
        try:
            model = model_type.model_validate(raw)
        except pydantic.ValidationError as exc:
            self.issues.extend(pydantic_issues(exc, model_type, origin.locate, f"{entry.label} in this state"))
            return None
        checked = self.check_element(entry, model, origin, namespace, failed)
        self.used |= checked.names
        return canonical(model, checked.replacements)

    # -- whole controller

    def run(self) -> ControllerSpec | None:
        self.check_names()
        typing_ = self.type_parameters()
        failed = set(typing_.errors) | typing_.skipped | self.clashing
        namespace = expressions.Namespace(typing_.exprs, self.sensors, self.cycles, parameter_texts={n: str(e.value) for n, e in self.merged.parameters.items()})
        elements = {}
        for name, entry in self.entries.items():
            checked = self.check_element(entry, entry.model, entry.origin, namespace, failed)
            self.used |= checked.names
            self.element_parameters[name] = typing_.closure(checked.names & set(self.merged.parameters))
            elements[name] = canonical(entry.model, checked.replacements)
        machines = {}
        for name, entry in self.entries.items():
            if entry.raw["type"] == "state_machine":
                machine = self.check_machine(name, entry, typing_, failed)
                if machine is not None:
                    machines[name] = machine
        self._check_ownership(machines)
        self._warn_unused()
        if any(issue.severity == "error" for issue in self.issues):
            return None
        parameters = {
            name: ParameterSpec(name, entry.value, entry.description, typing_.exprs[name].type, entry.where)
            for name, entry in self.merged.parameters.items()
        }
        for name, value in self.overrides.items():
            parameters[name] = ParameterSpec(name, value, parameters[name].description, typing_.exprs[name].type, self.override_where(name))
        warnings = tuple(issue for issue in self.issues if issue.severity != "error")
        return ControllerSpec(self.merged.name, self.merged.description, tuple(self.merged.sources), parameters, elements, machines, warnings)

    def _check_ownership(self, machines: Mapping[str, MachineSpec]) -> None:
        owner: dict[str, str] = {}
        for name, machine in machines.items():
            for element in machine.owned:
                if element in owner:
                    self.error(
                        "state-conflict",
                        f"element {element!r} is changed by two state machines, {owner[element]!r} and {name!r}",
                        self.entries[name].origin.locate(("name",)),
                        "let one machine own each element (it may switch it in several states)",
                    )
                owner.setdefault(element, name)

    def _warn_unused(self) -> None:
        top = self.merged.sources[0]
        for name, parameter in self.merged.parameters.items():
            if parameter.file == top and name not in self.used:
                self.warn("unused-parameter", f"parameter {name!r} is never used", parameter.where, "remove it, or use it in an element")
        for name, entry in self.entries.items():
            if entry.raw["type"] == "sensor" and name not in self.used and entry.origin.layers[0].doc.file == top:
                self.warn("unused-sensor", f"sensor {name!r} is never used", entry.origin.locate(("name",)), "use it in an expression by its name, or remove it")


def canonical(model: Any, replacements: Mapping[tuple[Any, ...], Any]) -> Any:
    """The model with canonical points, roles and legs put in place of what was written."""
    data = model.model_dump(by_alias=True, exclude_none=True)
    for path, value in replacements.items():
        node = data
        for part in path[:-1]:
            node = node[part]
        node[path[-1]] = value
    return type(model).model_validate(data)


def analyze_controller(
    name_or_path: str | Path,
    parameters: Mapping[str, Any] | None = None,
    where: Callable[[str], Location] | None = None,
) -> tuple[ControllerSpec | None, list[Issue]]:
    """Load and check a controller, returning the spec (None on errors) and every issue.

    Args:
        name_or_path: a built-in controller name or a file path.
        parameters: parameter values replacing the file's (from a scene or the command line).
        where: parameter name -> location of its replacement value, for messages.
    """
    issues: list[Issue] = []
    try:
        path = configs.find_config(CONTROLLER_KIND, name_or_path)
    except QuadpipeError as exc:
        return None, list(exc.issues)
    merged = merge_controller(path, issues)
    if merged is None:
        return None, sort_issues(issues)
    analysis = _Analysis(merged, issues, dict(parameters or {}), where or (lambda name: Location("<parameters>")))
    spec = analysis.run()
    return spec, sort_issues(issues)


def sort_issues(issues: list[Issue]) -> list[Issue]:
    """Issues in file order (file, line, column), then by code; exact duplicates dropped."""
    unique = list(dict.fromkeys(issues))

    def key(issue: Issue) -> tuple:
        where = issue.where or Location()
        return (where.file or "", where.line or 0, where.column or 0, issue.code, issue.message)

    return sorted(unique, key=key)


def load_controller(name_or_path: str | Path, parameters: Mapping[str, Any] | None = None) -> ControllerSpec:
    """Load a controller by built-in name or path, with optional parameter values.

    Raises:
        QuadpipeError: every error found (warnings are kept in `spec.warnings`).
    """
    spec, issues = analyze_controller(name_or_path, parameters)
    if spec is None:
        raise QuadpipeError([issue for issue in issues if issue.severity == "error"])
    return spec
