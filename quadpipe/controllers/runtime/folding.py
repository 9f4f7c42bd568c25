"""Folding a lowered controller program: fewer instructions and registers, the same forces.

`lower` (`quadpipe.controllers.runtime.lowering`) already turns every sub-expression that
needs nothing from the simulation into a constant. What it leaves are operations with a
constant operand that decides their result: a spring of stiffness 0 masked by its machine's
state (`0 * mask`), a tunable at 0 (`unload * smoothstep(...)`), `x * 1`, `x + 0`, a `mix`
by 0. `fold(program)` runs five passes over the program:

1. **Identities** (`_identity`), in program order: an operation whose constant operands
   decide its value becomes a constant (`x * 0`, `0 / x`, `0 and c`, any exact operation of
   constants only); one that just passes an operand through is replaced by that operand in
   every later instruction (`x * 1`, `x + 0`, `x - 0`, `x / 1`, `mix(x, y, 0)`, a `select`
   on a constant condition or between two equal values), and a division by a constant power of
   two becomes a product by its exact reciprocal (the same bits, and a product can be fused).
   Constants found this way enable more of them downstream.
2. **Dead springs**: a spring whose stiffness and damping are both constant 0 adds nothing.
3. **Components** (`_forward_components`): an elementwise op reading `COMP(v, k)` reads
   component k of v itself, and the `COMP` is dropped with the dead code.
4. **Dead code** (`_live`): an instruction whose result no kept instruction reads is
   dropped, and a state-machine block left empty loses its jump; the registers still read
   are renumbered densely (a table's blocks of constants stay whole and consecutive), so the
   register file shrinks with the program.
5. **Fusing** (`quadpipe.controllers.runtime.fusing`): a product or difference read only by
   the next instruction, as its operand b, is computed inside it (`a - b * c` and the like),
   and the dead code pass runs again to drop it.

What changes: a term multiplied by a constant 0 is 0 even where the other factor would be
NaN or infinite (that factor can never act, so its fault is not reported), and the sign of a
zero may differ (`-x * 0` is +0.0 here). Every other value is computed by the same IEEE
operations in the same order, so forces are bit-for-bit those of the unfolded program.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np

from quadpipe.controllers.runtime.fusing import fuse
from quadpipe.controllers.runtime.lowering import OPERANDS, Program
from quadpipe.controllers.runtime.ops import (
    ADD,
    ADVANCE,
    AND,
    ANGLE,
    BODYROT,
    COMP,
    COMPONENT_A,
    COMPONENT_B,
    COMPONENT_C,
    CROSS,
    DIV,
    DOT,
    DST,
    FORCE,
    GE,
    GT,
    HEADING,
    HEIGHT,
    HORIZONTAL,
    INTERP,
    JUMP_IF_NONE,
    LE,
    LT,
    MAX,
    MIN,
    MIX,
    MUL,
    NEG,
    NORM,
    NORMALIZE,
    NOT,
    OP,
    OR,
    SELECT,
    SMOOTH,
    SPRING,
    SUB,
    TRANSITION,
    VEC,
    VECTOR_RESULT,
    ZERO,
    A,
    B,
    C,
    E,
)

STATEFUL_OPS = frozenset((JUMP_IF_NONE, ZERO, SMOOTH, ADVANCE, TRANSITION, FORCE, SPRING))
"""Ops kept whether or not their result is read: they change state, forces or control flow."""

_REGISTER_FIELDS: dict[int, tuple[int, ...]] = {
    VEC: (A, B, C), COMP: (A,), NORM: (A,), NORMALIZE: (A,), DOT: (A, B), CROSS: (A, B), ANGLE: (A, B),
    HORIZONTAL: (A,), INTERP: (A,), HEADING: (A,), BODYROT: (A,), HEIGHT: (A,), JUMP_IF_NONE: (A,), SMOOTH: (DST, A, B),
    ADVANCE: (B,), TRANSITION: (DST, A, B), FORCE: (A, B), SPRING: (A, B, C),
}  # fmt: skip
"""The columns an op reads registers from, for the non-elementwise ops (other ops read none)."""

WRITES_REGISTER = frozenset((ZERO, SMOOTH, TRANSITION))
"""Stateful ops whose `dst` is a register (the others' is a slot, a spring or unused)."""


def read_fields(op: int) -> tuple[int, ...]:
    """The columns of an instruction of `op` that hold registers it reads."""
    if op < VEC:
        return (A, B, C)[: OPERANDS.get(op, 3)]
    return _REGISTER_FIELDS.get(op, ())


def table_blocks(row: np.ndarray) -> tuple[int, ...]:
    """The columns of an `INTERP` instruction that hold the first register of a block of
    constants (its breakpoints, its values), each `row[E]` registers long; none for other ops."""
    return (B, C) if row[0] == INTERP else ()


def writes_register(op: int) -> bool:
    """Whether an instruction of `op` writes the register in its `dst` column."""
    return op not in STATEFUL_OPS or op in WRITES_REGISTER


_EXACT: dict[int, Callable[..., Any]] = {
    ADD: lambda x, y, z: x + y,
    SUB: lambda x, y, z: x - y,
    MUL: lambda x, y, z: x * y,
    DIV: lambda x, y, z: np.divide(x, y, out=np.zeros_like(x), where=y != 0.0),
    MIN: lambda x, y, z: np.where(x < y, x, y),
    MAX: lambda x, y, z: np.where(x > y, x, y),
    NEG: lambda x, y, z: -x,
    LT: lambda x, y, z: (x < y).astype(float),
    LE: lambda x, y, z: (x <= y).astype(float),
    GT: lambda x, y, z: (x > y).astype(float),
    GE: lambda x, y, z: (x >= y).astype(float),
    AND: lambda x, y, z: ((x != 0.0) & (y != 0.0)).astype(float),
    OR: lambda x, y, z: ((x != 0.0) | (y != 0.0)).astype(float),
    NOT: lambda x, y, z: (x == 0.0).astype(float),
    SELECT: lambda x, y, z: np.where(x != 0.0, y, z),
    MIX: lambda x, y, z: x + (y - x) * z,
}
"""Elementwise ops whose numpy form computes exactly what the kernel's does (IEEE basic
operations in the same order), so constants folded with them are bit-for-bit the kernel's."""


class _Folder:
    """The identity pass (see the module docstring) over one program."""

    def __init__(self, program: Program):
        self.code = program.code.copy()
        self.constants = dict(program.constants)
        self.alias: dict[int, int] = {}
        self.removed: set[int] = set()
        self.next_register = program.registers
        self.state_registers = {int(row[DST]) for row in self.code if row[0] in WRITES_REGISTER and row[0] != ZERO}

    def constant(self, register: int) -> np.ndarray | None:
        return self.constants.get(register)

    def is_value(self, register: int, value: float) -> bool:
        known = self.constant(register)
        return known is not None and bool((known == value).all())

    def operand(self, row: np.ndarray, field: int, flags: int) -> np.ndarray:
        """The (n, 3) value of a constant operand as the kernel reads it (a scalar's first
        component in all three)."""
        value = self.constants[int(row[field])]
        vector = flags >> (field - DST) & 1
        return value if vector else np.repeat(value[:, :1], 3, axis=1)

    def run(self) -> None:
        for index, row in enumerate(self.code):
            for field in read_fields(int(row[0])):
                row[field] = self.alias.get(int(row[field]), int(row[field]))
            if row[0] < VEC:
                self._identity(index, row)
            elif row[0] == SPRING and self.is_value(int(row[B]), 0.0) and self.is_value(int(row[C]), 0.0):
                self.removed.add(index)

    def _identity(self, index: int, row: np.ndarray) -> None:
        """Fold one elementwise instruction into a constant or an operand, where it can be."""
        op, dst, flags = int(row[0]), int(row[DST]), int(row[6])
        fields = read_fields(op)
        if op in _EXACT and all(self.constant(int(row[f])) is not None for f in fields):
            x, y, z = (self.operand(row, f, flags) if f in fields else None for f in (A, B, C))
            with np.errstate(all="ignore"):
                value = _EXACT[op](x, y, z)
            self._make_constant(index, dst, value if flags & VECTOR_RESULT else np.repeat(value[:, :1], 3, axis=1))
            return
        zero = [self.is_value(int(row[f]), 0.0) for f in (A, B, C)]
        one = [self.is_value(int(row[f]), 1.0) for f in (A, B, C)]
        if (op == MUL and (zero[0] or zero[1])) or (op in (DIV, AND) and zero[0]) or (op == AND and zero[1]):
            self._make_constant(index, dst, np.zeros_like(next(iter(self.constants.values()))))
        elif op == MUL and one[0]:
            self._pass_through(index, row, B)
        elif op in (MUL, DIV) and one[1]:
            self._pass_through(index, row, A)
        elif op == ADD and zero[0]:
            self._pass_through(index, row, B)
        elif (op in (ADD, SUB) and zero[1]) or (op == MIX and zero[2]):
            self._pass_through(index, row, A)
        elif op == SELECT and self.constant(int(row[A])) is not None:
            condition = self.constants[int(row[A])][:, 0]
            if (condition != 0.0).all():
                self._pass_through(index, row, B)
            elif (condition == 0.0).all():
                self._pass_through(index, row, C)
        elif op == SELECT and self._same_value(int(row[B]), int(row[C])):
            self._pass_through(index, row, B)
        elif op == DIV and (reciprocal := self._exact_reciprocal(row, flags)) is not None:
            row[0], row[B] = MUL, self._new_constant(reciprocal)

    def _exact_reciprocal(self, row: np.ndarray, flags: int) -> np.ndarray | None:
        """1 / the divisor of a division, where the divisor is a constant power of two, whose
        reciprocal is exact: then `x / d` and `x * (1 / d)` round the same real number, bit for
        bit, for every x (and d is no 0, the kernel's guarded case)."""
        if self.constant(int(row[B])) is None:
            return None
        divisor = self.operand(row, B, flags)
        with np.errstate(all="ignore"):
            reciprocal = 1.0 / divisor
        exact = (
            (np.abs(np.frexp(divisor)[0]) == 0.5)
            & (np.abs(np.frexp(reciprocal)[0]) == 0.5)
            & (reciprocal * divisor == 1.0)
        )
        return reciprocal if bool(exact.all()) else None

    def _new_constant(self, value: np.ndarray) -> int:
        """A register, numbered after the program's, that holds the constant `value`."""
        register = self.next_register
        self.next_register += 1
        self.constants[register] = np.ascontiguousarray(value, dtype=float)
        return register

    def _same_value(self, first: int, second: int) -> bool:
        """Whether two registers always hold the same bits: one register, or two constants
        equal bit for bit (so a `select` between them does not depend on its condition)."""
        if first == second:
            return True
        x, y = self.constant(first), self.constant(second)
        return x is not None and y is not None and x.shape == y.shape and x.tobytes() == y.tobytes()

    def _make_constant(self, index: int, dst: int, value: np.ndarray) -> None:
        self.constants[dst] = np.ascontiguousarray(value, dtype=float)
        self.removed.add(index)

    def _pass_through(self, index: int, row: np.ndarray, field: int) -> None:
        """Replace the result by operand `field` when that operand has the result's kind (a
        vector, or a scalar) and is not a state register (read before and after it changes)."""
        flags, source = int(row[6]), int(row[field])
        if (flags & VECTOR_RESULT) != (flags >> (field - DST) & 1) or source in self.state_registers:
            return
        self.alias[int(row[DST])] = self.alias.get(source, source)
        self.removed.add(index)


def _live(code: np.ndarray, removed: set[int]) -> list[int]:
    """The instructions to keep, in order: every stateful one (and a jump only over a block
    that keeps something), every one whose result a kept one reads."""
    needed: set[int] = set()
    kept: list[int] = []
    for index in range(len(code) - 1, -1, -1):
        row = code[index]
        op = int(row[0])
        if index in removed:
            continue
        if op == JUMP_IF_NONE:
            keep = any(index < k < row[B] for k in kept)
        else:
            keep = op in STATEFUL_OPS or int(row[DST]) in needed
        if keep:
            kept.append(index)
            needed.update(int(row[f]) for f in read_fields(op))
    return kept[::-1]


def _forward_components(code: np.ndarray, kept: list[int]) -> None:
    """Let the elementwise readers of `COMP(v, k)` (component k of v, in all three components)
    read v's component k themselves (`ops.COMPONENT_A`), where v is not written between the
    two and the `COMP` is in no state's block that the reader is not in; the `COMP` is then
    dead where nothing else reads it."""
    writes: dict[int, list[int]] = {}
    for index in kept:
        if writes_register(int(code[index, OP])):
            writes.setdefault(int(code[index, DST]), []).append(index)
    comps = {int(code[i, DST]): i for i in kept if code[i, OP] == COMP and len(writes[int(code[i, DST])]) == 1}
    blocks = [(i, int(code[i, B])) for i in kept if code[i, OP] == JUMP_IF_NONE]
    for index in kept:
        row = code[index]
        if row[OP] >= VEC:
            continue
        for field in read_fields(int(row[OP])):
            at = comps.get(int(row[field]), index)
            vector, component = int(code[at, A]), int(code[at, B])
            if at >= index or any(at < w < index for w in writes.get(vector, ())):
                continue
            if any(jump < at < end <= index for jump, end in blocks):
                continue
            flags = int(row[E]) & ~(1 << (field - DST)) & ~(3 << component_shift(field))
            row[field], row[E] = vector, flags | component << component_shift(field)


def component_shift(field: int) -> int:
    """The shift of the component bits (`ops.COMPONENT_A`) of the operand in column `field`."""
    return {A: COMPONENT_A, B: COMPONENT_B, C: COMPONENT_C}[field]


def fold(program: Program, *, fused: bool = True) -> Program:
    """The program folded (see the module docstring): same forces, fewer instructions and
    registers; `fused=False` leaves out the fusing pass (to check or time it)."""
    folder = _Folder(program)
    folder.run()
    kept = _live(folder.code, folder.removed)
    _forward_components(folder.code, kept)
    kept = _live(folder.code, set(range(len(folder.code))) - set(kept))
    if fused:
        dropped = set(range(len(folder.code))) - set(kept)
        reads = Counter(int(row[f]) for row in folder.code[kept] for f in read_fields(int(row[0])))
        fuse(folder.code, dropped, reads, {register for register, _ in program.sensors.values()})
        kept = _live(folder.code, dropped)
    new_index = {old: new for new, old in enumerate(kept)}
    code = folder.code[kept]
    registers = sorted(
        {int(row[f]) for row in code for f in read_fields(int(row[0]))}
        | {int(row[DST]) for row in code if writes_register(int(row[0]))}
        | {register for register, _ in program.sensors.values()}
        | {int(row[f]) + k for row in code for f in table_blocks(row) for k in range(int(row[E]))}
    )
    renumber = {old: new for new, old in enumerate(registers)}
    for row in code:
        op = int(row[0])
        for field in set(read_fields(op)) | ({DST} if writes_register(op) else set()) | set(table_blocks(row)):
            row[field] = renumber[int(row[field])]
        if op == JUMP_IF_NONE:
            row[B] = _next_kept(new_index, int(row[B]), len(code))
    return replace(
        program,
        code=np.ascontiguousarray(code),
        registers=len(registers),
        constants={renumber[r]: v for r, v in folder.constants.items() if r in renumber},
        sensors={name: (renumber[r], vector) for name, (r, vector) in program.sensors.items()},
        sensor_end=_next_kept(new_index, program.sensor_end, len(code)),
    )


def _next_kept(new_index: dict[int, int], old: int, end: int) -> int:
    """The new index of the first kept instruction at or after old index `old` (`end` if none)."""
    return min((new for o, new in new_index.items() if o >= old), default=end)
