"""The controller kernel: one compiled function that runs a whole controller step.

A controller is lowered (`quadpipe.controllers.runtime.lowering`) to a flat program of instructions over a
register file, and this module executes it with numba, so a physics step costs one call
from Python instead of hundreds of small numpy calls.

Registers: `reg[r, animal, xyz]`, float64: a vector per animal, or a scalar in the first
component (a condition is 1.0 or 0.0). Constants are written into their registers once,
when the program is built, and never overwritten.

Instructions: rows of `code`, `(op, dst, a, b, c, d, e)`; `a`, `b`, `c` are registers for
the arithmetic ops, and table indices or jump targets for the others (each op is described
in `quadpipe.controllers.runtime.ops`; `_elementwise` computes the arithmetic ones). An
elementwise op's `e` holds the vector flags: which of its result and operands are vectors
(a scalar operand of a vector op is used for all three components).

Arrays: the kernel reaches every array it reads or writes (the program, the registers, the
runtime's tables and state, MuJoCo's data and model arrays) through one table of addresses
(`views.address_table`), so a call passes one address where it would pass some thirty arrays:
numba converts each array argument on every call (~0.1-0.2 µs each), an integer in ~0.04 µs,
and views made from an address carry no reference count.

One call of `run` does, in order:
1. the prologue: foot contacts per animal and leg (from MuJoCo's contact list), the ground
   normal under each foot, and the heading frame of each animal;
2. the instructions up to `last`;
3. when `finish` is set, the epilogue: the joint damping written into the model and the time
   in state of every machine advanced by one step.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from quadpipe.controllers.runtime import ops
from quadpipe.controllers.runtime.mjlib import mj_ray
from quadpipe.controllers.runtime.views import (
    int32_at,
    int32s2,
    ints1,
    ints2,
    real_at,
    reals1,
    reals2,
    reals3,
    table_at,
    uint32s2,
)

ZERO_NORM = 1e-12
"""Vectors shorter than this have no direction (as in `expressions.ZERO_NORM`)."""

LEG_DUTY_MARGIN = 1e-6
"""`leg_sweep` and `leg_lift` keep the duty factor this far inside (0, 1)."""

HEADING_MIN_NORM = 1e-9
"""Below this horizontal length, the pelvis-to-thorax direction is undefined: +x is used."""

NORMAL_MIN_NORM = 1e-9
"""Below this length, the summed contact normals give no direction: up is used."""

MIN_PERIOD_S = 1e-9
"""Shortest cycle period; a shorter (or zero) one is clamped to it."""

LEG_COUNT = 4

WORLD_GEOM_GROUPS = np.array([1, 0, 0, 0, 0, 0], dtype=np.uint8)
"""Geom groups a ground ray may hit: group 0 only (terrain and props; bones are in
`quadpipe.animals.model.ANIMAL_GEOM_GROUP`)."""

DOWN = -np.array([0.0, 0.0, 1.0])
"""Direction of a ground ray."""

NO_FAULT = -1
"""What `run` returns when every force and spring value was finite; else it returns the first
force slot with a non-finite force, or the number of slots plus the first such spring."""

CODE_DTYPE = np.uint32
"""The program's integer type (`program_array`). Every field fits (an opcode, a register, a row
of a table, a jump target, a bit mask of at most 32 states; none is negative), the instructions
streamed through the cache each step take half the bytes of int64, and numba indexes with an
unsigned field without first testing it for a negative index. The program is row `CODE` (0)
of the address table."""

CODE = 0

INTEGER_ARRAYS = (
    "point_body", "frame_body", "leg_of_geom", "animal_of_geom", "heading_points", "spring_start",
    "spring_dof", "spring_qpos", "spring_twist", "slot_body", "body_root", "state", "sensor_ready",
)  # fmt: skip
"""The int64 arrays of a runtime, rows of the address table (`views.address_table`) in this order, after `CODE`."""
(POINT_BODY, FRAME_BODY, LEG_OF_GEOM, ANIMAL_OF_GEOM, HEADING_POINTS, SPRING_START, SPRING_DOF,
 SPRING_QPOS, SPRING_TWIST, SLOT_BODY, BODY_ROOT, STATE, SENSOR_READY) = range(1, 1 + len(INTEGER_ARRAYS))  # fmt: skip

REAL_ARRAYS = (
    "registers", "point_offset", "base_damping", "slot_point", "slot_force", "phase", "time_in_state",
    "damping", "contact", "normals", "heading", "timestep",
)  # fmt: skip
"""The float64 arrays of a runtime, rows of the address table after `INTEGER_ARRAYS` (`timestep`:
one value, the physics step in seconds, which `run` would otherwise take as an argument)."""
(REGISTERS, POINT_OFFSET, BASE_DAMPING, SLOT_POINT, SLOT_FORCE, PHASES, TIME_IN_STATE, DAMPING, CONTACTS,
 NORMALS, HEADING_FRAMES, TIMESTEP) = range(1 + len(INTEGER_ARRAYS), 1 + len(INTEGER_ARRAYS) + len(REAL_ARRAYS))  # fmt: skip

MUJOCO_ARRAYS = (
    "xpos", "xmat", "xipos", "cvel", "subtree_com", "qpos", "qfrc_applied", "xfrc_applied", "dof_damping",
)  # fmt: skip
"""The float64 arrays of MuJoCo's data (and the model's `dof_damping`), rows of the address
table after `REAL_ARRAYS`; then two rows hold MuJoCo's contacts (`CONTACT_GEOMS`,
`CONTACT_FRAMES`: see `contact_row`), and two the addresses of the model and the data
themselves (`MODEL`, `DATA`, for `mj_ray`; the model's row also says, in its second field,
whether the ground is flat: `runtime.flat_ground`; the data's row holds, in its second and third
fields, the addresses of the data's `time` (float64) and `ncon` (int32): `views.data_field`,
which the kernel reads itself, where reading them in Python costs ~0.2 µs each)."""
(XPOS, XMAT, XIPOS, CVEL, SUBTREE_COM, QPOS, QFRC, XFRC, DOF_DAMPING, CONTACT_GEOMS, CONTACT_FRAMES, MODEL, DATA) = (
    range(REGISTERS + len(REAL_ARRAYS), REGISTERS + len(REAL_ARRAYS) + len(MUJOCO_ARRAYS) + 4)
)  # fmt: skip
TABLE_ROWS = DATA + 1
"""Rows of the address table."""


def program_array(code: np.ndarray) -> np.ndarray:
    """A program's instructions as the kernel reads them: C-contiguous `CODE_DTYPE`.

    Raises:
        ValueError: a field does not fit (a machine of more than 32 states, or some 2**32 registers).
    """
    limits = np.iinfo(CODE_DTYPE)
    if code.size and (code.min() < limits.min or code.max() > limits.max):
        raise ValueError(f"a controller program field is beyond the kernel's {np.dtype(CODE_DTYPE)} range")
    return np.ascontiguousarray(code, CODE_DTYPE)


@numba.njit(cache=True)
def _wrap(x: float) -> float:
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
def _elementwise(op: int, x: float, y: float, z: float) -> float:
    """One component of an arithmetic op on operands x, y, z."""
    if op == ops.ADD:
        return x + y
    if op == ops.SUB:
        return x - y
    if op == ops.MUL:
        return x * y
    if op == ops.SUB_MUL:
        return x - y * z
    if op == ops.MUL_SUB:
        return x * (y - z)
    if op == ops.MUL_MUL:
        return x * (y * z)
    if op == ops.ADD_MUL:
        return x + y * z
    if op == ops.DIV:
        return x / y if y != 0.0 else 0.0
    if op == ops.POW:
        return x**y
    if op == ops.MIN:
        return x if x < y else y
    if op == ops.MAX:
        return x if x > y else y
    if op == ops.ATAN2:
        return math.atan2(x, y)
    if op == ops.LT:
        return 1.0 if x < y else 0.0
    if op == ops.LE:
        return 1.0 if x <= y else 0.0
    if op == ops.GT:
        return 1.0 if x > y else 0.0
    if op == ops.GE:
        return 1.0 if x >= y else 0.0
    if op == ops.AND:
        return 1.0 if (x != 0.0 and y != 0.0) else 0.0
    if op == ops.OR:
        return 1.0 if (x != 0.0 or y != 0.0) else 0.0
    if op == ops.STEP:
        return 1.0 if y >= x else 0.0
    if op == ops.NEG:
        return -x
    if op == ops.NOT:
        return 1.0 if x == 0.0 else 0.0
    if op == ops.SIN:
        return math.sin(x)
    if op == ops.COS:
        return math.cos(x)
    if op == ops.TAN:
        return math.tan(x)
    if op == ops.ASIN:
        return math.asin(min(max(x, -1.0), 1.0))
    if op == ops.ACOS:
        return math.acos(min(max(x, -1.0), 1.0))
    if op == ops.ATAN:
        return math.atan(x)
    if op == ops.SQRT:
        return math.sqrt(max(x, 0.0))
    if op == ops.EXP:
        return math.exp(x)
    if op == ops.LOG:
        return math.log(max(x, ZERO_NORM))
    if op == ops.ABS:
        return abs(x)
    if op == ops.SIGN:
        return 1.0 if x > 0.0 else (-1.0 if x < 0.0 else x)
    if op == ops.WRAP:
        return _wrap(x)
    if op == ops.CLAMP:
        return min(max(x, y), z)
    if op == ops.SMOOTHSTEP:
        return _smoothstep(x, y, z)
    if op == ops.MIX:
        return x + (y - x) * z
    if op == ops.SELECT:
        return y if x != 0.0 else z
    if op == ops.LEG_SWEEP:
        duty = _duty(y)
        if x < duty:
            return 1.0 - 2.0 * x / duty
        return 2.0 * _smoothstep(duty, 1.0, x) - 1.0
    if op == ops.LEG_LIFT:
        duty = _duty(y)
        if x < duty:
            return 0.0
        return math.sin(math.pi * min(max((x - duty) / (1.0 - duty), 0.0), 1.0))
    return math.nan


@numba.njit(cache=True)
def _interp(reg: np.ndarray, dst: int, i: int, x: float, first: int, values: int, count: int) -> None:
    """Animal i's table at x into `reg[dst, i]`: the breakpoints are `reg[first + j, i, 0]`, not
    decreasing, the values `reg[values + j, i]`; linear between breakpoints, held at the ends,
    a repeated breakpoint's last value from it on (as `functions.table_interp`). A binary search:
    O(log count)."""
    low, high = 0, count
    while low < high:
        middle = (low + high) // 2
        if reg[first + middle, i, 0] <= x:
            low = middle + 1
        else:
            high = middle
    j = low - 1
    for k in range(3):
        if x != x:
            reg[dst, i, k] = math.nan
        elif j < 0 or j >= count - 1:
            reg[dst, i, k] = reg[values + min(max(j, 0), count - 1), i, k]
        else:
            u = (x - reg[first + j, i, 0]) / (reg[first + j + 1, i, 0] - reg[first + j, i, 0])
            reg[dst, i, k] = reg[values + j, i, k] + u * (reg[values + j + 1, i, k] - reg[values + j, i, k])


@numba.njit(cache=True)
def _unit(x: float, y: float, z: float) -> tuple[float, float, float]:
    """The direction of (x, y, z) (no array: the kernel allocates nothing per step)."""
    length = math.sqrt(x * x + y * y + z * z)
    if length > ZERO_NORM:
        return x / length, y / length, z / length
    if length == length:
        return 0.0, 0.0, 0.0
    return math.nan, math.nan, math.nan  # a NaN direction stays NaN, for FORCE to report (not a silent zero force)


@numba.njit(cache=True)
def _point(xpos: np.ndarray, xmat: np.ndarray, body: int, offset: np.ndarray) -> tuple[float, float, float]:
    """World position of the point at `offset` in `body`'s frame."""
    x = xpos[body, 0] + xmat[body, 0] * offset[0] + xmat[body, 1] * offset[1] + xmat[body, 2] * offset[2]
    y = xpos[body, 1] + xmat[body, 3] * offset[0] + xmat[body, 4] * offset[1] + xmat[body, 5] * offset[2]
    z = xpos[body, 2] + xmat[body, 6] * offset[0] + xmat[body, 7] * offset[1] + xmat[body, 8] * offset[2]
    return x, y, z


@numba.njit(cache=True)
def _ground_height(model: int, data: int, point: np.ndarray, flat: bool) -> float:
    """Height of `point` (3,), contiguous, above the world geom straight below it (terrain or
    prop, static or not; no animal's bone); its z when there is none. `model` and `data` are
    MuJoCo's, by address. `flat`: the only geoms a ray may hit are horizontal planes through
    z = 0 (`runtime.flat_ground`), where MuJoCo's ray finds the point's own z (or misses, and z is
    the answer), so no ray is cast."""
    if flat:
        return point[2]
    distance: float = mj_ray(
        model, data, point.ctypes.data, DOWN.ctypes.data, WORLD_GEOM_GROUPS.ctypes.data, 1, -1, 0, 0
    )
    return distance if distance >= 0.0 else point[2]


@numba.njit(cache=True)
def _contacts(
    ncon: int,
    geoms: np.ndarray,
    frames: np.ndarray,
    leg_of_geom: np.ndarray,
    animal_of_geom: np.ndarray,
    contact: np.ndarray,
    normals: np.ndarray,
) -> None:
    """Which feet touch something but their own animal, and the summed normals under them.

    The normal of MuJoCo's contact frame points from its first geom to its second; the one
    summed points into the foot, up from the ground.
    """
    contact[:] = 0.0
    normals[:] = 0.0
    for c in range(ncon):
        for side in range(2):
            foot = geoms[c, side]
            other = geoms[c, 1 - side]
            sign = -1.0 if side == 0 else 1.0
            leg = leg_of_geom[foot]
            animal = animal_of_geom[foot]
            if leg >= 0 and animal_of_geom[other] != animal:
                contact[animal, leg] = 1.0
                for k in range(3):
                    normals[animal, leg, k] += sign * frames[c, k]


@numba.njit(cache=True)
def _headings(
    xpos: np.ndarray,
    xmat: np.ndarray,
    point_body: np.ndarray,
    point_offset: np.ndarray,
    pelvis: int,
    thorax: int,
    heading: np.ndarray,
) -> None:
    """Heading frames (columns: forward, left, up) from pelvis.start toward thorax.start."""
    for i in range(heading.shape[0]):
        ax, ay, _ = _point(xpos, xmat, point_body[pelvis, i], point_offset[pelvis, i])
        bx, by, _ = _point(xpos, xmat, point_body[thorax, i], point_offset[thorax, i])
        fx, fy = bx - ax, by - ay
        length = math.sqrt(fx * fx + fy * fy)
        if length > HEADING_MIN_NORM:
            fx, fy = fx / length, fy / length
        else:
            fx, fy = 1.0, 0.0
        heading[i, 0, 0], heading[i, 1, 0], heading[i, 2, 0] = fx, fy, 0.0
        heading[i, 0, 1], heading[i, 1, 1], heading[i, 2, 1] = -fy, fx, 0.0
        heading[i, 0, 2], heading[i, 1, 2], heading[i, 2, 2] = 0.0, 0.0, 1.0


@numba.njit(cache=True, nogil=True)
def run(address: int, last: int, finish: bool) -> int:
    """Run the instructions of a controller program up to `last` (see the module docstring).

    `address` is that of the address table (`TABLE_ROWS` rows, `views.address_table`), which
    holds the address and shape of every array the kernel uses: the
    program, the registers, the runtime's tables and state (the time step among them), and
    MuJoCo's own arrays (forces are added into `xfrc_applied` and `qfrc_applied`, damping
    written into the model's `dof_damping`), and the addresses of the model and the data, for
    MuJoCo's ray casts (`HEIGHT`), of the data's `time` and `ncon`, and MuJoCo's contacts, of
    which the first `ncon` are read. Every argument is a number: numba's dispatcher converts
    each argument on every call, a number in ~0.04 µs.

    A force or spring value that is NaN or infinite is not applied: `run` returns where it
    was (see `NO_FAULT`), for the runtime to report.
    """
    table = table_at(address, TABLE_ROWS)
    code, reg = uint32s2(table, CODE), reals3(table, REGISTERS)
    n = reg.shape[1]
    point_body, frame_body = ints2(table, POINT_BODY), ints2(table, FRAME_BODY)
    leg_of_geom, animal_of_geom = ints1(table, LEG_OF_GEOM), ints1(table, ANIMAL_OF_GEOM)
    heading_points, body_root = ints1(table, HEADING_POINTS), ints1(table, BODY_ROOT)
    spring_start, spring_dof = ints1(table, SPRING_START), ints2(table, SPRING_DOF)
    spring_qpos, spring_twist = ints2(table, SPRING_QPOS), ints2(table, SPRING_TWIST)
    slot_body, state, sensor_ready = ints2(table, SLOT_BODY), ints2(table, STATE), ints1(table, SENSOR_READY)
    point_offset, base_damping = reals3(table, POINT_OFFSET), reals1(table, BASE_DAMPING)
    slot_point, slot_force = reals3(table, SLOT_POINT), reals3(table, SLOT_FORCE)
    phase, time_in_state = reals2(table, PHASES), reals2(table, TIME_IN_STATE)
    damping, contact = reals1(table, DAMPING), reals2(table, CONTACTS)
    normals, heading = reals3(table, NORMALS), reals3(table, HEADING_FRAMES)
    xpos, xmat, xipos = reals2(table, XPOS), reals2(table, XMAT), reals2(table, XIPOS)
    cvel, subtree_com, qpos = reals2(table, CVEL), reals2(table, SUBTREE_COM), reals1(table, QPOS)
    qfrc, xfrc, dof_damping = reals1(table, QFRC), reals2(table, XFRC), reals1(table, DOF_DAMPING)
    model, data, flat, dt = table[MODEL, 0], table[DATA, 0], table[MODEL, 1] != 0, reals1(table, TIMESTEP)[0]
    time, ncon = real_at(table[DATA, 1]), int32_at(table[DATA, 2])
    contact_geoms, contact_frames = int32s2(table, CONTACT_GEOMS), reals2(table, CONTACT_FRAMES)
    _contacts(ncon, contact_geoms, contact_frames, leg_of_geom, animal_of_geom, contact, normals)
    _headings(xpos, xmat, point_body, point_offset, heading_points[0], heading_points[1], heading)
    if finish:
        slot_force[:] = 0.0
        damping[:] = 0.0
    fault = NO_FAULT
    pc = 0
    while pc < last:
        op, dst, a, b, c, d, e = (
            code[pc, 0],
            code[pc, 1],
            code[pc, 2],
            code[pc, 3],
            code[pc, 4],
            code[pc, 5],
            code[pc, 6],
        )
        pc += 1
        if op < ops.VEC:  # a scalar operand is read at its component (`ops.COMPONENT_A`), a vector's all three
            ca, cb, cc = (e >> ops.COMPONENT_A) & 3, (e >> ops.COMPONENT_B) & 3, (e >> ops.COMPONENT_C) & 3
            if e & ops.VECTOR_RESULT:
                sa, sb, sc = (e >> 1) & 1, (e >> 2) & 1, (e >> 3) & 1
                for i in range(n):
                    for k in range(3):
                        x, y, z = reg[a, i, k * sa + ca], reg[b, i, k * sb + cb], reg[c, i, k * sc + cc]
                        reg[dst, i, k] = _elementwise(op, x, y, z)
            else:  # a scalar result: every operand read as a scalar
                for i in range(n):
                    reg[dst, i, 0] = _elementwise(op, reg[a, i, ca], reg[b, i, cb], reg[c, i, cc])
        elif op == ops.VEC:
            for i in range(n):
                reg[dst, i, 0], reg[dst, i, 1], reg[dst, i, 2] = reg[a, i, 0], reg[b, i, 0], reg[c, i, 0]
        elif op == ops.COMP:
            for i in range(n):
                value = reg[a, i, b]
                reg[dst, i, 0], reg[dst, i, 1], reg[dst, i, 2] = value, value, value
        elif op == ops.NORM:
            for i in range(n):
                value = math.sqrt(reg[a, i, 0] ** 2 + reg[a, i, 1] ** 2 + reg[a, i, 2] ** 2)
                reg[dst, i, 0], reg[dst, i, 1], reg[dst, i, 2] = value, value, value
        elif op == ops.NORMALIZE:
            for i in range(n):
                reg[dst, i, 0], reg[dst, i, 1], reg[dst, i, 2] = _unit(reg[a, i, 0], reg[a, i, 1], reg[a, i, 2])
        elif op == ops.DOT:
            for i in range(n):
                value = reg[a, i, 0] * reg[b, i, 0] + reg[a, i, 1] * reg[b, i, 1] + reg[a, i, 2] * reg[b, i, 2]
                reg[dst, i, 0], reg[dst, i, 1], reg[dst, i, 2] = value, value, value
        elif op == ops.CROSS:
            for i in range(n):
                x = reg[a, i, 1] * reg[b, i, 2] - reg[a, i, 2] * reg[b, i, 1]
                y = reg[a, i, 2] * reg[b, i, 0] - reg[a, i, 0] * reg[b, i, 2]
                z = reg[a, i, 0] * reg[b, i, 1] - reg[a, i, 1] * reg[b, i, 0]
                reg[dst, i, 0], reg[dst, i, 1], reg[dst, i, 2] = x, y, z
        elif op == ops.ANGLE:
            for i in range(n):
                ux, uy, uz = _unit(reg[a, i, 0], reg[a, i, 1], reg[a, i, 2])
                vx, vy, vz = _unit(reg[b, i, 0], reg[b, i, 1], reg[b, i, 2])
                value = math.acos(min(max(ux * vx + uy * vy + uz * vz, -1.0), 1.0))
                reg[dst, i, 0], reg[dst, i, 1], reg[dst, i, 2] = value, value, value
        elif op == ops.INTERP:
            for i in range(n):
                _interp(reg, dst, i, reg[a, i, 0], b, c, e)
        elif op == ops.HORIZONTAL:
            for i in range(n):
                reg[dst, i, 0], reg[dst, i, 1], reg[dst, i, 2] = reg[a, i, 0], reg[a, i, 1], 0.0
        elif op == ops.HEADING:
            for i in range(n):
                x, y, z = reg[a, i, 0], reg[a, i, 1], reg[a, i, 2]
                for k in range(3):
                    reg[dst, i, k] = heading[i, k, 0] * x + heading[i, k, 1] * y + heading[i, k, 2] * z
        elif op == ops.BODYROT:
            for i in range(n):
                x, y, z, body = reg[a, i, 0], reg[a, i, 1], reg[a, i, 2], frame_body[b, i]
                for k in range(3):
                    reg[dst, i, k] = xmat[body, 3 * k] * x + xmat[body, 3 * k + 1] * y + xmat[body, 3 * k + 2] * z
        elif op == ops.POINT:
            for i in range(n):
                reg[dst, i, 0], reg[dst, i, 1], reg[dst, i, 2] = _point(
                    xpos, xmat, point_body[a, i], point_offset[a, i]
                )
        elif op == ops.VELOCITY:
            for i in range(n):
                body = point_body[a, i]
                px, py, pz = _point(xpos, xmat, body, point_offset[a, i])
                root = body_root[body]
                rx, ry, rz = px - subtree_com[root, 0], py - subtree_com[root, 1], pz - subtree_com[root, 2]
                wx, wy, wz = cvel[body, 0], cvel[body, 1], cvel[body, 2]
                reg[dst, i, 0] = cvel[body, 3] + (wy * rz - wz * ry)
                reg[dst, i, 1] = cvel[body, 4] + (wz * rx - wx * rz)
                reg[dst, i, 2] = cvel[body, 5] + (wx * ry - wy * rx)
        elif op == ops.CONTACT:
            for i in range(n):
                reg[dst, i, 0] = reg[dst, i, 1] = reg[dst, i, 2] = contact[i, a]
        elif op == ops.PHASE:
            for i in range(n):
                reg[dst, i, 0] = reg[dst, i, 1] = reg[dst, i, 2] = _wrap(phase[a, i])
        elif op == ops.TIS:
            for i in range(n):
                reg[dst, i, 0] = reg[dst, i, 1] = reg[dst, i, 2] = time_in_state[a, i]
        elif op == ops.TIME:
            reg[dst, :, :] = time
        elif op == ops.GROUND_NORMAL:
            for i in range(n):
                x = y = z = 0.0
                for leg in range(LEG_COUNT):
                    if (a >> leg) & 1:
                        x += normals[i, leg, 0]
                        y += normals[i, leg, 1]
                        z += normals[i, leg, 2]
                length = math.sqrt(x * x + y * y + z * z)
                if length > NORMAL_MIN_NORM:
                    reg[dst, i, 0], reg[dst, i, 1], reg[dst, i, 2] = x / length, y / length, z / length
                else:
                    reg[dst, i, 0], reg[dst, i, 1], reg[dst, i, 2] = 0.0, 0.0, 1.0
        elif op == ops.HEIGHT:
            for i in range(n):
                reg[dst, i, 0] = reg[dst, i, 1] = reg[dst, i, 2] = _ground_height(model, data, reg[a, i], flat)
        elif op == ops.MASK:
            for i in range(n):
                reg[dst, i, 0] = reg[dst, i, 1] = reg[dst, i, 2] = 1.0 if state[a, i] == b else 0.0
        elif op == ops.JUMP_IF_NONE:
            none = True
            for i in range(n):
                if reg[a, i, 0] != 0.0:
                    none = False
            if none:
                pc = b
        elif op == ops.ZERO:
            reg[dst, :, :] = 0.0
        elif op == ops.SMOOTH:
            for i in range(n):
                if sensor_ready[c] != 0:
                    weight = dt / (reg[b, i, 0] + dt)
                    for k in range(3):
                        reg[dst, i, k] = reg[dst, i, k] + weight * (reg[a, i, k] - reg[dst, i, k])
                else:
                    for k in range(3):
                        reg[dst, i, k] = reg[a, i, k]
            sensor_ready[c] = 1
        elif op == ops.ADVANCE:
            for i in range(n):
                phase[a, i] += dt / max(reg[b, i, 0], MIN_PERIOD_S)
        elif op == ops.TRANSITION:
            for i in range(n):
                fires = (
                    reg[dst, i, 0] == 0.0
                    and (e >> state[c, i]) & 1
                    and time_in_state[c, i] >= reg[a, i, 0]
                    and reg[b, i, 0] != 0.0
                )
                if fires:
                    state[c, i] = d
                    time_in_state[c, i] = 0.0
                    reg[dst, i, 0] = reg[dst, i, 1] = reg[dst, i, 2] = 1.0
        elif op == ops.FORCE:
            sign = -1.0 if e else 1.0
            for i in range(n):
                body = slot_body[dst, i]
                fx, fy, fz = sign * reg[b, i, 0], sign * reg[b, i, 1], sign * reg[b, i, 2]
                if not (math.isfinite(fx) and math.isfinite(fy) and math.isfinite(fz)):
                    fault = dst if fault == NO_FAULT else fault
                    fx, fy, fz = 0.0, 0.0, 0.0
                for k in range(3):
                    slot_point[dst, i, k] = reg[a, i, k]
                slot_force[dst, i, 0], slot_force[dst, i, 1], slot_force[dst, i, 2] = fx, fy, fz
                rx, ry, rz = reg[a, i, 0] - xipos[body, 0], reg[a, i, 1] - xipos[body, 1], reg[a, i, 2] - xipos[body, 2]
                xfrc[body, 0] += fx
                xfrc[body, 1] += fy
                xfrc[body, 2] += fz
                xfrc[body, 3] += ry * fz - rz * fy
                xfrc[body, 4] += rz * fx - rx * fz
                xfrc[body, 5] += rx * fy - ry * fx
        elif op == ops.SPRING:
            for j in range(spring_start[dst], spring_start[dst + 1]):
                for i in range(n):
                    target = reg[a, i, 0] if spring_twist[j, i] != 0 else 0.0
                    if not (math.isfinite(target) and math.isfinite(reg[b, i, 0]) and math.isfinite(reg[c, i, 0])):
                        fault = slot_force.shape[0] + dst if fault == NO_FAULT else fault
                        continue
                    qfrc[spring_dof[j, i]] += -reg[b, i, 0] * (qpos[spring_qpos[j, i]] - target)
                    damping[spring_dof[j, i]] += reg[c, i, 0]
    if finish:
        for dof in range(dof_damping.shape[0]):
            dof_damping[dof] = base_damping[dof] + damping[dof]
        time_in_state += dt
    return fault
