"""Physical dimensions and units of controller quantities, and their per-animal values.

A controller is written once for every animal, so its numbers carry units, some of which
depend on the animal: `HP` is its pelvis height, `bw` its body weight, `bm` its body mass.
Dimensions are checked when a controller is validated (a period must be a time); units are
turned into SI numbers only when the controller is compiled for a set of animals (`Scale`).

Dimensions are vectors of rational exponents over four base dimensions: length, mass, time
and angle. Angles count as a dimension of their own so that "expected an angle" can be
checked, and are compiled to radians.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from fractions import Fraction
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from quadpipe.animals.library import Animal

STANDARD_GRAVITY = 9.80665
"""Standard gravity in m/s²: the `g` unit, and body weight = mass x g."""

BASE_SYMBOLS: tuple[str, ...] = ("m", "kg", "s", "rad")
"""SI units of the four base dimensions, in `Dim` order."""


@dataclass(frozen=True)
class Dim:
    """A physical dimension: exponents of length, mass, time and angle."""

    length: Fraction = Fraction(0)
    mass: Fraction = Fraction(0)
    time: Fraction = Fraction(0)
    angle: Fraction = Fraction(0)

    @property
    def exponents(self) -> tuple[Fraction, ...]:
        """The four exponents: length, mass, time, angle."""
        return (self.length, self.mass, self.time, self.angle)

    def __mul__(self, other: Dim) -> Dim:
        return Dim(*(a + b for a, b in zip(self.exponents, other.exponents)))

    def __truediv__(self, other: Dim) -> Dim:
        return Dim(*(a - b for a, b in zip(self.exponents, other.exponents)))

    def __pow__(self, power: Fraction | int) -> Dim:
        return Dim(*(a * Fraction(power) for a in self.exponents))

    @property
    def is_none(self) -> bool:
        """Whether this is a pure number."""
        return not any(self.exponents)

    def si_text(self) -> str:
        """The SI unit of this dimension, as text: `kg*m/s^2`."""
        up: list[str] = []
        down: list[str] = []
        for symbol, exponent in zip(BASE_SYMBOLS, self.exponents):
            if exponent:
                target = up if exponent > 0 else down
                power = abs(exponent)
                target.append(symbol if power == 1 else f"{symbol}^{power}")
        text = "*".join(up) or "1"
        return f"{text}/{'/'.join(down)}" if down else text


NONE = Dim()
LENGTH = Dim(length=Fraction(1))
MASS = Dim(mass=Fraction(1))
TIME = Dim(time=Fraction(1))
ANGLE = Dim(angle=Fraction(1))
FORCE = MASS * LENGTH / TIME**2
VELOCITY = LENGTH / TIME
ACCELERATION = LENGTH / TIME**2
FREQUENCY = NONE / TIME
TORQUE = FORCE * LENGTH
STIFFNESS = FORCE / LENGTH
DAMPING = FORCE * TIME / LENGTH
ANGULAR_STIFFNESS = TORQUE / ANGLE
ANGULAR_DAMPING = TORQUE * TIME / ANGLE
LENGTH2_FACTOR = FORCE / LENGTH**2
ANGULAR_VELOCITY = ANGLE / TIME

DIMENSION_NAMES: dict[Dim, tuple[str, str]] = {
    NONE: ("a number", "numbers"),
    LENGTH: ("a length", "lengths"),
    MASS: ("a mass", "masses"),
    TIME: ("a time", "times"),
    ANGLE: ("an angle", "angles"),
    FORCE: ("a force", "forces"),
    VELOCITY: ("a velocity", "velocities"),
    ACCELERATION: ("an acceleration", "accelerations"),
    FREQUENCY: ("a frequency", "frequencies"),
    TORQUE: ("a torque", "torques"),
    STIFFNESS: ("a stiffness (force per length)", "stiffnesses"),
    DAMPING: ("a damping (force x time per length)", "dampings"),
    ANGULAR_STIFFNESS: ("an angular stiffness (torque per angle)", "angular stiffnesses"),
    ANGULAR_DAMPING: ("an angular damping (torque x time per angle)", "angular dampings"),
    LENGTH2_FACTOR: ("a force per squared length", "forces per squared length"),
    ANGULAR_VELOCITY: ("an angular velocity", "angular velocities"),
    LENGTH**2: ("an area", "areas"),
}
"""How messages name the common dimensions (singular, plural)."""


def dimension_name(dim: Dim, *, plural: bool = False) -> str:
    """Name a dimension for a message: `a time`, or `a quantity in kg*m/s^2` when unnamed."""
    if dim in DIMENSION_NAMES:
        return DIMENSION_NAMES[dim][1 if plural else 0]
    return f"quantities in {dim.si_text()}" if plural else f"a quantity in {dim.si_text()}"


@dataclass(frozen=True)
class Unit:
    """A unit symbol usable after a number (`2 cm`) or alone in an expression (`HP`).

    Attributes:
        symbol: how it is written.
        dim: its dimension.
        si: its value in SI units, or None when it depends on the animal.
        scale_key: for animal-dependent units, the `Scale` attribute holding its value.
        description: one line for the reference documentation.
    """

    symbol: str
    dim: Dim
    si: float | None
    scale_key: str | None
    description: str


UNITS: dict[str, Unit] = {
    unit.symbol: unit
    for unit in (
        Unit("HP", LENGTH, None, "hp", "the animal's pelvis height (the thesis's HP): scales with the animal"),
        Unit("m", LENGTH, 1.0, None, "metre"),
        Unit("cm", LENGTH, 0.01, None, "centimetre"),
        Unit("mm", LENGTH, 0.001, None, "millimetre"),
        Unit("s", TIME, 1.0, None, "second"),
        Unit("ms", TIME, 0.001, None, "millisecond"),
        Unit("Hz", FREQUENCY, 1.0, None, "hertz (cycles per second)"),
        Unit("deg", ANGLE, math.pi / 180.0, None, "degree"),
        Unit("rad", ANGLE, 1.0, None, "radian"),
        Unit("bm", MASS, None, "bm", "the animal's body mass: scales with the animal"),
        Unit("kg", MASS, 1.0, None, "kilogram"),
        Unit("bw", FORCE, None, "bw", "the animal's body weight (body mass x g): scales with the animal"),
        Unit("N", FORCE, 1.0, None, "newton"),
        Unit("g", ACCELERATION, STANDARD_GRAVITY, None, "standard gravity, 9.80665 m/s² (not grams)"),
    )
}
"""Every unit the language knows, in the order the reference lists them."""


@dataclass(frozen=True)
class Scale:
    """Per-animal values of the animal-dependent units, for `n` animals compiled together.

    Attributes:
        hp: pelvis heights in metres, shape (n,).
        bw: body weights in newtons, shape (n,).
        bm: body masses in kilograms, shape (n,).
        rest_points: canonical body point (`lf_hip.start`) -> rest-pose position in metres in
            the body frame, shape (n, 3); needed for `rest` lengths and `length2` strengths.
    """

    hp: np.ndarray
    bw: np.ndarray
    bm: np.ndarray
    rest_points: Mapping[str, np.ndarray] = field(default_factory=dict)

    @property
    def n(self) -> int:
        """Number of animals."""
        return int(self.hp.shape[0])

    @classmethod
    def of(
        cls,
        hp: float | Sequence[float],
        mass_kg: float | Sequence[float],
        rest_points: Mapping[str, np.ndarray] | None = None,
    ) -> Scale:
        """Build a scale from pelvis heights (m) and masses (kg), one per animal."""
        hp_arr = np.atleast_1d(np.asarray(hp, dtype=float))
        mass = np.broadcast_to(np.atleast_1d(np.asarray(mass_kg, dtype=float)), hp_arr.shape).copy()
        return cls(hp_arr, mass * STANDARD_GRAVITY, mass, dict(rest_points or {}))

    def unit_value(self, unit: Unit) -> np.ndarray:
        """The unit's value in SI for every animal, shape (n,)."""
        if unit.scale_key is None:
            return np.full(self.n, unit.si)
        return np.asarray(getattr(self, unit.scale_key), dtype=float)


def scale_for_animals(animals: Sequence[Animal]) -> Scale:
    """The scale of a list of loaded animals, with rest positions of every body point.

    Every bone gives three points: `<role>.start`, `<role>.end` and `<role>.mid`.
    """
    rest: dict[str, list[np.ndarray]] = {}
    for animal in animals:
        for role, bone in animal.skeleton.bones.items():
            for anchor, point in (("start", bone.start), ("end", bone.end), ("mid", (bone.start + bone.end) / 2)):
                rest.setdefault(f"{role}.{anchor}", []).append(np.asarray(point, dtype=float))
    return Scale.of(
        [animal.pelvis_height for animal in animals],
        [animal.mass_kg for animal in animals],
        {key: np.stack(points) for key, points in rest.items()},
    )
