"""The kernel's instruction set: the opcodes of a controller program.

A controller program (`quadpipe.controllers.runtime.lowering`) is rows of `code`,
`(op, dst, a, b, c, d, e)`, run by `quadpipe.controllers.runtime.kernel`; lowering, folding,
fusing and the kernel share these numbers. The kernel's cached compilation has them built in
and numba does not see a change here: one needs `kernel.py` touched (or the cache cleared).
"""

from __future__ import annotations

VECTOR_RESULT, VECTOR_A, VECTOR_B, VECTOR_C = 1, 2, 4, 8
"""the vector flags of an elementwise op (its `e`): the result, operand a, b, c are vectors."""

COMPONENT_A, COMPONENT_B, COMPONENT_C = 4, 6, 8
"""Where an elementwise op's `e` holds, after its vector flags, two bits per operand a, b, c
(these shifts): the component read from a scalar operand (0: x, as lowering emits; 1, 2: y, z,
where folding reads `COMP(v, k)` straight from `v`, `quadpipe.controllers.runtime.folding`). A
vector operand's are 0."""


# Opcodes. Arithmetic (dst, a, b, c are registers), elementwise (see `VECTOR_RESULT`).
ADD, SUB, MUL, DIV, POW, MIN, MAX, ATAN2 = 1, 2, 3, 4, 5, 6, 7, 8
LT, LE, GT, GE, AND, OR, STEP = 9, 10, 11, 12, 13, 14, 15
NEG, NOT, SIN, COS, TAN, ASIN, ACOS, ATAN, SQRT, EXP, LOG, ABS, SIGN, WRAP = range(16, 30)
CLAMP, SMOOTHSTEP, MIX, SELECT, LEG_SWEEP, LEG_LIFT = 30, 31, 32, 33, 34, 35
# Fused pairs (`quadpipe.controllers.runtime.fusing`): a - b * c, a * (b - c), a * (b * c), a + b * c.
SUB_MUL, MUL_SUB, MUL_MUL, ADD_MUL = 36, 37, 38, 39
# Vector ops (dst, a, b are registers; COMP's b is the component index).
VEC, COMP, NORM, NORMALIZE, DOT, CROSS, ANGLE, HORIZONTAL = 40, 41, 42, 43, 44, 45, 46, 47
# Tables: INTERP(dst, a = x, b = first of the breakpoints' registers, c = first of the values',
# e = their number): the table at x (see `_interp`).
INTERP = 48
# Frames: HEADING(dst, a); BODYROT(dst, a, b = row of `frame_body`).
HEADING, BODYROT = 50, 51
# Simulation reads: POINT/VELOCITY(dst, a = row of `point_body`); CONTACT(dst, a = leg);
# PHASE(dst, a = cycle); TIS(dst, a = machine); TIME(dst); GROUND_NORMAL(dst, a = leg bits);
# MASK(dst, a = machine, b = state); HEIGHT(dst, a = point register: its height above the ground).
POINT, VELOCITY, CONTACT, PHASE, TIS, TIME, GROUND_NORMAL, MASK, HEIGHT = 60, 61, 62, 63, 64, 65, 66, 67, 68
# Control: JUMP_IF_NONE(a = mask register, b = target); ZERO(dst).
JUMP_IF_NONE, ZERO = 70, 71
# State: SMOOTH(dst = sensor register, a = raw, b = time constant, c = sensor);
# ADVANCE(a = cycle, b = period register);
# TRANSITION(dst = switched register, a = delay, b = condition, c = machine, d = target state,
# e = bit mask of the source states).
SMOOTH, ADVANCE, TRANSITION = 80, 81, 82
# Forces: FORCE(dst = slot, a = point register, b = force register, e = 1: its opposite);
# SPRING(dst = spring, a = target angle, b = stiffness, c = damping).
FORCE, SPRING = 90, 91

CODE_WIDTH = 7
"""Columns of an instruction: op, dst, a, b, c, d, e."""

OP, DST, A, B, C, D, E = range(CODE_WIDTH)
"""The column of each field of an instruction (lowering, folding, fusing, allocation read them so)."""
