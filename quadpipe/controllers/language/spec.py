"""`ControllerSpec`: a controller loaded, merged and checked, independent of its files.

This is what `load_controller` returns and what `compile_controller` compiles. Elements
are the pydantic models of `schema.py` in a canonical form: templates expanded (one element
per leg), `extends` merged, body points written `role.anchor` (`lf.top` became
`lf_scapula.start`), spring `joints` expanded to role lists, sensor `feet` to leg lists,
and shorthands expanded (a bare vector direction became `{vector: ...}`, a bare strength
`{force: ...}`). Values keep their text; `compile_controller` turns them into numbers.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from quadpipe.controllers.language.schema import Element
from quadpipe.core.errors import Issue, Location
from quadpipe.quantities import expressions


@dataclass(frozen=True)
class ParameterSpec:
    """A parameter or a tunable: its value as written, its checked type and where it was defined.

    Attributes:
        limits: a tunable's range (min, max) as written; None for a parameter.
    """

    name: str
    value: Any
    description: str
    type: expressions.Type
    where: Location
    limits: tuple[Any, Any] | None = None

    @property
    def tunable(self) -> bool:
        """Whether it is a knob of the controller (from `tunables:`)."""
        return self.limits is not None


@dataclass(frozen=True)
class TransitionSpec:
    """A transition: the states it leaves (`*` expanded), the one it enters, when.

    Attributes:
        sources: states it leaves.
        target: state it enters.
        when: its condition as written, or None (fires once `after` has passed).
        after: minimum time in the current state, as written.
    """

    sources: tuple[str, ...]
    target: str
    when: Any
    after: Any


@dataclass(frozen=True)
class StateSpec:
    """One state of a machine.

    Attributes:
        name: the state's name.
        description: its description.
        parameters: parameter values while in this state, as written.
        elements: the elements this state changes, in the form they take while it is
            active (their `enabled` flag and `set` keys applied). Elements not listed keep
            their base form.
    """

    name: str
    description: str
    parameters: Mapping[str, Any]
    elements: Mapping[str, Element]


@dataclass(frozen=True)
class MachineSpec:
    """A state machine: its states, transitions, and the elements it owns.

    `owned` lists every element any of its states changes (directly, or through a parameter
    the element uses); no other machine changes them.
    """

    name: str
    initial: str
    states: Mapping[str, StateSpec]
    transitions: tuple[TransitionSpec, ...]
    owned: tuple[str, ...]


@dataclass(frozen=True)
class ControllerSpec:
    """A validated controller.

    Attributes:
        name: its name.
        description: its description.
        sources: the files it was read from, the requested one first, then its parents.
        parameters: name -> parameter, tunables included, in definition order.
        elements: name -> canonical element model, in order (see module docstring).
        machines: state machine name -> its states and transitions.
        warnings: non-fatal issues found while checking it.
    """

    name: str
    description: str
    sources: tuple[str, ...]
    parameters: Mapping[str, ParameterSpec]
    elements: Mapping[str, Element]
    machines: Mapping[str, MachineSpec]
    warnings: tuple[Issue, ...] = field(default=())

    @property
    def tunables(self) -> dict[str, ParameterSpec]:
        """The knobs of the controller, in definition order."""
        return {name: parameter for name, parameter in self.parameters.items() if parameter.tunable}
