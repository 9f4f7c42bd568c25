"""Checking what a merged controller means, and building its `ControllerSpec`.

After `loader.merge_controller` has checked the structure, `analyze_controller` checks the
values: names and parameters here (with overrides from a scene or the command line),
expressions (syntax, names, types, dimensions), body points, role globs, legs, frames and
the rules of each element type in `element_checks.py`, state machines in
`machine_checks.py`, and references between parts (parameters, sensors, cycles, states,
elements). Every problem becomes a located `Issue`; warnings (unused parameters and
sensors, unreachable states) do not stop loading. `load.py` turns the result into a spec
or an error.

Fields are found through the markers of `schema.py` (`marked.iter_marked`), so a new field
with a `Quantity(...)` marker is checked without touching the checks.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from quadpipe.controllers.language.element_checks import canonical
from quadpipe.controllers.language.entries import Bound, ParameterEntry
from quadpipe.controllers.language.loader import CONTROLLER_KIND, merge_controller
from quadpipe.controllers.language.machine_checks import MachineChecks
from quadpipe.controllers.language.parameters import ParameterTyping, clash, type_parameters
from quadpipe.controllers.language.spec import ControllerSpec, MachineSpec, ParameterSpec
from quadpipe.core import configs
from quadpipe.core.errors import Issue, Location, QuadpipeError, did_you_mean
from quadpipe.quantities import expressions

IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")
"""Parameters, sensors and cycles are used in expressions, so their names must be identifiers."""


class _Analysis(MachineChecks):
    """Checks one merged controller; `run` returns the spec (None when there are errors)."""

    # -- names and parameters

    def check_names(self) -> None:
        for name, entry in self.entries.items():
            if entry.raw["type"] not in ("sensor", "cycle"):
                continue
            self._check_name(name, f"{entry.raw['type']} {name!r}", entry.origin.locate(("name",)))
        for name, parameter in self.merged.parameters.items():
            self._check_name(name, f"parameter {name!r}", parameter.where)
            if name in self.sensors or name in self.cycles:
                self.error(
                    "name-clash",
                    f"parameter {name!r} has the name of an element used in expressions",
                    parameter.where,
                    "rename one of them",
                )

    def _check_name(self, name: str, what: str, where: Location) -> None:
        if not IDENTIFIER.match(name):
            self.error(
                "bad-name",
                f"{what} is used in expressions, so its name may only hold letters, digits and _",
                where,
                "e.g. hip_pedal",
            )
        elif (meaning := clash(name)) is not None:
            self.error("name-clash", f"{what} has the name of {meaning}", where, "choose another name")
            self.clashing.add(name)

    def type_parameters(self) -> ParameterTyping:
        values = {name: entry.value for name, entry in self.merged.parameters.items()}
        typing_ = type_parameters(values, self.sensors, self.cycles)
        self._check_replaced(typing_)
        for name, exc in typing_.errors.items():
            if not expressions.referenced_names(values[name]) & self.clashing:
                self.error(exc.code, exc.message, self.merged.parameters[name].where, exc.hint)
        for name in self.merged.parameters:
            self.used |= expressions.referenced_names(values[name]) - {name}
        if not self.overrides:
            return typing_
        for name in self.overrides:
            if name not in values:
                self.error(
                    "unknown-parameter",
                    f"the controller has no parameter {name!r}",
                    self.override_where(name),
                    did_you_mean(name, values),
                )
        known = {name: value for name, value in self.overrides.items() if name in values}
        changed = type_parameters({**values, **known}, self.sensors, self.cycles)
        for name in known:
            self._compare_override(name, typing_, changed)
        return changed

    def _check_replaced(self, typing_: ParameterTyping) -> None:
        """Report a parameter a child controller gives another type than its parent, where the child says so.

        The parent's formulas and elements were written for the parent's type, so the
        parameters using the changed one (and their uses) are not checked again: the problem
        is the child's value.
        """
        parameters = self.merged.parameters
        replaced = {name for name, entry in parameters.items() if entry.replaces is not None}
        if not replaced:
            return
        first = type_parameters(
            {name: entry.first.value for name, entry in parameters.items()}, self.sensors, self.cycles
        )
        changed = set()
        for name in sorted(replaced & set(first.exprs) & set(typing_.exprs)):
            old, new = first.exprs[name].type, typing_.exprs[name].type
            if old != new:
                self._report_replaced(name, old, new, first)
                changed.add(name)
        if changed:
            self.clashing |= {name for name in parameters if typing_.closure({name}) & changed}

    def _report_replaced(self, name: str, old: expressions.Type, new: expressions.Type, first: ParameterTyping) -> None:
        entry = self.merged.parameters[name]
        written = entry.first
        what = "tunable" if entry.tunable else "parameter"
        users = sorted(
            (self.merged.parameters[user].where for user, deps in first.deps.items() if name in deps),
            key=lambda where: (where.line or 0, where.column or 0),
        )
        used = f"; its formulas use it so, e.g. at {_short(users[0])}" if users else ""
        self.error(
            "wrong-dimension" if old.kind == new.kind else "wrong-type",
            f"{what} {name!r} is {new.describe()} here, but {Path(written.file).name} makes it {old.describe()}",
            entry.where,
            f"give {old.describe()}, as {_short(written.where)} does{used}",
        )

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

    # -- whole controller

    def run(self) -> ControllerSpec | None:
        self.check_names()
        typing_ = self.type_parameters()
        self.check_tunables(typing_)
        failed = set(typing_.errors) | typing_.skipped | self.clashing
        namespace = expressions.Namespace(
            typing_.exprs,
            self.sensors,
            self.cycles,
            parameter_texts={n: str(e.value) for n, e in self.merged.parameters.items()},
        )
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
            name: self._parameter_spec(name, entry, typing_) for name, entry in self.merged.parameters.items()
        }
        warnings = tuple(issue for issue in self.issues if issue.severity != "error")
        return ControllerSpec(
            self.merged.name,
            self.merged.description,
            tuple(self.merged.sources),
            parameters,
            elements,
            machines,
            warnings,
        )

    def _parameter_spec(self, name: str, entry: ParameterEntry, typing_: ParameterTyping) -> ParameterSpec:
        """The spec of a parameter or a tunable, with its override's value and place if it has one."""
        value, where = (
            (self.overrides[name], self.override_where(name)) if name in self.overrides else (entry.value, entry.where)
        )
        limits = (entry.low.value, entry.high.value) if entry.tunable and entry.low and entry.high else None
        return ParameterSpec(name, value, entry.description, typing_.exprs[name].type, where, limits)

    # -- tunables

    def check_tunables(self, typing_: ParameterTyping) -> None:
        """Every tunable is a constant number within its range (the file's value, or its override's)."""
        namespace = expressions.Namespace(typing_.exprs, self.sensors, self.cycles)
        for name, entry in self.merged.parameters.items():
            if entry.tunable and name in typing_.exprs and name not in self.clashing:
                self._check_tunable(name, entry, typing_.exprs[name], namespace)

    def _check_tunable(
        self, name: str, entry: ParameterEntry, expr: expressions.Expr, namespace: expressions.Namespace
    ) -> None:
        value, where = (
            (self.overrides[name], self.override_where(name)) if name in self.overrides else (entry.value, entry.where)
        )
        if expr.type.kind != expressions.SCALAR or not expr.is_constant:
            got = (
                expr.type.describe()
                if expr.type.kind != expressions.SCALAR
                else "a value that changes during the simulation"
            )
            self.error(
                "tunable-not-constant",
                f"tunable {name!r} must be a constant number, got {got}",
                where,
                "a tunable is a knob; formulas go in `parameters:`",
            )
            return
        low, high = (
            self._bound(name, end, bound, expr.type, namespace)
            for end, bound in (("min", entry.low), ("max", entry.high))
        )
        if low is None or high is None or entry.low is None or entry.high is None:
            return  # a missing end (`_bound` gives None for it) or a bad one, reported
        if low > high:
            self.error(
                "bad-range",
                f"the range of tunable {name!r} is empty: min {entry.low.value} is above max {entry.high.value}",
                entry.low.where,
            )
        elif not low <= float(expressions.evaluate_constant(expr)) <= high:
            self.error(
                "out-of-range",
                f"tunable {name!r} is {value}, outside its range {entry.low.value} to {entry.high.value}",
                where,
                "give a value in the range (bw, HP and g count as for an animal of bw 1 N and HP 1 m), or widen the range in the controller",
            )

    def _bound(
        self, name: str, end: str, bound: Bound | None, typ: expressions.Type, namespace: expressions.Namespace
    ) -> float | None:
        """The value of one end of a tunable's range, None if it has a problem (reported)."""
        if bound is None:
            return None
        try:
            expr = expressions.check(bound.value, namespace)
        except expressions.ExprError as exc:
            self.error(exc.code, exc.message, bound.where, exc.hint)
            return None
        if expr.type != typ and not _plain_zero(expr):
            self.error(
                "wrong-dimension",
                f"the {end} of tunable {name!r} must be {typ.describe()}, like its value, not {expr.type.describe()}",
                bound.where,
            )
            return None
        if not expr.is_constant:
            self.error(
                "tunable-not-constant",
                f"the {end} of tunable {name!r} must be a constant, not a value that changes during the simulation",
                bound.where,
            )
            return None
        return float(expressions.evaluate_constant(expr))

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
                what = "tunable" if parameter.tunable else "parameter"
                self.warn(
                    "unused-parameter",
                    f"{what} {name!r} is never used",
                    parameter.where,
                    "remove it, or use it in an element",
                )
        for name, entry in self.entries.items():
            if entry.raw["type"] == "sensor" and name not in self.used and entry.origin.layers[0].doc.file == top:
                self.warn(
                    "unused-sensor",
                    f"sensor {name!r} is never used",
                    entry.origin.locate(("name",)),
                    "use it in an expression by its name, or remove it",
                )


def _short(where: Location) -> str:
    """A location in a hint: the file's name (a built-in controller's full path says nothing more)."""
    return str(Location(Path(where.file).name if where.file else None, where.line, where.column))


def _plain_zero(expr: expressions.Expr) -> bool:
    """Whether an expression is a bare 0, which a range may give for zero of any unit."""
    return expr.op == "num" and expr.type == expressions.NUMBER and expr.value == 0.0


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
