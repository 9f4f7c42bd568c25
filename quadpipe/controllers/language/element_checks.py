"""Checking elements: their marked fields (quantities, points, roles, legs, frames) and the rules of each type.

`ElementChecks` holds what checking a controller needs (the merged controller, the issues
found, the names used) and checks one element at a time; `MachineChecks` and the analysis
of `semantics.py` build on it.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from quadpipe.anatomy.roles import JOINT_AXES, LEGS, PARENT, ROLES, match_roles
from quadpipe.controllers.language import schema
from quadpipe.controllers.language.entries import ElementEntry, MergedController, Origin
from quadpipe.controllers.language.marked import iter_marked
from quadpipe.controllers.language.parameters import cycle_names, element_namespace, sensor_types
from quadpipe.controllers.language.templates import resolve_legs
from quadpipe.core.errors import Issue, Location, did_you_mean
from quadpipe.quantities import expressions

PARALLEL_SINE = 1e-6
"""Below this sine of the angle between them, a cycle's axis and reference are parallel."""

SENSOR_KEYS: dict[str, tuple[set[str], set[str]]] = {
    "balance": ({"at"}, {"feet"}),
    "contact_normal": (set(), {"at", "horizon"}),
    "velocity": ({"at"}, {"feet", "horizon"}),
    "height": ({"at"}, {"feet", "horizon"}),
}
"""Sensor kind -> (keys it needs, keys it does not take)."""


@dataclass
class _Checked:
    """What checking one element produced: canonical values and names it uses."""

    replacements: dict[tuple[Any, ...], Any] = field(default_factory=dict)
    names: set[str] = field(default_factory=set)


class ElementChecks:
    """The state of checking one merged controller, and the checks of its elements."""

    def __init__(
        self,
        merged: MergedController,
        issues: list[Issue],
        overrides: Mapping[str, Any],
        override_where: Callable[[str], Location],
    ) -> None:
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

    # -- elements

    def check_element(
        self, entry: ElementEntry, model: Any, origin: Origin, namespace: expressions.Namespace, failed: set[str]
    ) -> _Checked:
        checked = _Checked()
        local = element_namespace(model, namespace)
        for path, value, marker in iter_marked(model):
            self._check_marked(path, value, marker, origin, local, failed, checked)
        rule = getattr(self, f"_rules_{model.type}", None)
        if rule is not None:
            rule(model, origin, local, entry.label)
        return checked

    def _check_marked(
        self,
        path: tuple,
        value: Any,
        marker: Any,
        origin: Origin,
        namespace: expressions.Namespace,
        failed: set[str],
        checked: _Checked,
    ) -> None:
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
                self.error(
                    "unknown-leg",
                    f"{bad!r} is neither a leg nor a group",
                    origin.locate(path),
                    did_you_mean(bad, [*LEGS, *self.merged.groups]),
                )
            checked.replacements[path] = legs
        elif isinstance(marker, schema.FrameName) and value not in schema.FRAMES and value not in PARENT:
            self.error(
                "unknown-frame",
                f"there is no frame {value!r}",
                origin.locate(path),
                did_you_mean(value, [*schema.FRAMES, *ROLES], listing=False) or "use heading, world or a role",
            )

    def _quantity(
        self,
        value: Any,
        expect: expressions.Expect,
        where: Location,
        namespace: expressions.Namespace,
        failed: set[str],
    ) -> None:
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

    def _point_map(
        self,
        path: tuple,
        mapping: dict,
        expect: expressions.Expect,
        origin: Origin,
        namespace: expressions.Namespace,
        failed: set[str],
        checked: _Checked,
    ) -> dict:
        canonical = {}
        for key, value in mapping.items():
            point = self._point(key, origin.locate(path + (key,), key=True))
            checked.names |= expressions.referenced_names(value)
            self._quantity(value, expect, origin.locate(path + (key,)), namespace, failed)
            if point in canonical:
                self.error(
                    "duplicate-point",
                    f"{key!r} is the same point as another key here ({point})",
                    origin.locate(path + (key,), key=True),
                    "merge their values",
                )
            canonical[point or key] = value
        if not mapping:
            self.error("invalid-value", f"`{path[-1]}` needs at least one body point", origin.locate(path))
        return canonical

    def _joints(self, path: tuple, patterns: list[str], origin: Origin) -> list[str]:
        roles: list[str] = []
        for index, written in enumerate(patterns):
            where = origin.locate(path + (index,))
            pattern, _, axis = written.partition(".")
            if axis and axis not in JOINT_AXES:
                self.error(
                    "unknown-axis",
                    f"{written!r} names no axis of a joint: {axis!r}",
                    where,
                    f"write the role alone (every axis) or one of: {', '.join(f'{pattern}.{a}' for a in JOINT_AXES)}",
                )
                continue
            if pattern == "pelvis":
                self.error(
                    "no-joint",
                    "the pelvis is the root of the skeleton: it has no joint to put a spring on",
                    where,
                    "springs on the spine start at spine0",
                )
                continue
            matched = [role for role in match_roles(pattern) if PARENT[role] is not None]
            if not matched and not any(ch in pattern for ch in "*?["):
                self.error(
                    "unknown-role",
                    f"{pattern!r} is not a role",
                    where,
                    did_you_mean(pattern, ROLES, listing=False) or "see the roles in docs/controllers.md",
                )
            elif not matched:
                self.error(
                    "glob-matches-nothing",
                    f"{pattern!r} matches no joint",
                    where,
                    "globs match roles: spine*, *_hip, lf_*, *_* (all leg joints)",
                )
            selected = [f"{role}.{axis}" if axis else role for role in matched]
            roles.extend(joint for joint in selected if joint not in roles)
        return roles

    # -- per-type rules

    def _direction(
        self, direction: schema.Direction | None, path: tuple, origin: Origin, namespace: expressions.Namespace
    ) -> None:
        if direction is None:
            return
        given = [key for key in ("vector", "toward", "balance") if getattr(direction, key) is not None]
        if len(given) != 1:
            got = " and ".join(given) if given else "none"
            self.error(
                "direction-kind",
                f"a direction needs exactly one of vector, toward or balance; got {got}",
                origin.locate(path),
            )
        if "horizon" in direction.model_fields_set and direction.balance is None:
            self.error(
                "unused-key",
                "`horizon` only applies to a `balance` direction",
                origin.locate(path + ("horizon",), key=True),
            )
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
        if vector is not None and not np.abs(vector).max(initial=0.0) > 0:  # a norm overflows at 1e308
            self.error(
                "zero-vector", f"the vector {value!r} has no direction", where, "give at least one non-zero component"
            )

    def _rules_segment(
        self, model: schema.Segment, origin: Origin, namespace: expressions.Namespace, label: str
    ) -> None:
        self._direction(model.direction, ("direction",), origin, namespace)
        if model.direction is not None and model.strength is None:
            self.error(
                "missing-key",
                f"{label} has a direction but no `strength`",
                origin.locate(("direction",), key=True),
                "add e.g. `strength: {length2: 0.5 bw/HP^2}`",
            )
        if model.strength is not None and model.direction is None:
            self.error(
                "missing-key",
                f"{label} has a strength but no `direction` to push along",
                origin.locate(("strength",), key=True),
                "add e.g. `direction: [0, 0, -1]`",
            )
        if model.direction is None and model.elastic is None:
            self.error(
                "nothing-to-do",
                f"{label} has neither a direction nor an elastic",
                origin.locate(("name",)),
                "give it `direction` + `strength`, or `elastic`",
            )
        if model.strength is not None and (model.strength.force is None) == (model.strength.length2 is None):
            self.error(
                "strength-kind",
                "a strength is either a force or `length2: factor`, not both",
                origin.locate(("strength",)),
            )
        try:
            same = expressions.resolve_point_name(model.from_) == expressions.resolve_point_name(model.to)
        except expressions.ExprError:
            same = False
        if same:
            self.error(
                "same-point",
                f"{label} starts and ends at the same point",
                origin.locate(("to",)),
                "a segment joins two different points",
            )

    def _rules_force_pair(
        self, model: schema.ForcePair, origin: Origin, namespace: expressions.Namespace, label: str
    ) -> None:
        self._direction(model.direction, ("direction",), origin, namespace)
        weights = []
        for key, value in model.reaction.items():
            try:
                expr = expressions.check(value, namespace)
            except expressions.ExprError:
                return
            if not expr.is_constant or expr.uses_scale or expr.type != expressions.NUMBER:
                self.error(
                    "bad-weights", f"reaction weight {value!r} must be a plain number", origin.locate(("reaction", key))
                )
                return
            weights.append(float(expressions.evaluate_constant(expr)))
        if any(weight < 0 for weight in weights) or (weights and sum(weights) <= 0):
            self.error(
                "bad-weights",
                "reaction weights must be positive (they are shares of the opposite force)",
                origin.locate(("reaction",)),
            )

    def _rules_pull(self, model: schema.Pull, origin: Origin, namespace: expressions.Namespace, label: str) -> None:
        self._direction(model.direction, ("direction",), origin, namespace)

    def _rules_cycle(self, model: schema.Cycle, origin: Origin, namespace: expressions.Namespace, label: str) -> None:
        self._nonzero(model.axis, origin.locate(("axis",)), namespace)
        axis, reference = (
            self._constant_vector(model.axis, namespace),
            self._constant_vector(model.reference, namespace),
        )
        if axis is None or reference is None or not np.abs(axis).max() > 0 or not np.abs(reference).max() > 0:
            return
        axis, reference = axis / np.abs(axis).max(), reference / np.abs(reference).max()  # no overflow at 1e308
        sine = np.linalg.norm(np.cross(axis, reference)) / (np.linalg.norm(axis) * np.linalg.norm(reference))
        if sine < PARALLEL_SINE:
            self.error(
                "parallel-axis",
                f"{label}: `reference` is parallel to `axis`, so the force cannot turn about it",
                origin.locate(("reference",)),
                "give a reference across the axis, e.g. [1, 0, 0] for axis [0, 1, 0]",
            )

    def _rules_sensor(self, model: schema.Sensor, origin: Origin, namespace: expressions.Namespace, label: str) -> None:
        needed, refused = SENSOR_KEYS[model.kind]
        for key in sorted(needed):
            if getattr(model, key) is None:
                self.error("missing-key", f"a {model.kind} sensor needs `{key}`", origin.locate(("kind",)))
        for key in sorted(refused):
            if getattr(model, key) is not None:
                self.error(
                    "unused-key", f"a {model.kind} sensor does not take `{key}`", origin.locate((key,), key=True)
                )


def canonical(model: Any, replacements: Mapping[tuple[Any, ...], Any]) -> Any:
    """The model with canonical points, roles and legs put in place of what was written."""
    data = model.model_dump(by_alias=True, exclude_none=True)
    for path, value in replacements.items():
        node = data
        for part in path[:-1]:
            node = node[part]
        node[path[-1]] = value
    return type(model).model_validate(data)
