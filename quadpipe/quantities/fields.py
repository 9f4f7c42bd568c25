"""Pydantic fields holding quantities, shared by every file format (controllers, scenes).

A quantity field holds a number with units, an expression text, or a vector of them
(`3 HP`, `froude_speed(2.5)`, `[1 m/s, 0, 0]`). Its type checks only the value's shape; the
units and dimensions are checked afterwards against the `Expect` of the `Quantity` marker
(and the `Items` and `Bounds` markers) that the field's `Annotated` type carries, which the
format's checker finds by walking its models.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Annotated, Any, Union

from pydantic import Field, PlainValidator

from quadpipe.quantities import units
from quadpipe.quantities.expressions import SCALAR, VECTOR, Expect

# Expected kinds and dimensions every format uses (examples are shown in hints and docs;
# `with_example` gives another).
TIME = Expect(SCALAR, (units.TIME,), "time", "38/30 s")
ANGLE = Expect(SCALAR, (units.ANGLE,), "angle", "20 deg")
LENGTH = Expect(SCALAR, (units.LENGTH,), "length", "0.9 HP")
POINT = Expect(VECTOR, (units.LENGTH,), "point (vector of lengths)", "[5 HP, 0, 0]")


def with_example(expect: Expect, example: str) -> Expect:
    """The same expectation, shown with another example (a scene's lengths span the world)."""
    return dataclasses.replace(expect, example=example)


# --------------------------------------------------------------------------- markers


@dataclass(frozen=True)
class Quantity:
    """Marks a field holding a value or expression of the `expect`ed kind and dimension."""

    expect: Expect


@dataclass(frozen=True)
class Items:
    """Marks a list field whose items are scalar quantities of the `expect`ed kind."""

    expect: Expect


@dataclass(frozen=True)
class Bounds:
    """Marks a quantity whose value (in SI, once evaluated for the animals) is bounded.

    Attributes:
        positive: True: it must be more than 0; False: it may also be 0.
        high: the highest value allowed, or None.
        high_text: how messages write `high`.
    """

    positive: bool = True
    high: float | None = None
    high_text: str = ""


POSITIVE = Bounds()
NON_NEGATIVE = Bounds(positive=False)


# --------------------------------------------------------------------------- value types


def _plain_value(value: Any) -> Any:
    if isinstance(value, bool) or not isinstance(value, (int, float, str)):
        raise ValueError(f"expected a number or an expression, got {kind_of(value)}")
    return value


def _quantity_value(value: Any) -> Any:
    if isinstance(value, list):
        if len(value) != 3:
            raise ValueError(f"a vector has 3 components [x, y, z], got {len(value)}")
        return [_plain_value(item) for item in value]
    return _plain_value(value)


def kind_of(value: Any) -> str:
    """What a YAML value is, for messages: `a mapping`, `text`, `a number`..."""
    if value is None:
        return "nothing"
    return {bool: "true/false", dict: "a mapping", list: "a list", str: "text"}.get(type(value), "a number")


VECTOR_INPUT = Annotated[list[float | str], Field(min_length=3, max_length=3)]
"""A vector as the JSON Schema shows it: three numbers or expression texts."""

Value = Annotated[Any, PlainValidator(_plain_value, json_schema_input_type=Union[float, str])]
"""A number or an expression text."""

AnyValue = Annotated[Any, PlainValidator(_quantity_value, json_schema_input_type=Union[float, str, VECTOR_INPUT])]
"""A number, an expression text or a vector of them, of any kind (parameter values)."""


def quantity(expect: Expect, bounds: Bounds | None = None) -> Any:
    """The type of a field holding one quantity (a number with units, or a vector of them)."""
    input_type = Union[float, str, VECTOR_INPUT] if expect.kind == VECTOR else Union[float, str]
    base = Annotated[Any, PlainValidator(_quantity_value, json_schema_input_type=input_type), Quantity(expect)]
    return Annotated[base, bounds] if bounds else base


def quantities(expect: Expect, count: int | tuple[int, int], bounds: Bounds | None = None) -> Any:
    """The type of a field holding a list of `count` scalar quantities (or min, max counts)."""
    low, high = (count, count) if isinstance(count, int) else count
    marks = [Items(expect), Field(min_length=low, max_length=high)] + ([bounds] if bounds else [])
    return Annotated[list[Value], *marks]


def described(text: str, expect: Expect | None = None) -> str:
    """A field description, with the expected unit and an example for quantities."""
    if expect is None:
        return text
    return f"{text} Expects {expect.describe()}, e.g. `{expect.example}`."
