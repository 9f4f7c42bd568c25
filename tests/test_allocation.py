"""Register allocation (`quadpipe.controllers.runtime.allocation`): temporaries share registers.

That an allocated program applies the very forces of the lowered one, bit for bit, is
`tests/test_folding.py`'s comparison (every shipped controller runs folded and allocated); here:
that allocation shrinks the walk's register file, and which registers it must leave alone.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from quadpipe.controllers.runtime.allocation import allocate
from quadpipe.controllers.runtime.folding import fold
from quadpipe.controllers.runtime.lowering import Program, lower
from quadpipe.controllers.runtime.ops import ADD, JUMP_IF_NONE, MUL, NEG, SMOOTH, VECTOR_A, VECTOR_B, VECTOR_RESULT
from tests.test_folding import compiled, dog_world

MAX_WALK_SHARE = 0.4
"""The walk's allocated register file is at most this share of its folded one (it is 28 %)."""

VECTOR_AB = VECTOR_RESULT | VECTOR_A | VECTOR_B


def walk() -> Program:
    return fold(lower(compiled("walk"), dog_world().model.opt.gravity))


def test_the_walks_temporaries_share_registers() -> None:
    folded = walk()
    allocated = allocate(folded)
    assert allocated.registers <= MAX_WALK_SHARE * folded.registers
    assert len(allocated.constants) == len(folded.constants)
    assert [vector for _, vector in allocated.sensors.values()] == [vector for _, vector in folded.sensors.values()]
    for new, old in zip(allocated.constants.values(), folded.constants.values()):
        np.testing.assert_array_equal(new, old)


def allocated(*rows: list[int], constants: tuple[int, ...] = (), sensors: tuple[int, ...] = ()) -> np.ndarray:
    """`rows` (op, dst, a, b, c, d, e) allocated, as a program of the walk's other tables."""
    one = np.ones((1, 3))
    program = replace(
        walk(),
        code=np.array(rows, dtype=np.int64),
        registers=1 + max(max(row[1:5]) for row in rows),
        constants=dict.fromkeys(constants, one),
        sensors={f"s{r}": (r, True) for r in sensors},
        sensor_end=0,
    )
    return allocate(program).code


def test_a_temporary_takes_the_register_of_one_no_longer_used() -> None:
    code = allocated(
        [ADD, 10, 1, 2, 0, 0, VECTOR_AB], [NEG, 11, 10, 0, 0, 0, VECTOR_AB], [NEG, 12, 11, 0, 0, 0, VECTOR_AB],
        constants=(1, 2),
    )  # fmt: skip
    assert code[2, 1] == code[0, 1], "the third result takes the first's register, read last by the second"
    assert code[1, 1] != code[1, 2], "never the register of an operand of its own instruction"


def test_scalar_and_vector_results_never_share() -> None:
    code = allocated([MUL, 10, 1, 2, 0, 0, 0], [NEG, 11, 10, 0, 0, 0, VECTOR_AB], constants=(1, 2))
    assert code[1, 1] != code[0, 1], "a scalar result leaves the other two components as they were"


def test_state_and_values_read_after_a_skipped_block_keep_their_registers() -> None:
    code = allocated(
        [JUMP_IF_NONE, 0, 1, 3, 0, 0, 0],
        [ADD, 10, 1, 2, 0, 0, VECTOR_AB],  # written in the block, read after it
        [ADD, 11, 1, 2, 0, 0, VECTOR_AB],
        [SMOOTH, 5, 10, 2, 0, 0, 0],  # a sensor: read before it is written in a run
        [ADD, 12, 11, 5, 0, 0, VECTOR_AB],
        constants=(1, 2), sensors=(5,),
    )  # fmt: skip
    owners = {int(code[1, 1]), int(code[3, 1])}
    assert len(owners) == 2 and int(code[2, 1]) not in owners and int(code[4, 1]) not in owners
