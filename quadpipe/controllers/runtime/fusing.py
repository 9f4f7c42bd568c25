"""Fusing pairs of a folded program's instructions into one: fewer dispatches, the same bits.

The kernel pays most of an arithmetic instruction's cost in choosing what to do (reading the
row, branching on its op), not in the arithmetic. The commonest pairs in the shipped programs
are a product or a difference whose only reader is the very next instruction, as its operand
`b`: the spring-damper terms `k * (x - x0)` and `x - c * v`, the scalings `a * (w * s)` and
`a + w * s`. `fuse(code, removed, kept_registers)` turns each such reader into one op of three
operands (`FUSED`: `a - b * c`, `a * (b - c)`, `a * (b * c)`, `a + b * c`), computed by the
same IEEE operations in the same order, so its result is bit-for-bit the pair's; the first
instruction of the pair is then read by nothing and dropped with the dead code
(`quadpipe.controllers.runtime.folding`).

A reader that adds or multiplies reads its operands either way round (IEEE addition and
multiplication are commutative, bit for bit): one that reads the produced value as its operand
`a` has its operands swapped first (`x * y * z`, `x * y + z`: `z * (x * y)`, `z + x * y`).

A pair is fused only when the two are adjacent (nothing can change the first one's operands in
between) and the second is no jump target; the first's result must be read by the second alone
(not by a later instruction, a sensor or the runtime), and be a vector exactly where the second
reads it as one.
"""

from __future__ import annotations

import numpy as np

from quadpipe.controllers.runtime.ops import (
    ADD,
    ADD_MUL,
    COMPONENT_A,
    COMPONENT_B,
    COMPONENT_C,
    DST,
    JUMP_IF_NONE,
    MUL,
    MUL_MUL,
    MUL_SUB,
    OP,
    SUB,
    SUB_MUL,
    VECTOR_A,
    VECTOR_B,
    VECTOR_C,
    VECTOR_RESULT,
    A,
    B,
    C,
    E,
)

COMMUTATIVE = frozenset((ADD, MUL))
"""Readers whose operands `a` and `b` may be swapped without changing a bit of the result
(the fused op reads the other operand as its `a`)."""

FUSED: dict[tuple[int, int], int] = {(SUB, MUL): SUB_MUL, (MUL, SUB): MUL_SUB, (MUL, MUL): MUL_MUL, (ADD, MUL): ADD_MUL}
"""(the reader's op, the op of its operand `b`) -> the fused op: `reader(a, inner(b, c))`."""


def fuse(code: np.ndarray, removed: set[int], read: dict[int, int], kept_registers: set[int]) -> int:
    """Fuse the pairs of `code` that qualify (see the module docstring), in place; how many.

    Args:
        code: the program's rows; a fused reader is rewritten, its producer left to dead code.
        removed: rows already dropped (neither producer nor reader).
        read: how many times the kept rows read each register (a row reading it twice: 2).
        kept_registers: registers read from outside the program (sensors), never fused away.
    """
    targets = {int(row[B]) for row in code if row[OP] == JUMP_IF_NONE}
    fused = 0
    for index in range(1, len(code)):
        inner, outer = code[index - 1], code[index]
        if index in targets or index in removed or index - 1 in removed:
            continue
        op = FUSED.get((int(outer[OP]), int(inner[OP])))
        produced = int(inner[DST])
        if op is None or read.get(produced) != 1 or produced in kept_registers:
            continue
        swap = int(outer[OP]) in COMMUTATIVE and int(outer[A]) == produced
        flags = _swapped_flags(int(outer[E])) if swap else int(outer[E])
        if (int(outer[A]) if swap else int(outer[B])) != produced or not _same_width(int(inner[E]), flags):
            continue
        if swap:
            outer[A] = outer[B]
        outer[E] = _fused_flags(int(inner[E]), flags)
        outer[OP], outer[B], outer[C] = op, inner[A], inner[B]
        fused += 1
    return fused


def _swapped_flags(flags: int) -> int:
    """The flags of an instruction whose operands `a` and `b` are swapped (vector flags and components)."""
    a, b = flags & VECTOR_A, flags & VECTOR_B
    component_a, component_b = (flags >> COMPONENT_A) & 3, (flags >> COMPONENT_B) & 3
    kept = flags & ~(VECTOR_A | VECTOR_B | 3 << COMPONENT_A | 3 << COMPONENT_B)
    return (
        kept | (VECTOR_B if a else 0) | (VECTOR_A if b else 0) | component_b << COMPONENT_A | component_a << COMPONENT_B
    )


def _same_width(inner: int, outer: int) -> bool:
    """Whether the reader reads the produced value as what it is: a vector operand of a vector
    result only where the producer made a vector (a scalar result reads first components only),
    a scalar at its first component (not a component of a vector, `ops.COMPONENT_A`)."""
    first = not (outer >> COMPONENT_B) & 3
    return first and (not (outer & VECTOR_RESULT and outer & VECTOR_B) or bool(inner & VECTOR_RESULT))


def _fused_flags(inner: int, outer: int) -> int:
    """The flags of the fused op: the reader's result and `a`; the producer's `a` and `b` as its
    `b` and `c` (their components, and their vector flags where the reader reads the produced
    vector component by component)."""
    by_component = outer & VECTOR_RESULT and outer & VECTOR_B
    b = VECTOR_B if by_component and inner & VECTOR_A else 0
    c = VECTOR_C if by_component and inner & VECTOR_B else 0
    components = ((inner >> COMPONENT_A) & 3) << COMPONENT_B | ((inner >> COMPONENT_B) & 3) << COMPONENT_C
    return (outer & (VECTOR_RESULT | VECTOR_A | 3 << COMPONENT_A)) | b | c | components
