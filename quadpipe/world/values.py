"""A scene's quantities evaluated for the size of its first animal (`3 HP` -> metres)."""

from __future__ import annotations

from typing import Any, Protocol

import numpy as np
from pydantic import BaseModel

from quadpipe.core.errors import Issue, Location, QuadpipeError
from quadpipe.core.limits import SCENE_EXTENT_HP
from quadpipe.core.yamlio import YamlDocument
from quadpipe.quantities import units
from quadpipe.quantities.expressions import VECTOR, Expect, compile_quantity
from quadpipe.quantities.fields import Bounds
from quadpipe.world.format import is_zero, iter_quantities
from quadpipe.world.loading import file_order, shown


class Located(Protocol):
    """A validated file with its parsed YAML: a scene (`SceneSpec`) or a direction file."""

    @property
    def file(self) -> BaseModel: ...
    @property
    def doc(self) -> YamlDocument: ...
    def locate(self, path: tuple[Any, ...]) -> Location: ...


class Values:
    """A scene's quantities in SI, evaluated for its first animal, looked up by file path.

    Paths are those of `iter_quantities` (`("terrain", 0, "angle")`, list items by index).

    Attributes:
        scene: the scene, to locate errors.
        hp: the first animal's pelvis height, metres.

    Raises (on creation):
        QuadpipeError: a value out of its bounds (a negative size, a 70 degree ramp), not
            finite, or a length beyond the sane extent of a scene (`SCENE_EXTENT_HP`).
    """

    def __init__(self, scene: Located, scale: units.Scale):
        self.scene = scene
        self.hp = float(scale.hp[0])
        self._values: dict[tuple[Any, ...], Any] = {}
        issues = []
        for path, value, expect, bounds in iter_quantities(scene.file):
            resolved = _evaluate(value, expect, scale)
            self._values[path] = resolved
            problem = _not_sane(resolved, expect, self.hp) or _out_of_bounds(resolved, bounds)
            if problem:
                issues.append(
                    Issue(
                        "out-of-range",
                        f"{shown(path, scene.doc)}: {value!r} {problem}",
                        scene.locate(path),
                        SCENE_EXTENT_HP.hint if problem == _FAR else None,
                    )
                )
        if issues:
            raise QuadpipeError(sorted(issues, key=file_order))

    def __getitem__(self, path: tuple[Any, ...]) -> Any:
        return self._values[path]

    def get(self, path: tuple[Any, ...], default: Any = None) -> Any:
        """The value at `path`, or `default` when the file leaves it out."""
        return self._values.get(path, default)

    def items(self, path: tuple[Any, ...], count: int) -> np.ndarray:
        """The `count` scalar items of a list quantity, as an array."""
        return np.array([self._values[path + (i,)] for i in range(count)])


def _evaluate(value: Any, expect: Expect, scale: units.Scale) -> Any:
    if is_zero(value):
        return np.zeros(3) if expect.kind == VECTOR else 0.0
    constant = compile_quantity(value, scale, expect).constant
    assert constant is not None, "loading refuses scene values that read the simulation (`not-constant`)"
    result = constant[0]
    return np.array(result, dtype=float) if expect.kind == VECTOR else float(result)


_FAR = f"is over {SCENE_EXTENT_HP.high:g} HP: no scene reaches that far"
"""The problem of a length too large for any scene."""

_HP_ROUNDING = 1e-9
"""A length written in HP comes back from metres a few ulps over (1000 HP on the cat read
1000.0000000000001 HP): the extent check forgives this relative rounding."""


def _not_sane(value: Any, expect: Expect, hp: float) -> str | None:
    """What makes a value no physics at all: not finite, or a length beyond `SCENE_EXTENT_HP`."""
    values = np.atleast_1d(np.asarray(value, dtype=float))
    if not np.isfinite(values).all():
        return "is not a finite number"
    if expect.dims != (units.LENGTH,):
        return None
    extent_hp = float(np.abs(values).max()) / hp * (1.0 - _HP_ROUNDING)
    return _FAR if SCENE_EXTENT_HP.problem(extent_hp) is not None else None


def _out_of_bounds(value: Any, bounds: Bounds | None) -> str | None:
    if bounds is None:
        return None
    if value < 0 or (bounds.positive and value == 0):
        return "must be more than 0" if bounds.positive else "cannot be negative"
    if bounds.high is not None and value > bounds.high:
        return f"must be at most {bounds.high_text}"
    return None
