"""The nodes of a checked expression: types, expectations, errors and env keys.

`Type` is what checking gives every node (scalar, vector or condition, with a `Dim`),
`Expect` what a field accepts, `Expr` a checked node, `ExprError` a located-later problem
with a stable code. The env keys an expression reads are named here too (see
`evaluation.py` for what they hold).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import Any, TypeVar

from quadpipe.core.limits import Limit
from quadpipe.quantities import units

SCALAR, VECTOR, BOOL = "scalar", "vector", "bool"

POINT_ANCHORS: tuple[str, ...] = ("start", "end", "mid")
"""Where on a bone a point lies: its proximal joint, its far end, halfway."""

LEG_LANDMARKS: dict[str, dict[bool, str]] = {
    "top": {True: "scapula.start", False: "hip.start"},
    "foot": {True: "fpha1.end", False: "hpha2.end"},
}
"""Leg points usable on every leg: `<leg>.top` (where the leg meets the trunk) and
`<leg>.foot` (the tip of the toes); keyed by landmark, then by "is a front leg"."""

LEG_REST_LENGTH = "rest_length"
"""A leg's length usable on every leg: `<leg>.rest_length`, the distance from `<leg>.top` to
`<leg>.foot` in the rest pose (a length, known before the simulation, one per animal)."""

COMPONENTS: dict[str, int] = {"x": 0, "y": 1, "z": 2}
"""Vector components: `v.x` (forward in the body frame), `v.y` (left), `v.z` (up)."""

CONSTANTS: dict[str, float] = {"pi": math.pi}
"""Named pure numbers."""

TIME_VARIABLE = "t"
"""The variable holding the time since the controller started."""

TABLE_FUNCTION = "interp"
"""The function reading a table: `interp(x, [x0, x1, ...], [y0, y1, ...])` (its lists are
tables, of any length; see `checking.py` and `parsing.table_lists`)."""

ZERO_NORM = 1e-12
"""Vectors shorter than this have no direction: `normalize` returns zero for them."""


class ExprError(Exception):
    """A problem in one expression, with a stable code and an optional hint."""

    def __init__(self, code: str, message: str, hint: str | None = None) -> None:
        super().__init__(message)
        self.code = code
        self.message = message
        self.hint = hint


def limit_error(limit: Limit, amount: float | None = None) -> ExprError:
    """The `limit-exceeded` error of an expression over `limit` (located by the caller)."""
    return ExprError("limit-exceeded", limit.message(amount), limit.hint)


NodeT = TypeVar("NodeT")


def nesting_depth(root: NodeT, children: Callable[[NodeT], Sequence[NodeT]]) -> int:
    """Levels of a tree (1 for a leaf), without recursion, asking each node for its children
    once (a table's thousands of points are many nodes); shared subtrees are measured once."""
    depth: dict[int, int] = {}
    stack: list[tuple[NodeT, Sequence[NodeT] | None]] = [(root, None)]
    while stack:
        node, kids = stack.pop()
        if kids is not None:
            depth[id(node)] = 1 + max((depth[id(kid)] for kid in kids), default=0)
        elif id(node) not in depth:
            kids = children(node)
            stack.append((node, kids))
            stack.extend((kid, None) for kid in kids if id(kid) not in depth)
    return depth[id(root)]


@dataclass(frozen=True)
class Type:
    """The type of a value: `scalar`, `vector` (3 components) or `bool`, with a dimension."""

    kind: str
    dim: units.Dim = units.NONE

    def describe(self) -> str:
        """Name it for a message: `a time`, `a vector of lengths`, `a condition`."""
        if self.kind == BOOL:
            return "a condition (true/false)"
        if self.kind == VECTOR:
            return (
                "a direction vector (no unit)"
                if self.dim.is_none
                else f"a vector of {units.dimension_name(self.dim, plural=True)}"
            )
        return units.dimension_name(self.dim)


NUMBER = Type(SCALAR)
CONDITION = Type(BOOL)
POINT_TYPE = Type(VECTOR, units.LENGTH)


@dataclass(frozen=True)
class Expect:
    """What a field accepts: a kind and one of some dimensions (None: any dimension).

    Attributes:
        kind: `scalar`, `vector` or `bool`.
        dims: accepted dimensions, or None for any.
        label: short name for documentation (`time`, `force`).
        example: a valid value, shown in documentation and hints.
    """

    kind: str
    dims: tuple[units.Dim, ...] | None
    label: str
    example: str

    def describe(self) -> str:
        """Name the expectation for a message."""
        if self.dims is None:
            return {VECTOR: "a vector", SCALAR: "a number", BOOL: "a condition (true/false)"}[self.kind]
        names = [Type(self.kind, dim).describe() for dim in self.dims]
        return " or ".join(names)

    def accepts(self, typ: Type) -> bool:
        """Whether a value of type `typ` fits."""
        return typ.kind == self.kind and (self.dims is None or typ.dim in self.dims)


@dataclass(frozen=True, eq=False)
class Expr:
    """A checked expression node.

    Attributes:
        op: what the node does (`num`, `unit`, `var`, `add`, `call`, ...).
        type: its type.
        args: child nodes.
        value: the op's datum: a number in SI (`num`), a unit symbol (`unit`), an env key
            (`var`), a function name (`call`), comparison operators (`cmp`), an index (`comp`).
        text: the source text, for the top node of a field or parameter.
    """

    op: str
    type: Type
    args: tuple[Expr, ...] = ()
    value: Any = None
    text: str = ""

    @cached_property
    def needs(self) -> frozenset[str]:
        """Env keys this expression reads (compile-time keys like `rest:` excluded)."""
        own = {self.value} if self.op == "var" and not str(self.value).startswith(REST_PREFIX) else set()
        if self.op == "call" and self.value in CALL_NEEDS:
            own.add(CALL_NEEDS[self.value])
        return frozenset(own).union(*(arg.needs for arg in self.args))

    @cached_property
    def uses_scale(self) -> bool:
        """Whether the value depends on the animal (units like HP, or rest lengths)."""
        here = (self.op == "unit" and units.UNITS[self.value].scale_key is not None) or (
            self.op == "var" and str(self.value).startswith(REST_PREFIX)
        )
        return here or any(arg.uses_scale for arg in self.args)

    @property
    def is_constant(self) -> bool:
        """Whether it is known before the simulation starts (for one animal)."""
        return not self.needs


HEADING_FRAME_KEY = "frame:heading"
"""Env key of the heading frame's rotation matrices."""

CALL_NEEDS: dict[str, str] = {"heading": HEADING_FRAME_KEY}
"""Functions that read the env, and the key they read."""

REST_PREFIX = "rest:"
"""Env keys resolved at compile time from `Scale.rest_points`: `rest:<point a>|<point b>`."""


def point_key(point: str) -> str:
    """The env key of a canonical body point: `point:lf_hip.start`."""
    return f"point:{point}"


def rest_distance_key(a: str, b: str) -> str:
    """The compile-time key of the rest-pose distance between two canonical points."""
    return f"{REST_PREFIX}{a}|{b}"
