"""The kernel's instruction set: opcodes, and the arithmetic of one component.

A controller program (`quadpipe.controllers.runtime.lowering`) is rows of `code`,
`(op, dst, a, b, c, d, e)`, run by `quadpipe.controllers.runtime.kernel`. This module names
the opcodes and computes the elementwise ones (`elementwise`: one component of an arithmetic
op), so lowering, folding and the kernel share one definition of each.
"""

from __future__ import annotations

import math

import numba

ZERO_NORM = 1e-12
"""Vectors shorter than this have no direction (as in `expressions.ZERO_NORM`)."""

LEG_DUTY_MARGIN = 1e-6
"""`leg_sweep` and `leg_lift` keep the duty factor this far inside (0, 1)."""

VECTOR_RESULT, VECTOR_A, VECTOR_B, VECTOR_C = 1, 2, 4, 8
"""the vector flags of an elementwise op (its `e`): the result, operand a, b, c are vectors."""

# Opcodes. Arithmetic (dst, a, b, c are registers), elementwise (see `VECTOR_RESULT`).
ADD, SUB, MUL, DIV, POW, MIN, MAX, ATAN2 = 1, 2, 3, 4, 5, 6, 7, 8
LT, LE, GT, GE, AND, OR, STEP = 9, 10, 11, 12, 13, 14, 15
NEG, NOT, SIN, COS, TAN, ASIN, ACOS, ATAN, SQRT, EXP, LOG, ABS, SIGN, WRAP = range(16, 30)
CLAMP, SMOOTHSTEP, MIX, SELECT, LEG_SWEEP, LEG_LIFT = 30, 31, 32, 33, 34, 35
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


@numba.njit(cache=True)
def wrap(x: float) -> float:
    """x modulo 1, as numpy's `mod` computes it (the same single rounding)."""
    return x - math.floor(x)


@numba.njit(cache=True)
def _smoothstep(e0: float, e1: float, x: float) -> float:
    if e1 == e0:
        return 1.0 if x >= e0 else 0.0
    u = min(max((x - e0) / (e1 - e0), 0.0), 1.0)
    return u * u * (3.0 - 2.0 * u)


@numba.njit(cache=True)
def _duty(duty: float) -> float:
    return min(max(duty, LEG_DUTY_MARGIN), 1.0 - LEG_DUTY_MARGIN)


@numba.njit(cache=True, inline="always")
def elementwise(op: int, x: float, y: float, z: float) -> float:
    """One component of an arithmetic op on operands x, y, z."""
    if op == ADD:
        return x + y
    if op == SUB:
        return x - y
    if op == MUL:
        return x * y
    if op == DIV:
        return x / y if y != 0.0 else 0.0
    if op == POW:
        return x**y
    if op == MIN:
        return x if x < y else y
    if op == MAX:
        return x if x > y else y
    if op == ATAN2:
        return math.atan2(x, y)
    if op == LT:
        return 1.0 if x < y else 0.0
    if op == LE:
        return 1.0 if x <= y else 0.0
    if op == GT:
        return 1.0 if x > y else 0.0
    if op == GE:
        return 1.0 if x >= y else 0.0
    if op == AND:
        return 1.0 if (x != 0.0 and y != 0.0) else 0.0
    if op == OR:
        return 1.0 if (x != 0.0 or y != 0.0) else 0.0
    if op == STEP:
        return 1.0 if y >= x else 0.0
    if op == NEG:
        return -x
    if op == NOT:
        return 1.0 if x == 0.0 else 0.0
    if op == SIN:
        return math.sin(x)
    if op == COS:
        return math.cos(x)
    if op == TAN:
        return math.tan(x)
    if op == ASIN:
        return math.asin(min(max(x, -1.0), 1.0))
    if op == ACOS:
        return math.acos(min(max(x, -1.0), 1.0))
    if op == ATAN:
        return math.atan(x)
    if op == SQRT:
        return math.sqrt(max(x, 0.0))
    if op == EXP:
        return math.exp(x)
    if op == LOG:
        return math.log(max(x, ZERO_NORM))
    if op == ABS:
        return abs(x)
    if op == SIGN:
        return 1.0 if x > 0.0 else (-1.0 if x < 0.0 else x)
    if op == WRAP:
        return wrap(x)
    if op == CLAMP:
        return min(max(x, y), z)
    if op == SMOOTHSTEP:
        return _smoothstep(x, y, z)
    if op == MIX:
        return x + (y - x) * z
    if op == SELECT:
        return y if x != 0.0 else z
    if op == LEG_SWEEP:
        duty = _duty(y)
        if x < duty:
            return 1.0 - 2.0 * x / duty
        return 2.0 * _smoothstep(duty, 1.0, x) - 1.0
    if op == LEG_LIFT:
        duty = _duty(y)
        if x < duty:
            return 0.0
        return math.sin(math.pi * min(max((x - duty) / (1.0 - duty), 0.0), 1.0))
    return math.nan
