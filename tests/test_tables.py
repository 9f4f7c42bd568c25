"""Tables in the controller language: `interp(x, [x0, x1, ...], [y0, y1, ...])`.

A table is linear between its breakpoints and held at its ends, in the units of its values,
for every animal at once; bad tables are refused with located, coded errors; a table's
lists do not count against the expression length limit (their points are bounded instead).
That the kernel computes tables as this reference does is `tests/test_kernel.py`'s probe.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from quadpipe.controllers.language.load import load_controller
from quadpipe.core.errors import QuadpipeError
from quadpipe.core.limits import MAX_EXPRESSION_LENGTH, Limit
from quadpipe.quantities import parsing, units
from quadpipe.quantities.expressions import ExprError, Namespace, check, compile_expr

TWO_ANIMALS = units.Scale.of([0.5, 2.0], [10.0, 500.0])
"""A dog-sized and an elephant-sized animal: HP 0.5 m and 2 m."""


def table_at(text: str, times: list[float], scale: units.Scale = TWO_ANIMALS) -> np.ndarray:
    """A table expression of `t` evaluated at each time: (times, animals[, 3])."""
    compiled = compile_expr(check(text, Namespace()), scale)
    return np.array([compiled({"t": np.full(scale.n, when)}) for when in times])


def test_a_table_is_linear_between_its_breakpoints_and_held_at_its_ends() -> None:
    values = table_at("interp(t, [1 s, 2 s, 4 s], [10 m/s, 30 m/s, 0 m/s])", [0.0, 1.0, 1.5, 2.0, 3.0, 4.0, 9.0])
    assert values[:, 0] == pytest.approx([10, 10, 20, 30, 15, 0, 0])
    assert check("interp(t, [1 s, 2 s], [1 m/s, 2 m/s])", Namespace()).type.dim == units.VELOCITY


def test_a_table_of_vectors_interpolates_each_component_in_each_animals_units() -> None:
    values = table_at("interp(t, [0 s, 2 s], [[0 HP, 0, 0], [2 HP, -4 HP, 1 m]])", [-1.0, 1.0, 3.0])
    assert values[:, 0] == pytest.approx(np.array([[0, 0, 0], [0.5, -1, 0.5], [1, -2, 1]]))
    assert values[:, 1] == pytest.approx(np.array([[0, 0, 0], [2, -4, 0.5], [4, -8, 1]]))


def test_a_repeated_breakpoint_is_a_jump_to_its_last_value() -> None:
    values = table_at("interp(t, [1 s, 1 s, 2 s], [0, 5, 7])", [0.5, 0.999, 1.0, 1.5])
    assert values[:, 0] == pytest.approx([0, 0, 5, 6])


def test_breakpoints_may_be_in_the_animals_units() -> None:
    """`[0 m, 1 HP]`: the second breakpoint is 0.5 m for the dog, 2 m for the elephant."""
    compiled = compile_expr(check("interp(1 m, [0 m, 1 HP], [0, 1])", Namespace()), TWO_ANIMALS)
    assert compiled({}) == pytest.approx([1.0, 0.5])


@pytest.mark.parametrize(
    ("text", "code", "words"),
    [
        ("interp(t, [0 s, 2 s, 1 s], [1, 2, 3])", "table-order", "breakpoint 3 is below breakpoint 2"),
        ("interp(t, [0 s, 1 s], [1, 2, 3])", "table-lengths", "2 breakpoints but 3 values"),
        ("interp(t, [0 s], [1])", "table-size", "at least 2 points, got 1"),
        ("interp(t, [0 s, 1 m], [1, 2])", "table-units", "breakpoints of a table mix a length and a time"),
        ("interp(t, [0 s, 1 s], [1 N, [0, 0, 1]])", "table-units", "values of a table mix"),
        ("interp(t, [0 s, t], [1, 2])", "table-not-constant", "reads the simulation"),
        ("interp(t, [0 m, 1 m], [1, 2])", "dimension-mismatch", "breakpoints are lengths is read at a time"),
        ("interp(t, 1 s, 2)", "wrong-arguments", "as lists"),
        ("interp(t, [0 s, 1 s])", "wrong-arguments", "takes 3 arguments"),
        ("interp(t, [0 s, 1e308 s * 1e308], [1, 2])", "non-finite-number", "overflows"),
    ],
)
def test_bad_tables_are_refused_with_their_code(text: str, code: str, words: str) -> None:
    with pytest.raises(ExprError) as error:
        check(text, Namespace())
    assert error.value.code == code and words in error.value.message


def test_a_bad_table_in_a_controller_is_located_at_its_line(tmp_path: Path) -> None:
    body = {
        "schema": 1,
        "name": "table",
        "parameters": {"lift": "interp(t, [0 s, 2 s, 1 s], [0 N, 10 N, 5 N])"},
        "elements": [{"type": "pull", "name": "up", "at": "pelvis.mid", "direction": {"vector": [0, 0, 1]}, "strength": "lift"}],
    }  # fmt: skip
    path = tmp_path / "table.yaml"
    path.write_text(yaml.safe_dump(body, sort_keys=False), encoding="utf-8")
    with pytest.raises(QuadpipeError) as error:
        load_controller(str(path))
    assert f"{path}:4:9: error table-order:" in str(error.value)


def table_lists(points: int) -> tuple[str, str]:
    """The breakpoints and the values of a table of `points` points over `points` seconds."""
    times = "[" + ", ".join(f"{k}.25 s" for k in range(points)) + "]"
    values = "[" + ", ".join(f"[{k}.5 m, {-k}.125 m, 0 m]" for k in range(points)) + "]"
    return times, values


def long_table(points: int) -> str:
    """A table of `points` points, its lists far longer than its call."""
    times, values = table_lists(points)
    return f"interp(t, {times}, {values})"


def test_a_table_longer_than_the_expression_limit_is_read() -> None:
    text = f"2 * {long_table(400)} + [1 m, 0, 0]"
    assert len(text) > MAX_EXPRESSION_LENGTH.value
    times, values = table_lists(400)
    assert parsing.table_lists(text) == [(len(times), 400), (len(values), 400)]
    assert table_at(text, [10.5])[0, 0] == pytest.approx([2 * 10.75 + 1, 2 * -10.375, 0])


def test_the_text_outside_tables_is_still_limited() -> None:
    text = long_table(2) + " + [1 m, 0, 0]" * (int(MAX_EXPRESSION_LENGTH.value) // 14 + 1)
    with pytest.raises(ExprError) as error:
        check(text, Namespace())
    assert error.value.code == "limit-exceeded" and "the expression's length" in error.value.message


def test_a_table_over_its_size_limit_is_refused(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(parsing, "MAX_TABLE_POINTS", Limit("the table's size", 50, "points", "resample it"))
    with pytest.raises(ExprError) as error:
        parsing.parse(long_table(51) + " + [0 m, 0 m, 0.5 m]")  # a text parsed by no other test (`parse` keeps trees)
    assert (
        error.value.code == "limit-exceeded"
        and "table's size is over the limit of 50 points (51" in error.value.message
    )
