"""Lowering a compiled controller to a flat program for the kernel (`quadpipe.controllers.runtime.kernel`).

`lower(compiled)` walks the controller in the order the runtime's step runs it and emits
instructions over registers:

1. sensors: raw value, then low-pass smoothing into the sensor's own register;
2. cycles: each phase advances by dt / period;
3. state machines: each transition, in priority order, for the animals it fires for;
4. force elements: each form of each element (the base form, or one per state of the machine
   that owns it, skipped when no animal is in that state), its forces into force slots.

Expressions are lowered node by node with common subexpressions shared: a node whose
operation and operands were already computed reuses that register. A value that reads state
changed later in the step (a phase, a time in state, a sensor) is forgotten when that state
changes, and values computed inside a skipped block are forgotten at its end. Sub-trees
that need nothing from the simulation are folded into constants by the reference
evaluator (`expressions.compile_expr`), so constants are exactly those of the DSL.

The program names what it reads symbolically (body points, frames, joints by role), so it
does not depend on a MuJoCo model; the runtime binds those names to body and joint ids.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from quadpipe.anatomy.roles import LEGS
from quadpipe.controllers.language import schema
from quadpipe.controllers.language.compiler import CompiledController, CompiledElement
from quadpipe.controllers.runtime.ops import (
    ABS,
    ACOS,
    ADD,
    ADVANCE,
    AND,
    ANGLE,
    ASIN,
    ATAN,
    ATAN2,
    BODYROT,
    CLAMP,
    CODE_WIDTH,
    COMP,
    CONTACT,
    COS,
    CROSS,
    DIV,
    DOT,
    EXP,
    FORCE,
    GE,
    GROUND_NORMAL,
    GT,
    HEADING,
    HEIGHT,
    HORIZONTAL,
    INTERP,
    JUMP_IF_NONE,
    LE,
    LEG_LIFT,
    LEG_SWEEP,
    LOG,
    LT,
    MASK,
    MAX,
    MIN,
    MIX,
    MUL,
    NEG,
    NORM,
    NORMALIZE,
    NOT,
    OR,
    PHASE,
    POINT,
    POW,
    SELECT,
    SIGN,
    SIN,
    SMOOTH,
    SMOOTHSTEP,
    SPRING,
    SQRT,
    STEP,
    SUB,
    TAN,
    TIME,
    TIS,
    TRANSITION,
    VEC,
    VELOCITY,
    WRAP,
    ZERO,
)
from quadpipe.quantities import units
from quadpipe.quantities.expressions import TIME_VARIABLE, VECTOR, Compiled, Expr, Type, compile_expr, table_rows

FUNCTION_OPS: dict[str, int] = {
    "sin": SIN, "cos": COS, "tan": TAN, "asin": ASIN, "acos": ACOS, "atan": ATAN,
    "atan2": ATAN2, "sqrt": SQRT, "exp": EXP, "log": LOG, "abs": ABS, "sign": SIGN,
    "min": MIN, "max": MAX, "clamp": CLAMP, "wrap": WRAP, "leg_sweep": LEG_SWEEP,
    "leg_lift": LEG_LIFT, "step": STEP, "smoothstep": SMOOTHSTEP, "mix": MIX,
    "norm": NORM, "normalize": NORMALIZE, "dot": DOT, "cross": CROSS, "angle": ANGLE,
    "horizontal": HORIZONTAL, "heading": HEADING,
}  # fmt: skip
"""DSL function -> kernel opcode (`froude_speed` is lowered to a product and a root)."""

BINARY_OPS: dict[str, int] = {"add": ADD, "sub": SUB, "mul": MUL, "div": DIV, "pow": POW}
COMPARE_OPS: dict[str, int] = {"<": LT, "<=": LE, ">": GT, ">=": GE}
REDUCING_OPS: dict[str, int] = {"and": AND, "or": OR, "min": MIN, "max": MAX}
"""N-ary operations, lowered as a chain of binary ones."""

VECTOR_RESULTS: dict[int, bool] = {
    VEC: True, NORMALIZE: True, CROSS: True, HORIZONTAL: True, HEADING: True, BODYROT: True,
    COMP: False, NORM: False, DOT: False, ANGLE: False, HEIGHT: False,
}  # fmt: skip
"""Non-elementwise ops: whether their result is a vector."""

OPERANDS: dict[int, int] = {
    **dict.fromkeys((NEG, NOT, SIN, COS, TAN, ASIN, ACOS, ATAN, SQRT, EXP, LOG, ABS, SIGN, WRAP), 1),
    **dict.fromkeys((COMP, NORM, NORMALIZE, HORIZONTAL, HEADING, BODYROT, HEIGHT), 1),
    **dict.fromkeys((ADD, SUB, MUL, DIV, POW, MIN, MAX, ATAN2, LT, LE, GT, GE, AND, OR, STEP), 2),
    **dict.fromkeys((LEG_SWEEP, LEG_LIFT, DOT, CROSS, ANGLE), 2),
}  # fmt: skip
"""How many of an op's a, b, c are registers (3 when not listed)."""

HEADING_POINTS = ("pelvis.start", "thorax.start")
"""The heading frame points from the first toward the second (horizontally)."""

MIN_RAMP_S = 1e-9
"""A pull's shortest fade time (a zero ramp switches at once)."""

TWO_PI = 2.0 * np.pi


@dataclass
class Program:
    """A lowered controller.

    Attributes:
        code: (I, 7) instructions.
        registers: number of registers.
        constants: register -> (n, 3) value, written once.
        points: canonical body points read (row of the runtime's point table).
        frames: roles whose body frame is used.
        springs: the joint roles of each spring instruction.
        slots: each force slot: (body point it acts at, element type that made it).
        sensors: sensor name -> (register, whether it is a vector).
        cycles: cycle element names (row of the phase table).
        machines: machine name -> its state names (row of the state table).
        sensor_end: first instruction after the sensors (a run to there only refreshes them).
        slot_elements: the element that made each force slot.
        spring_elements: the element that made each spring instruction.
    """

    code: np.ndarray
    registers: int
    constants: dict[int, np.ndarray]
    points: list[str]
    frames: list[str]
    springs: list[tuple[str, ...]]
    slots: list[tuple[str, str]]
    sensors: dict[str, tuple[int, bool]]
    cycles: list[str]
    machines: dict[str, list[str]]
    sensor_end: int
    slot_elements: list[str] = field(default_factory=list)
    spring_elements: list[str] = field(default_factory=list)


@dataclass
class _Memo:
    """The register of each operation computed so far, and the env keys each register reads."""

    registers: dict[tuple[int, ...], int] = field(default_factory=dict)
    needs: dict[int, frozenset[str]] = field(default_factory=dict)

    def forget(self, key: str) -> None:
        """Forget every value that reads env key `key` (its value just changed)."""
        for operation in [o for o, r in self.registers.items() if key in self.needs[r]]:
            del self.registers[operation]

    def forget_since(self, operations: set[tuple[int, ...]]) -> None:
        """Forget the values remembered since `operations` were (a block ended)."""
        for operation in [o for o in self.registers if o not in operations]:
            del self.registers[operation]


class _Lowerer:
    def __init__(self, compiled: CompiledController):
        self.compiled = compiled
        self.n = compiled.scale.n
        self.code: list[list[int]] = []
        self.registers = 0
        self.constants: dict[int, np.ndarray] = {}
        self.constant_keys: dict[tuple, int] = {}
        self.memo = _Memo()
        self.points: list[str] = list(HEADING_POINTS)
        self.frames: list[str] = []
        self.springs: list[tuple[str, ...]] = []
        self.slots: list[tuple[str, str]] = []
        self.slot_elements: list[str] = []
        self.spring_elements: list[str] = []
        self.sensors: dict[str, tuple[int, bool]] = {}
        self.cycles = [name for name, e in compiled.elements.items() if e.type == "cycle"]
        self.machines = {name: list(m.states) for name, m in compiled.machines.items()}
        self.owner = {element: name for name, m in compiled.machines.items() for element in m.owned}
        self.vector: dict[int, bool] = {}
        self.gravity = np.zeros(3)

    # ------------------------------------------------------------------ basics

    def new_register(self, vector: bool) -> int:
        """A fresh register holding a vector, or a scalar (only its first component is used)."""
        self.vector[self.registers] = vector
        self.registers += 1
        return self.registers - 1

    def emit(self, op: int, dst: int = 0, a: int = 0, b: int = 0, c: int = 0, d: int = 0, e: int = 0) -> int:
        self.code.append([op, dst, a, b, c, d, e])
        return dst

    def constant(self, array: np.ndarray, vector: bool) -> int:
        """The register of a constant (n, 3) array (one register per distinct value)."""
        array = np.ascontiguousarray(array, dtype=float)
        key = (vector, array.tobytes())
        if key not in self.constant_keys:
            register = self.new_register(vector)
            self.constants[register] = array
            self.constant_keys[key] = register
        return self.constant_keys[key]

    def scalar_constant(self, value: Any) -> int:
        """The register of a scalar constant: one number, or one per animal."""
        column = np.broadcast_to(np.asarray(value, dtype=float).reshape(-1, 1), (self.n, 1))
        return self.constant(np.broadcast_to(column, (self.n, 3)), vector=False)

    def vector_constant(self, value: Any) -> int:
        """The register of a vector constant: one (3,) vector, or one per animal (n, 3)."""
        return self.constant(np.broadcast_to(np.asarray(value, dtype=float), (self.n, 3)), vector=True)

    def typed_constant(self, value: np.ndarray, typ: Type) -> int:
        return self.vector_constant(value) if typ.kind == VECTOR else self.scalar_constant(value)

    def shared(
        self, needs: frozenset[str], vector: bool, op: int, a: int = 0, b: int = 0, c: int = 0, flags: int = 0
    ) -> int:
        """The register of `op(a, b, c)`: computed once, reused while still valid."""
        register = self.memo.registers.get((op, a, b, c))
        if register is None:
            register = self.emit(op, self.new_register(vector), a, b, c, 0, flags)
            self.memo.registers[(op, a, b, c)] = register
            self.memo.needs[register] = needs
        return register

    def op(self, op: int, a: int = 0, b: int = 0, c: int = 0) -> int:
        """An operation on registers (shared with an identical earlier one).

        Elementwise ops get flags telling which of the result and operands are vectors
        (`ops.VECTOR_RESULT` and the next flags); the others read only their register operands.
        """
        operands = (a, b, c)[: OPERANDS.get(op, 3)]
        needs = frozenset().union(*(self.memo.needs.get(r, frozenset()) for r in operands))
        if op in VECTOR_RESULTS:
            vector, flags = VECTOR_RESULTS[op], 0
        else:
            kinds = [self.vector[r] for r in operands]
            vector = any(kinds[1:]) if op == SELECT else any(kinds)
            flags = vector | sum(kind << (index + 1) for index, kind in enumerate(kinds))
        return self.shared(needs, vector, op, a, b, c, flags)

    def read(self, key: str, op: int, a: int = 0, b: int = 0) -> int:
        """A register holding an env read (a point, a phase...)."""
        return self.shared(frozenset([key]), op in (POINT, VELOCITY, GROUND_NORMAL), op, a, b)

    def point(self, point: str) -> int:
        return self.read(f"point:{point}", POINT, self.point_row(point))

    def velocity(self, point: str) -> int:
        return self.read(f"velocity:{point}", VELOCITY, self.point_row(point))

    def point_row(self, point: str) -> int:
        if point not in self.points:
            self.points.append(point)
        return self.points.index(point)

    # ------------------------------------------------------------------ expressions

    def value(self, compiled: Compiled) -> int:
        """The register of a compiled DSL value."""
        if compiled.constant is not None:
            return self.typed_constant(compiled.constant, compiled.type)
        assert compiled.expr is not None, "a compiled value without a constant keeps its expression"
        return self.expr(compiled.expr, {})

    def expr(self, expr: Expr, lowered: dict[int, int]) -> int:
        """The register of an expression node; `lowered` holds the nodes of this value already
        lowered, by `id`: a parameter used twice is one shared node (`p2: p1 + p1`), lowered once
        rather than once per path through it (2^n times down a chain of n)."""
        if id(expr) not in lowered:
            lowered[id(expr)] = self._lower_node(expr, lowered)
        return lowered[id(expr)]

    def _lower_node(self, expr: Expr, lowered: dict[int, int]) -> int:
        if not expr.needs:
            constant = compile_expr(expr, self.compiled.scale).constant
            assert constant is not None, "an expression that needs nothing compiles to a constant"
            return self.typed_constant(constant, expr.type)
        op = expr.op
        if op == "var":
            return self.variable(str(expr.value))
        if op == "interp":
            return self.table(expr, lowered)
        args = [self.expr(arg, lowered) for arg in expr.args]
        if op in BINARY_OPS:
            return self.op(BINARY_OPS[op], *args)
        if op in REDUCING_OPS:
            return self.reduce(REDUCING_OPS[op], args)
        if op == "neg":
            return self.op(NEG, args[0])
        if op == "not":
            return self.op(NOT, args[0])
        if op == "vec":
            return self.op(VEC, *args)
        if op == "comp":
            return self.op(COMP, args[0], int(expr.value))
        if op == "if":
            return self.op(SELECT, *args)
        if op == "cmp":
            pairs = [self.op(COMPARE_OPS[o], left, right) for o, left, right in zip(expr.value, args, args[1:])]
            return self.reduce(AND, pairs)
        if op == "call":
            return self.call(str(expr.value), args)
        raise ValueError(f"the kernel cannot run expression node {op!r}")

    def table(self, expr: Expr, lowered: dict[int, int]) -> int:
        """A table read (`interp`): its breakpoints and its values in two blocks of consecutive
        constant registers, one per point (one block per distinct list), searched by `INTERP`."""
        vector, blocks = expr.type.kind == VECTOR, list[int]()
        for rows, kind in zip(table_rows(expr, self.compiled.scale), (False, vector)):
            key = ("block", kind, rows.tobytes())
            if key not in self.constant_keys:
                self.constant_keys[key] = self.registers
                self.constants |= {self.new_register(kind): row for row in rows}
            blocks.append(self.constant_keys[key])
        x = self.expr(expr.args[0], lowered)
        return self.shared(self.memo.needs.get(x, frozenset()), vector, INTERP, x, blocks[0], blocks[1], expr.value)

    def reduce(self, op: int, args: list[int]) -> int:
        result = args[0]
        for arg in args[1:]:
            result = self.op(op, result, arg)
        return result

    def call(self, name: str, args: list[int]) -> int:
        if name == "froude_speed":
            reference = units.STANDARD_GRAVITY * np.asarray(self.compiled.scale.hp, dtype=float)
            return self.op(SQRT, self.op(MUL, args[0], self.scalar_constant(reference)))
        if name in REDUCING_OPS:
            return self.reduce(REDUCING_OPS[name], args)
        return self.op(FUNCTION_OPS[name], *args)

    def variable(self, key: str) -> int:
        kind, _, rest = key.partition(":")
        if kind == "point":
            return self.point(rest)
        if kind == "sensor":
            register = self.sensors[rest][0]
            self.memo.needs[register] = frozenset([key])
            return register
        if kind == "phase":
            return self.read(key, PHASE, self.cycles.index(rest))
        if kind == "contact":
            return self.read(key, CONTACT, LEGS.index(rest))
        if kind == "time_in_state":
            return self.read(key, TIS, list(self.machines).index(rest))
        if key == TIME_VARIABLE:
            return self.read(key, TIME)
        raise ValueError(f"the kernel does not provide {key!r}")

    def changed(self, key: str) -> None:
        """State behind env key `key` changed: forget what was computed from it."""
        self.memo.forget(key)

    # ------------------------------------------------------------------ sensors, cycles, machines

    def sensor_registers(self) -> None:
        """Give every sensor its register first, so any expression may read any sensor."""
        for name, element in self.compiled.elements.items():
            if element.type == "sensor":
                vector = element.spec.kind != "height"
                self.sensors[name] = (self.new_register(vector), vector)

    def sensor(self, element: CompiledElement) -> None:
        spec: schema.Sensor = element.spec
        if spec.kind == "contact_normal":
            bits = sum(1 << LEGS.index(leg) for leg in (spec.feet or LEGS))
            raw = self.read(f"ground_normal:{bits}", GROUND_NORMAL, bits)
        else:
            at = spec.at
            assert at is not None, f"the element checks require `at` on a {spec.kind} sensor"
            if spec.kind == "balance":
                horizon = (
                    self.value(element.value("horizon"))
                    if ("horizon",) in element.values
                    else self.scalar_constant(1.0)
                )
                raw = self.op(ADD, self.vector_constant(self.gravity), self.op(DIV, self.velocity(at), horizon))
            elif spec.kind == "velocity":
                raw = self.velocity(at)
            else:
                raw = self.op(HEIGHT, self.point(at))
        register = self.sensors[element.name][0]
        self.emit(SMOOTH, register, raw, self.value(element.value("smoothing")), list(self.sensors).index(element.name))
        self.changed(f"sensor:{element.name}")

    def machine(self, name: str) -> None:
        machine = self.compiled.machines[name]
        states = self.machines[name]
        row = list(self.machines).index(name)
        switched = self.emit(ZERO, self.new_register(vector=False))
        for transition in machine.transitions:
            after = self.value(transition.after)
            when = self.value(transition.when) if transition.when is not None else self.scalar_constant(1.0)
            sources = sum(1 << states.index(s) for s in transition.sources)
            self.emit(TRANSITION, switched, after, when, row, states.index(transition.target), sources)
            self.changed(f"time_in_state:{name}")

    # ------------------------------------------------------------------ force elements

    def element(self, name: str, base: CompiledElement) -> None:
        machine = self.owner.get(name)
        if machine is None:
            if base.enabled:
                self.form(base, None)
            return
        row = list(self.machines).index(machine)
        for index, state in enumerate(self.machines[machine]):
            form = self.compiled.machines[machine].states[state].elements.get(name, base)
            if not form.enabled:
                continue
            mask = self.read(f"mask:{machine}:{state}", MASK, row, index)
            jump = len(self.code)
            self.emit(JUMP_IF_NONE, 0, mask)
            known = set(self.memo.registers)
            self.form(form, mask)
            self.memo.forget_since(known)
            self.code[jump][3] = len(self.code)

    def masked(self, register: int, mask: int | None) -> int:
        return register if mask is None else self.op(MUL, register, mask)

    def force(self, point: str, at: int, force: int, kind: str, negate: bool = False) -> None:
        """Apply a force (its opposite when `negate`) at a point, through a new slot."""
        self.slots.append((point, kind))
        self.emit(FORCE, len(self.slots) - 1, at, force, e=int(negate))

    def form(self, element: CompiledElement, mask: int | None) -> None:
        """Lower one form of an element, noting it as the maker of its force slots and springs."""
        slots, springs = len(self.slots), len(self.springs)
        self.lower_form(element, mask)
        self.slot_elements += [element.name] * (len(self.slots) - slots)
        self.spring_elements += [element.name] * (len(self.springs) - springs)

    def lower_form(self, element: CompiledElement, mask: int | None) -> None:
        spec = element.spec
        kind = element.type
        if kind == "spring":
            self.springs.append(tuple(spec.joints))
            stiffness = self.masked(self.value(element.value("stiffness")), mask)
            damping = self.masked(self.value(element.value("damping")), mask)
            self.emit(SPRING, len(self.springs) - 1, self.value(element.value("target")), stiffness, damping)
        elif kind == "segment":
            start, end = self.point(spec.from_), self.point(spec.to)
            if spec.direction is not None:
                direction = self.direction(element, spec.direction, start)
                force = self.op(MUL, direction, self.masked(self.value(element.value("strength")), mask))
                self.force(spec.to, end, force, kind)
                self.force(spec.from_, start, force, kind, negate=True)
            if spec.elastic is not None:
                self.elastic(element, mask, start, end)
        elif kind == "force_pair":
            at = self.point(spec.at)
            strength = self.masked(self.value(element.value("strength")), mask)
            force = self.op(MUL, self.direction(element, spec.direction, at), strength)
            self.force(spec.at, at, force, kind)
            for point in spec.reaction:
                weight = self.value(element.value("reaction", point))
                self.force(point, self.point(point), self.op(MUL, force, weight), kind, negate=True)
        elif kind == "pull":
            at = self.point(spec.at)
            gain = self.masked(self.pull_gain(element), mask)
            strength = self.op(MUL, self.value(element.value("strength")), gain)
            self.force(spec.at, at, self.op(MUL, self.direction(element, spec.direction, at), strength), kind)
        elif kind == "cycle":
            self.cycle(element, mask)

    def frame_vector(self, vector: int, frame: str) -> int:
        if frame == "world":
            return vector
        if frame == "heading":
            return self.op(HEADING, vector)
        if frame not in self.frames:
            self.frames.append(frame)
        return self.op(BODYROT, vector, self.frames.index(frame))

    def direction(self, element: CompiledElement, direction: schema.Direction, acting: int) -> int:
        if direction.vector is not None:
            vector = self.frame_vector(self.value(element.value("direction", "vector")), direction.frame)
        elif direction.toward is not None:
            vector = self.op(SUB, self.value(element.value("direction", "toward")), acting)
        else:
            assert direction.balance is not None, "the element checks require one of vector, toward or balance"
            horizon = self.value(element.value("direction", "horizon"))
            vector = self.op(
                ADD, self.vector_constant(self.gravity), self.op(DIV, self.velocity(direction.balance), horizon)
            )
        if direction.horizontal:
            vector = self.op(HORIZONTAL, vector)
        return self.op(NORMALIZE, vector)

    def elastic(self, element: CompiledElement, mask: int | None, start: int, end: int) -> None:
        spec = element.spec
        span = self.op(SUB, end, start)
        length, along = self.op(NORM, span), self.op(NORMALIZE, span)
        target = self.op(
            MUL, self.value(element.value("elastic", "rest_length")), self.value(element.value("elastic", "ratio"))
        )
        speed = self.op(DOT, self.op(SUB, self.velocity(spec.to), self.velocity(spec.from_)), along)
        stretch = self.op(MUL, self.value(element.value("elastic", "stiffness")), self.op(SUB, target, length))
        tension = self.op(SUB, stretch, self.op(MUL, self.value(element.value("elastic", "damping")), speed))
        force = self.op(MUL, along, self.masked(tension, mask))
        self.force(spec.to, end, force, "elastic")
        self.force(spec.from_, start, force, "elastic", negate=True)

    def pull_gain(self, element: CompiledElement) -> int:
        """0..1: how much of a pull acts now (fading in after start, out before stop)."""
        t = self.read(TIME_VARIABLE, TIME)
        zero, one = self.scalar_constant(0.0), self.scalar_constant(1.0)
        ramp = self.op(MAX, self.value(element.value("ramp")), self.scalar_constant(MIN_RAMP_S))
        gain = self.op(CLAMP, self.op(DIV, self.op(SUB, t, self.value(element.value("start"))), ramp), zero, one)
        if ("stop",) in element.values:
            fade = self.op(CLAMP, self.op(DIV, self.op(SUB, self.value(element.value("stop")), t), ramp), zero, one)
            gain = self.op(MIN, gain, fade)
        return gain

    def cycle(self, element: CompiledElement, mask: int | None) -> None:
        spec: schema.Cycle = element.spec
        axis = self.op(NORMALIZE, self.frame_vector(self.value(element.value("axis")), spec.frame))
        reference = self.frame_vector(self.value(element.value("reference")), spec.frame)
        reference = self.op(NORMALIZE, self.op(SUB, reference, self.op(MUL, axis, self.op(DOT, reference, axis))))
        across = self.op(CROSS, axis, reference)
        strength = self.masked(self.value(element.value("strength")), mask)
        phase = self.read(f"phase:{element.name}", PHASE, self.cycles.index(element.name))
        for point in spec.sites:
            turns = self.op(ADD, phase, self.value(element.value("sites", point)))
            angle = self.op(MUL, turns, self.scalar_constant(TWO_PI))
            direction = self.op(
                ADD, self.op(MUL, reference, self.op(COS, angle)), self.op(MUL, across, self.op(SIN, angle))
            )
            self.force(point, self.point(point), self.op(MUL, direction, strength), "cycle")

    # ------------------------------------------------------------------ the whole step

    def lower(self, gravity: np.ndarray) -> Program:
        self.gravity = np.asarray(gravity, dtype=float)
        self.sensor_registers()
        for element in self.compiled.elements.values():
            if element.type == "sensor":
                self.sensor(element)
        sensor_end = len(self.code)
        for name in self.cycles:
            self.emit(ADVANCE, 0, self.cycles.index(name), self.value(self.compiled.elements[name].value("period")))
            self.changed(f"phase:{name}")
        for name in self.compiled.machines:
            self.machine(name)
        for name, base in self.compiled.elements.items():
            if base.type != "sensor":
                self.element(name, base)
        code = np.array(self.code, dtype=np.int64).reshape(-1, CODE_WIDTH)
        return Program(
            code, self.registers, self.constants, self.points, self.frames, self.springs, self.slots,
            self.sensors, self.cycles, self.machines, sensor_end,
            slot_elements=self.slot_elements, spring_elements=self.spring_elements,
        )  # fmt: skip


def lower(compiled: CompiledController, gravity: np.ndarray) -> Program:
    """Lower a compiled controller to a kernel program (see the module docstring).

    Args:
        compiled: the controller compiled for its animals.
        gravity: the world's gravity vector (balance vectors add it), m/s².
    """
    return _Lowerer(compiled).lower(gravity)
