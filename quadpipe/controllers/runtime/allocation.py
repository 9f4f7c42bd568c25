"""Register allocation: a folded program's temporaries share registers, the same values.

Lowering gives every intermediate value its own register, so the register file is as long as
the program (`walk` on the dog: 402 registers of 24 bytes per animal for 402 instructions),
and every step streams all of it through the caches that MuJoCo's step has just filled with
its own data. Most values live for a few instructions only. `allocate(program)` gives each
temporary a register from a pool at its first write and gives the register back after its
last use, one linear scan over the program (which has no backward jump), so the file holds
the constants, the sensors and only as many temporaries as are live at once.

A register is a temporary when every run writes it before it reads it and nothing outside a
run reads it. These keep a register of their own: constants (written once, when the program
is built), sensors (smoothed state, read by the runtime), a register read before its first
write (state kept from the step before), and a value first written inside a state's block
(between a `JUMP_IF_NONE` and its target) and used after the block, which a skipped block
would leave stale (lowering forgets such values, so there is none).

Every run computes the same values, bit for bit: a temporary's register holds its value from
its first write to its last use, and no other temporary shares it in between. An elementwise
op with a scalar result writes only the first component of its register; such registers share
registers only among themselves, whose other components therefore stay 0 as before (every
other instruction writes all three components). A result never takes the register of an
operand of its own instruction (a vector op may read an operand after writing a component).
"""

from __future__ import annotations

import heapq
from dataclasses import dataclass, field, replace

import numpy as np

from quadpipe.controllers.runtime.folding import read_fields, table_blocks, writes_register
from quadpipe.controllers.runtime.lowering import Program
from quadpipe.controllers.runtime.ops import DST, JUMP_IF_NONE, VEC, VECTOR_RESULT, B, E


@dataclass
class _Uses:
    """Where a program writes and reads each register (instruction indices)."""

    first_write: dict[int, int] = field(default_factory=dict)
    first_read: dict[int, int] = field(default_factory=dict)
    last_use: dict[int, int] = field(default_factory=dict)
    scalar_writes: dict[int, set[bool]] = field(default_factory=dict)

    @classmethod
    def of(cls, code: np.ndarray) -> _Uses:
        uses = cls()
        for index, row in enumerate(code):
            op = int(row[0])
            for column in read_fields(op):
                register = int(row[column])
                uses.first_read.setdefault(register, index)
                uses.last_use[register] = index
            if writes_register(op):
                register = int(row[DST])
                uses.first_write.setdefault(register, index)
                uses.last_use[register] = index
                uses.scalar_writes.setdefault(register, set()).add(op < VEC and not int(row[E]) & VECTOR_RESULT)
        return uses


def allocate(program: Program) -> Program:
    """`program` with its temporaries sharing registers (see the module docstring)."""
    code, uses = program.code, _Uses.of(program.code)
    own = _own_registers(program, uses)
    renumber = {old: new for new, old in enumerate(sorted(own))}
    temporaries = sorted((uses.first_write[r], r) for r in uses.first_write if r not in own)
    renumber |= _linear_scan(temporaries, uses, len(renumber))
    allocated = code.copy()
    for row in allocated:
        op = int(row[0])
        for column in set(read_fields(op)) | ({DST} if writes_register(op) else set()) | set(table_blocks(row)):
            row[column] = renumber[int(row[column])]
    return replace(
        program,
        code=np.ascontiguousarray(allocated),
        registers=max(renumber.values(), default=-1) + 1,
        constants={renumber[r]: value for r, value in program.constants.items()},
        sensors={name: (renumber[r], vector) for name, (r, vector) in program.sensors.items()},
    )


def _own_registers(program: Program, uses: _Uses) -> set[int]:
    """The registers that are no temporary (see the module docstring), or written both ways
    (only the first component and all three) and so in neither pool."""
    never_written = len(program.code)
    return (
        set(program.constants)
        | {register for register, _ in program.sensors.values()}
        | {r for r, index in uses.first_read.items() if index <= uses.first_write.get(r, never_written)}
        | {r for r, kinds in uses.scalar_writes.items() if len(kinds) > 1}
        | _used_after_their_block(program.code, uses)
    )


def _used_after_their_block(code: np.ndarray, uses: _Uses) -> set[int]:
    """Registers first written inside a state's block and used at or after its end."""
    found = set()
    for jump, row in enumerate(code):
        if row[0] == JUMP_IF_NONE:
            end = int(row[B])
            found |= {r for r, first in uses.first_write.items() if jump < first < end <= uses.last_use[r]}
    return found


def _linear_scan(temporaries: list[tuple[int, int]], uses: _Uses, first_free: int) -> dict[int, int]:
    """Old -> new register of each temporary (`temporaries`: (first write, register), in order),
    from two pools (scalar results, the rest), numbered from `first_free`. A register given
    back is the next one handed out of its pool (the most recently used: still in the cache)."""
    free: dict[bool, list[int]] = {True: [], False: []}
    live: list[tuple[int, int, bool]] = []  # (last use, new register, pool)
    renumber, count = {}, first_free
    for start, register in temporaries:
        while live and live[0][0] < start:
            _, freed, pool = heapq.heappop(live)
            free[pool].append(freed)
        pool = True in uses.scalar_writes[register]
        if free[pool]:
            renumber[register] = free[pool].pop()
        else:
            renumber[register], count = count, count + 1
        heapq.heappush(live, (uses.last_use[register], renumber[register], pool))
    return renumber
