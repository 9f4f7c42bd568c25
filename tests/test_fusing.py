"""Fusing adjacent instruction pairs (`quadpipe.controllers.runtime.fusing`).

That a fused program applies the very forces of the lowered one, bit for bit, is
`tests/test_folding.py`'s comparison (every shipped controller is folded and fused); here: that
fusing keeps doing its job on the walk, and fuses only what it may.
"""

from __future__ import annotations

from collections import Counter

import numpy as np

from quadpipe.controllers.runtime.folding import fold, read_fields
from quadpipe.controllers.runtime.fusing import FUSED, fuse
from quadpipe.controllers.runtime.lowering import lower
from quadpipe.controllers.runtime.ops import (
    ADD,
    ADD_MUL,
    COMPONENT_A,
    COMPONENT_B,
    COMPONENT_C,
    JUMP_IF_NONE,
    MUL,
    MUL_MUL,
    SUB,
    SUB_MUL,
    VECTOR_A,
    VECTOR_B,
    VECTOR_C,
    VECTOR_RESULT,
)
from tests.test_folding import compiled, dog_world

MIN_WALK_FUSED = 0.10
"""Share of the walk's folded instructions that fusing removes at least (it removed 14 %)."""

VECTOR_AB = VECTOR_RESULT | VECTOR_A | VECTOR_B


def test_fusing_computes_the_walks_spring_terms_in_one_instruction() -> None:
    walk = lower(compiled("walk"), dog_world().model.opt.gravity)
    fused, unfused = fold(walk), fold(walk, fused=False)
    assert len(fused.code) <= (1 - MIN_WALK_FUSED) * len(unfused.code)
    ops = Counter(int(op) for op in fused.code[:, 0])
    assert all(ops[op] for op in FUSED.values()), "every fused op is used by the walk"


def fused_rows(*rows: list[int], sensors: frozenset[int] = frozenset()) -> np.ndarray:
    """`rows` (op, dst, a, b, c, d, e) fused as `fold` does (every row kept)."""
    code = np.array(rows, dtype=np.int64)
    reads = Counter(int(row[f]) for row in code for f in read_fields(int(row[0])))
    fuse(code, set(), reads, set(sensors))
    return code


def test_a_product_read_once_by_the_next_difference_is_fused() -> None:
    code = fused_rows([MUL, 5, 1, 2, 0, 0, VECTOR_AB], [SUB, 6, 3, 5, 0, 0, VECTOR_AB])
    np.testing.assert_array_equal(code[1], [SUB_MUL, 6, 3, 1, 2, 0, VECTOR_AB | VECTOR_C])


def test_a_scalar_product_read_by_a_vector_difference_is_fused_as_a_scalar() -> None:
    code = fused_rows([MUL, 5, 1, 2, 0, 0, 0], [SUB, 6, 3, 5, 0, 0, VECTOR_RESULT | VECTOR_A])
    np.testing.assert_array_equal(code[1], [SUB_MUL, 6, 3, 1, 2, 0, VECTOR_RESULT | VECTOR_A])


def test_a_product_read_as_operand_a_of_a_sum_or_product_is_fused_with_the_operands_swapped() -> None:
    product = [MUL, 5, 1, 2, 0, 0, VECTOR_AB]
    sum_ = fused_rows(product, [ADD, 6, 5, 3, 0, 0, VECTOR_RESULT | VECTOR_A])
    np.testing.assert_array_equal(sum_[1], [ADD_MUL, 6, 3, 1, 2, 0, VECTOR_RESULT | VECTOR_B | VECTOR_C])
    scaled = fused_rows(product, [MUL, 6, 5, 3, 0, 0, VECTOR_AB])
    np.testing.assert_array_equal(scaled[1], [MUL_MUL, 6, 3, 1, 2, 0, VECTOR_AB | VECTOR_C])


def test_the_components_read_by_a_fused_pair_stay_with_their_operands() -> None:
    y_of_1, z_of_2, y_of_3 = 1 << COMPONENT_A, 2 << COMPONENT_B, 1 << COMPONENT_A
    code = fused_rows([MUL, 5, 1, 2, 0, 0, y_of_1 | z_of_2], [SUB, 6, 3, 5, 0, 0, y_of_3])
    np.testing.assert_array_equal(code[1], [SUB_MUL, 6, 3, 1, 2, 0, y_of_3 | 1 << COMPONENT_B | 2 << COMPONENT_C])
    swapped = fused_rows([MUL, 5, 1, 2, 0, 0, 0], [ADD, 6, 5, 3, 0, 0, 2 << COMPONENT_B])
    np.testing.assert_array_equal(swapped[1], [ADD_MUL, 6, 3, 1, 2, 0, 2 << COMPONENT_A])


def test_only_a_value_read_once_right_after_it_is_made_is_fused() -> None:
    product, difference = [MUL, 5, 1, 2, 0, 0, 0], [SUB, 6, 3, 5, 0, 0, 0]
    cases = {
        "read again later": ([product, difference, [ADD, 7, 5, 6, 0, 0, 0]], {}),
        "read as operand a": ([product, [SUB, 6, 5, 3, 0, 0, 0]], {}),
        "not next": ([product, [ADD, 7, 1, 1, 0, 0, 0], difference], {}),
        "a sensor": ([product, difference], {"sensors": frozenset({5})}),
        "a jump target": ([[JUMP_IF_NONE, 0, 4, 2, 0, 0, 0], product, difference], {}),
        "not a fused pair": ([[ADD, 5, 1, 2, 0, 0, 0], difference], {}),
        "a component of it": ([[MUL, 5, 1, 2, 0, 0, VECTOR_AB], [SUB, 6, 3, 5, 0, 0, 1 << COMPONENT_B]], {}),
    }
    for case, (rows, options) in cases.items():
        code = fused_rows(*rows, **options)
        np.testing.assert_array_equal(code, np.array(rows), err_msg=case)
