"""Checking state machines: states, transitions, and the elements each state changes."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import pydantic

from quadpipe.controllers.language import schema
from quadpipe.controllers.language.element_checks import ElementChecks, canonical
from quadpipe.controllers.language.entries import ElementEntry, Origin
from quadpipe.controllers.language.loader import deep_merge, match_names, pydantic_issues
from quadpipe.controllers.language.parameters import ParameterTyping, type_parameters
from quadpipe.controllers.language.spec import MachineSpec, StateSpec, TransitionSpec
from quadpipe.core.errors import Location, did_you_mean
from quadpipe.quantities import expressions


class MachineChecks(ElementChecks):
    """The checks of state machines, on top of those of elements."""

    def check_machine(
        self, name: str, entry: ElementEntry, typing_: ParameterTyping, failed: set[str]
    ) -> MachineSpec | None:
        model: schema.StateMachine = entry.model
        origin = entry.origin
        states = model.states
        ok = True
        if model.initial not in states:
            self.error(
                "unknown-state",
                f"initial state {model.initial!r} is not one of the states",
                origin.locate(("initial",)),
                did_you_mean(model.initial, states),
            )
            ok = False
        transitions = []
        for index, transition in enumerate(model.transitions):
            sources = tuple(states) if "*" in transition.from_ else tuple(transition.from_)
            for position, source in enumerate(transition.from_):
                if source != "*" and source not in states:
                    where = origin.locate(("transitions", index, "from", position))
                    self.error(
                        "unknown-state",
                        f"transition {index + 1} leaves {source!r}, which is not a state",
                        where,
                        did_you_mean(source, states),
                    )
                    ok = False
            if transition.to not in states:
                self.error(
                    "unknown-state",
                    f"transition {index + 1} goes to {transition.to!r}, which is not a state",
                    origin.locate(("transitions", index, "to")),
                    did_you_mean(transition.to, states),
                )
                ok = False
            self.used |= expressions.referenced_names(transition.when) | expressions.referenced_names(transition.after)
            transitions.append(TransitionSpec(sources, transition.to, transition.when, transition.after))
        reachable = {model.initial} | {transition.to for transition in model.transitions}
        for state in states if model.initial in states else ():
            if state not in reachable:
                self.warn(
                    "unreachable-state",
                    f"no transition enters state {state!r}",
                    origin.locate(("states", state), key=True),
                    f"add a transition `to: {state}`",
                )
        built = {
            state_name: self._state(state_name, state, entry, typing_, failed) for state_name, state in states.items()
        }
        checked = {state_name: state for state_name, state in built.items() if state is not None}
        if not ok or len(checked) < len(built):
            return None
        owned = sorted({element for state in checked.values() for element in state.elements})
        return MachineSpec(name, model.initial, checked, tuple(transitions), tuple(owned))

    def _state(
        self, state_name: str, state: schema.State, entry: ElementEntry, typing_: ParameterTyping, failed: set[str]
    ) -> StateSpec | None:
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
        namespace = expressions.Namespace(
            typing_.exprs if not changed else self._state_exprs(changed), self.sensors, self.cycles
        )
        variants = {}
        for target in sorted(affected, key=list(self.entries).index):
            variant = self._variant(target, switches.get(target), patches.get(target), namespace, failed)
            if variant is not None:
                variants[target] = variant
        return StateSpec(
            state_name, state.description, {name: state.parameters[name] for name in state.parameters}, variants
        )

    def _targets(self, pattern: str, where: Location, state_name: str) -> list[str]:
        matched = match_names(pattern, self.entries)
        if not matched:
            self.error(
                "unknown-element",
                f"state {state_name!r} names {pattern!r}, but no element matches",
                where,
                did_you_mean(pattern, self.entries),
            )
        switchable = [name for name in matched if self.entries[name].raw["type"] in schema.FORCE_ELEMENT_TYPES]
        for name in matched:
            if name not in switchable:
                self.error(
                    "not-switchable",
                    f"{name!r} is a {self.entries[name].raw['type']}; states only switch and change force elements",
                    where,
                    f"force elements: {', '.join(schema.FORCE_ELEMENT_TYPES)}",
                )
        return switchable

    def _state_parameters(
        self, state: schema.State, origin: Origin, base: tuple, typing_: ParameterTyping
    ) -> dict[str, Any] | None:
        known = {name: value for name, value in state.parameters.items() if name in self.merged.parameters}
        for name in state.parameters:
            self.used |= expressions.referenced_names(state.parameters[name])
            if name not in known:
                self.error(
                    "unknown-parameter",
                    f"there is no parameter {name!r} to set",
                    origin.locate(base + ("parameters", name), key=True),
                    did_you_mean(name, self.merged.parameters),
                )
        if not known:
            return {} if len(known) == len(state.parameters) else None
        values = {name: entry.value for name, entry in self.merged.parameters.items()} | {
            name: self.overrides[name] for name in self.overrides if name in self.merged.parameters
        }
        changed = type_parameters({**values, **known}, self.sensors, self.cycles)
        ok = len(known) == len(state.parameters)
        for name in known:
            where = origin.locate(base + ("parameters", name))
            if name in changed.errors:
                exc = changed.errors[name]
                self.error(exc.code, exc.message, where, exc.hint)
                ok = False
            elif (
                name in typing_.exprs and name in changed.exprs and typing_.exprs[name].type != changed.exprs[name].type
            ):
                self.error(
                    "wrong-dimension",
                    f"parameter {name!r} is {typing_.exprs[name].type.describe()}, but this state gives {changed.exprs[name].type.describe()}",
                    where,
                    f"the parameter is {self.merged.parameters[name].value!r}",
                )
                ok = False
        return known if ok else None

    def _state_exprs(self, changed: Mapping[str, Any]) -> dict[str, expressions.Expr]:
        values = (
            {name: entry.value for name, entry in self.merged.parameters.items()} | dict(self.overrides) | dict(changed)
        )
        return type_parameters(
            {k: v for k, v in values.items() if k in self.merged.parameters}, self.sensors, self.cycles
        ).exprs

    def _variant(
        self,
        name: str,
        switch: bool | None,
        patch: tuple[dict, Origin] | None,
        namespace: expressions.Namespace,
        failed: set[str],
    ) -> Any:
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
