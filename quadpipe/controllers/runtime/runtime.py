"""The controller runtime: a compiled controller turned into forces, every physics step.

One `ControllerRuntime` drives every animal of a world at once. The controller is lowered
once to a kernel program (`quadpipe.controllers.runtime.lowering`), folded
(`quadpipe.controllers.runtime.folding`), and every step runs it in one call of the
compiled kernel (`quadpipe.controllers.runtime.kernel`), over all animals. Forces enter MuJoCo as Cartesian
forces through `data.xfrc_applied` (laid out [force, torque], the torque taken about the
body's centre of mass) for segments, pairs, pulls and cycles, and as joint torques through
`data.qfrc_applied` for the stiffness of angular springs. Their damping goes into the
model's `dof_damping`, which MuJoCo's Euler integrator applies implicitly: explicit damping
torques are unstable on small bones (a rat's toes), implicit damping never is. The runtime
therefore owns its model's `dof_damping` while it runs: it keeps the values it found when it
was built as its base, writes base + its damping at each step, and `release()` puts the base
back. That is the only change a runtime makes to its model; release one before building
another on the same model (`quadpipe.sim.simulation.Simulation` does, in one place).

Each step (between `mj_step1` and `mj_step2`, so positions and velocities are current):
1. foot contacts and heading frames are measured;
2. sensors update (with their low-pass smoothing), cycles advance their phase;
3. state machines fire their transitions (first that fires wins, per animal);
4. every force element adds its forces, in the form its machine's current state gives it.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import mujoco
import numba
import numpy as np

from quadpipe.anatomy.roles import FOOT_BONES, JOINT_AXES, LEGS, ROLES
from quadpipe.animals.library import mixed_carriage, repertoire_parameters, repertoire_place
from quadpipe.controllers.language.compiler import CompiledController, compile_controller
from quadpipe.controllers.language.entries import ParameterEntry
from quadpipe.controllers.language.load import load_controller
from quadpipe.controllers.language.loader import CONTROLLER_KIND, merge_controller
from quadpipe.controllers.runtime.allocation import allocate
from quadpipe.controllers.runtime.folding import fold
from quadpipe.controllers.runtime.kernel import (
    CODE_DTYPE,
    HEADING_MIN_NORM,
    INTEGER_ARRAYS,
    MUJOCO_ARRAYS,
    NO_FAULT,
    REAL_ARRAYS,
    TABLE_ROWS,
    WORLD_GEOM_GROUPS,
    program_array,
    run,
)
from quadpipe.controllers.runtime.lowering import HEADING_POINTS, Program, lower
from quadpipe.controllers.runtime.variation import StrideClock, Variation
from quadpipe.controllers.runtime.views import address_row, address_table, contact_row, data_field
from quadpipe.core import configs
from quadpipe.core.errors import Location, QuadpipeError
from quadpipe.quantities.units import scale_for_animals
from quadpipe.world.placement import Placement

UP = np.array([0.0, 0.0, 1.0])


def flat_ground(model: mujoco.MjModel) -> bool:
    """Whether every geom a ground ray may hit (`kernel.WORLD_GEOM_GROUPS`) is a plane of the world
    body, lying horizontal through z = 0 (the `flat` scene's floor): then MuJoCo's ray from a
    point straight down finds exactly the point's z (it computes `-z / -1`), or misses a point
    below the floor or beyond a finite plane, where the kernel's `_ground_height` answers z as
    well (so it casts no ray: the model's row of the address table says so)."""
    rayed = [g for g in range(model.ngeom) if 0 <= model.geom_group[g] < len(WORLD_GEOM_GROUPS)]
    return all(
        model.geom_type[g] == mujoco.mjtGeom.mjGEOM_PLANE
        and model.geom_bodyid[g] == 0
        and model.geom_pos[g, 2] == 0.0
        and tuple(model.geom_quat[g]) == (1.0, 0.0, 0.0, 0.0)
        for g in rayed
        if WORLD_GEOM_GROUPS[model.geom_group[g]]
    )


@functools.cache
def compiled_kernel() -> Callable[[int, int, bool], int]:
    """`kernel.run` compiled for the runtime's arguments (the table's address, the last
    instruction, whether to finish the step), called without numba's dispatcher, which types
    every argument on every call to choose a compilation (~0.35 µs a call: there is one)."""
    entry: Callable[[int, int, bool], int] = run.compile((numba.int64, numba.int64, numba.boolean))
    return entry


@dataclass
class AppliedForces:
    """The Cartesian forces of one step, for overlays and metrics.

    Attributes:
        bodies: body id of each force, (K,).
        points: world point where it acts, (K, 3).
        forces: the force, (K, 3), newtons.
        animals: index of the animal it acts on, (K,).
        kinds: element type that made it, per force.
    """

    bodies: np.ndarray
    points: np.ndarray
    forces: np.ndarray
    animals: np.ndarray
    kinds: list[str] = field(default_factory=list)


class ControllerRuntime:
    """Executes one compiled controller on every animal of a compiled world.

    The controller is lowered to a kernel program once (`quadpipe.controllers.runtime.lowering`); each step is
    then one call of `quadpipe.controllers.runtime.kernel.run` over the model's and data's own arrays.
    The model's `dof_damping` when the runtime is built is its base damping (see `release`).

    Args:
        compiled: the controller compiled for the placements' animals (same order).
        model: the compiled world.
        placements: the animals, in the order of `compiled.scale`.
        variation: seeded stride-to-stride variation of every cycle (`quadpipe.controllers.runtime.variation`);
            None: none, every stride alike.
        folded: run the program folded (`quadpipe.controllers.runtime.folding`: the same forces from
            fewer instructions) with its temporaries sharing registers
            (`quadpipe.controllers.runtime.allocation`); False runs it as lowered, to check or time them.
    """

    def __init__(
        self,
        compiled: CompiledController,
        model: mujoco.MjModel,
        placements: Sequence[Placement],
        variation: Variation | None = None,
        *,
        folded: bool = True,
    ):
        self.compiled, self.model, self.placements = compiled, model, list(placements)
        self.name = compiled.name
        self.n = len(placements)
        self.dt = model.opt.timestep
        self.gravity = np.array(model.opt.gravity)
        self._bodies = np.array([[model.body(f"{p.name}/{role}").id for role in ROLES] for p in placements])
        self._offsets = self._point_offsets()
        self._animal_of_body = np.full(model.nbody, -1)
        for index, row in enumerate(self._bodies):
            self._animal_of_body[row] = index
        lowered = lower(compiled, self.gravity)
        self.program = allocate(fold(lowered)) if folded else lowered
        registers = np.zeros((self.program.registers, self.n, 3))
        for register, value in self.program.constants.items():
            registers[register] = value
        arrays = (
            {"registers": registers, "timestep": np.array([self.dt])}
            | self._bind(self.program)
            | self._initial_state(self.program)
        )
        self._arrays = (
            {"code": program_array(self.program.code)}
            | {name: np.ascontiguousarray(arrays[name], np.int64) for name in INTEGER_ARRAYS}
            | {name: np.ascontiguousarray(arrays[name], np.float64) for name in REAL_ARRAYS}
        )
        self._registers = self._arrays["registers"]
        self._own_rows = (
            [address_row(self._arrays["code"], CODE_DTYPE)]
            + [address_row(self._arrays[name], np.int64) for name in INTEGER_ARRAYS]
            + [address_row(self._arrays[name], np.float64) for name in REAL_ARRAYS]
        )
        self._last: AppliedForces | None = None
        self.fault: str | None = None
        """The first non-finite force or spring value an element computed (None: none so far)."""
        self._length = len(self.program.code)
        self._kernel = compiled_kernel()
        self._flat_ground = flat_ground(model)  # for the address table, made at the first step
        self._table_for: mujoco.MjData | None = None
        self._table: np.ndarray  # set with `_table_for` by `_address_table`
        self._table_address = 0  # the address of `_table`
        self._contacts: tuple[np.ndarray, np.ndarray]  # set with `_table_for` by `_address_table`
        self._clock = (
            StrideClock(variation, len(self.program.cycles), self.n) if variation and variation.active else None
        )

    # ------------------------------------------------------------------ set-up

    def _point_offsets(self) -> dict[str, np.ndarray]:
        """Canonical point `role.anchor` -> offset in the role's body frame, (n, 3)."""
        offsets = {}
        for role in ROLES:
            vectors = np.array(
                [p.built.animal.skeleton[role].end - p.built.animal.skeleton[role].start for p in self.placements]
            )
            offsets[f"{role}.start"] = np.zeros((self.n, 3))
            offsets[f"{role}.end"] = vectors
            offsets[f"{role}.mid"] = vectors / 2.0
        return offsets

    def _body_of(self, point: str) -> np.ndarray:
        """(n,) body ids of the bone a canonical point lies on."""
        return self._bodies[:, ROLES.index(point.partition(".")[0])]

    def _bind(self, program: Program) -> dict[str, np.ndarray]:
        """The program's symbolic names bound to this model's ids (the kernel's tables)."""
        model = self.model
        leg_of_geom, animal_of_geom = np.full(model.ngeom, -1), np.full(model.ngeom, -1)
        for animal, row in enumerate(self._bodies):
            animal_of_geom[np.isin(model.geom_bodyid, row)] = animal
        for leg_index, leg in enumerate(LEGS):
            for placement in self.placements:
                for bone in FOOT_BONES[leg]:
                    body = model.body(f"{placement.name}/{bone}").id
                    start = model.body_geomadr[body]
                    leg_of_geom[start : start + model.body_geomnum[body]] = leg_index
        dofs, qpos, twist = self._spring_tables(program.springs)
        return {
            "point_body": np.array([self._body_of(p) for p in program.points], dtype=np.int64).reshape(-1, self.n),
            "point_offset": np.array([self._offsets[p] for p in program.points]).reshape(-1, self.n, 3),
            "frame_body": np.array([self._body_of(f"{role}.start") for role in program.frames], dtype=np.int64).reshape(
                -1, self.n
            ),
            "leg_of_geom": leg_of_geom.astype(np.int64),
            "animal_of_geom": animal_of_geom.astype(np.int64),
            "heading_points": np.array([program.points.index(p) for p in HEADING_POINTS], dtype=np.int64),
            "spring_start": np.cumsum([0] + [len(rows) for rows in dofs]).astype(np.int64),
            "spring_dof": np.concatenate(dofs + [np.zeros((0, self.n), np.int64)]).astype(np.int64),
            "spring_qpos": np.concatenate(qpos + [np.zeros((0, self.n), np.int64)]).astype(np.int64),
            "spring_twist": np.concatenate(twist + [np.zeros((0, self.n), bool)]).astype(np.bool_),
            "slot_body": np.array([self._body_of(point) for point, _ in program.slots], dtype=np.int64).reshape(
                -1, self.n
            ),
            "body_root": model.body_rootid.astype(np.int64),
            "base_damping": model.dof_damping.copy(),
        }

    def _spring_tables(self, springs: Sequence[tuple[str, ...]]) -> tuple[list[np.ndarray], ...]:
        """Per spring: (J, n) dof addresses, qpos addresses, and whether each is a twist.

        A spring's joints are roles (every axis of the joint) or `role.axis` (that axis only).
        """
        dofs, qpos, twist = [], [], []
        for joints in springs:
            rows_d, rows_q, rows_t = [], [], []
            for joint in joints:
                role, _, axis = joint.partition(".")
                for suffix in [JOINT_AXES[axis]] if axis else JOINT_AXES.values():
                    ids = [
                        mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_JOINT, f"{p.name}/{role}{suffix}")
                        for p in self.placements
                    ]
                    if min(ids) >= 0:
                        rows_d.append(self.model.jnt_dofadr[ids])
                        rows_q.append(self.model.jnt_qposadr[ids])
                        rows_t.append(np.full(self.n, suffix == ""))
            dofs.append(np.array(rows_d, dtype=np.int64).reshape(-1, self.n))
            qpos.append(np.array(rows_q, dtype=np.int64).reshape(-1, self.n))
            twist.append(np.array(rows_t, dtype=bool).reshape(-1, self.n))
        return dofs, qpos, twist

    def _initial_state(self, program: Program) -> dict[str, np.ndarray]:
        """The arrays the kernel keeps between steps, at the start."""
        machines = self.compiled.machines
        return {
            "phase": np.zeros((len(program.cycles), self.n)),
            "state": np.array(
                [[names.index(machines[m].initial)] * self.n for m, names in program.machines.items()], dtype=np.int64
            ).reshape(-1, self.n),
            "time_in_state": np.zeros((len(program.machines), self.n)),
            "sensor_ready": np.zeros(len(program.sensors), dtype=np.bool_),
            "damping": np.zeros(self.model.nv),
            "contact": np.zeros((self.n, len(LEGS))),
            "normals": np.zeros((self.n, len(LEGS), 3)),
            "heading": np.zeros((self.n, 3, 3)),
            "slot_point": np.zeros((len(program.slots), self.n, 3)),
            "slot_force": np.zeros((len(program.slots), self.n, 3)),
        }

    # ------------------------------------------------------------------ geometry (overlays, goals)

    def point(self, data: mujoco.MjData, point: str) -> np.ndarray:
        """World position of a canonical body point for every animal, (n, 3)."""
        bodies = self._body_of(point)
        rotations = data.xmat[bodies].reshape(-1, 3, 3)
        return data.xpos[bodies] + np.einsum("nij,nj->ni", rotations, self._offsets[point])

    def point_velocity(self, data: mujoco.MjData, point: str) -> np.ndarray:
        """World linear velocity of a canonical body point, (n, 3)."""
        return self._velocity_at(data, self._body_of(point), self.point(data, point))

    def _velocity_at(self, data: mujoco.MjData, bodies: np.ndarray, points: np.ndarray) -> np.ndarray:
        """Linear velocity of world points fixed to bodies (from MuJoCo's com-based cvel)."""
        roots = data.subtree_com[self.model.body_rootid[bodies]]
        angular, linear = data.cvel[bodies, :3], data.cvel[bodies, 3:]
        return linear + np.cross(angular, points - roots)

    def heading_frames(self, data: mujoco.MjData) -> np.ndarray:
        """(n, 3, 3) rotations from each animal's heading frame to the world.

        The heading's x is the horizontal direction from pelvis to thorax, z is up.
        """
        forward = self.point(data, "thorax.start") - self.point(data, "pelvis.start")
        forward[:, 2] = 0.0
        norm = np.linalg.norm(forward, axis=1, keepdims=True)
        forward = np.where(norm > HEADING_MIN_NORM, forward / np.maximum(norm, 1e-12), np.array([1.0, 0.0, 0.0]))
        left = np.cross(UP, forward)
        return np.stack([forward, left, np.broadcast_to(UP, forward.shape)], axis=-1)

    # ------------------------------------------------------------------ step

    def release(self) -> None:
        """Give the model back as this runtime found it: its `dof_damping` set to the base values.

        A released runtime may still be read (`last`, states, sensors) and adopted from; stepping
        it again writes its damping again.
        """
        self.model.dof_damping[:] = self._arrays["base_damping"]

    def apply(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """Add this step's forces to `data.xfrc_applied` and `data.qfrc_applied`.

        With a variation, the cycles' phase advance of this step is then scaled by its stride's
        factor (`StrideClock.advance`); the step's own forces saw the unscaled advance, a
        difference of variation x dt / period: millionths of a cycle.
        """
        if self._clock is None and self._table_for is data:  # the common case, without `_run`'s Python
            fault = self._kernel(self._table_address, self._length, True)
            if fault != NO_FAULT and self.fault is None:
                self.fault = self._describe_fault(fault)
        elif self._clock is None:
            self._run(data, self._length, True)
        else:
            phase = self._arrays["phase"]
            before = phase.copy()
            self._run(data, self._length, True)
            self._clock.advance(before, phase)
        self._last = None

    def _run(self, data: mujoco.MjData, last: int, finish: bool) -> None:
        """Run the program's instructions up to `last` on the current state (see `kernel.run`)."""
        table = self._table_address if self._table_for is data else self._address_table(data)
        fault = self._kernel(table, last, finish)
        if fault != NO_FAULT and self.fault is None:
            self.fault = self._describe_fault(fault)

    def _describe_fault(self, fault: int) -> str:
        """Say which element computed a non-finite value (`fault` as `kernel.run` returns it)."""
        program = self.program
        if fault < len(program.slots):
            element, what = program.slot_elements[fault], f"a force at {program.slots[fault][0]}"
        else:
            element, what = program.spring_elements[fault - len(program.slots)], "a spring target, stiffness or damping"
        return f"element {element!r} of {self.name} computed {what} that is NaN or infinite"

    @staticmethod
    def _contact_arrays(data: mujoco.MjData) -> tuple[np.ndarray, np.ndarray]:
        """The geoms and frames of every contact `data` can hold: strided views into MuJoCo's
        contact structs, as many rows as the arena holds contacts, of which the kernel reads
        the first `ncon` (through their rows of the address table, `kernel.contact_row`).

        MuJoCo keeps its contacts at the start of the data's arena, so these views stay valid
        for the data's lifetime: made once per data (`data.contact` makes its views anew on
        every read, ~2 µs a step), they are no argument of the kernel's call (numba converts
        each array argument on every call).
        """
        contacts = data.contact
        rows = data.narena // contacts.geom.strides[0]

        def every_row(view: np.ndarray) -> np.ndarray:
            return np.lib.stride_tricks.as_strided(view, (rows, view.shape[1]), view.strides)

        return every_row(contacts.geom), every_row(contacts.frame)

    def _address_table(self, data: mujoco.MjData) -> int:
        """The kernel's address table (`kernel.address_table`) for `data`: this runtime's arrays,
        then `data`'s and the model's, and `data`'s contacts (`_contacts`). Their addresses stay
        the same for the data's lifetime: the runtime keeps the table for the data it was last
        run on (`_table_for`). Returns the table's address, as the kernel takes it."""
        self._contacts = self._contact_arrays(data)
        mujoco_arrays = [getattr(data, name) for name in MUJOCO_ARRAYS[:-1]] + [self.model.dof_damping]
        self._table = address_table(
            self._own_rows
            + [address_row(array, np.float64) for array in mujoco_arrays]
            + [contact_row(view) for view in self._contacts]
            + [
                (self.model._address, int(self._flat_ground), 0, 0),
                (data._address, data_field(data, "time", np.float64), data_field(data, "ncon", np.int32), 0),
            ]
        )
        assert len(self._table) == TABLE_ROWS, "the runtime's table rows are the kernel's"
        self._table_address = self._table.ctypes.data
        self._table_for = data
        return self._table_address

    @property
    def last(self) -> AppliedForces:
        """The Cartesian forces of the last step (for overlays and metrics)."""
        if self._last is None:
            slots = self.program.slots
            bodies = self._arrays["slot_body"].reshape(-1)
            self._last = AppliedForces(
                bodies,
                self._arrays["slot_point"].reshape(-1, 3).copy(),
                self._arrays["slot_force"].reshape(-1, 3).copy(),
                self._animal_of_body[bodies],
                [kind for _, kind in slots for _ in range(self.n)],
            )
        return self._last

    @last.setter
    def last(self, forces: AppliedForces) -> None:
        self._last = forces

    def sensor_values(self, data: mujoco.MjData) -> dict[str, np.ndarray]:
        """Every sensor's current (smoothed) value: (n, 3) vectors, (n,) scalars.

        Before the first step, the sensors are measured now (and that value starts their
        smoothing).
        """
        if not self._arrays["sensor_ready"].all():
            self._run(data, self.program.sensor_end, finish=False)
        registers = self._registers
        return {
            name: registers[r].copy() if vector else registers[r, :, 0].copy()
            for name, (r, vector) in self.program.sensors.items()
        }

    def frame_values(self, data: mujoco.MjData) -> dict[str, np.ndarray]:
        """Values recorded once per frame into the clip, per animal: every sensor
        (`<sensor>:<animal>`), the net controller force (`controller_force:<animal>`, N) and
        the power of the controller's forces (`controller_power:<animal>`, W: sum of force x
        velocity of the point it acts on, at the last step)."""
        values = {}
        forces = self.last
        velocities = self._velocity_at(data, forces.bodies, forces.points) if len(forces.bodies) else np.zeros((0, 3))
        power = np.einsum("ki,ki->k", forces.forces, velocities)
        sensors = self.sensor_values(data)
        for index, placement in enumerate(self.placements):
            mine = forces.animals == index
            values[f"controller_force:{placement.name}"] = forces.forces[mine].sum(axis=0)
            values[f"controller_power:{placement.name}"] = np.array(power[mine].sum())
            for name, value in sensors.items():
                values[f"{name}:{placement.name}"] = value[index]
        return values

    def adopt(self, previous: ControllerRuntime) -> None:
        """Take over the running state of the runtime this one replaces (a hot reload).

        Cycle phases, machine states (with their time in state) and smoothed sensor values are
        kept for every cycle, machine, state and sensor this controller still has, so a
        reloaded walk keeps its footfalls.
        """
        if previous.n != self.n:
            return
        old, new = previous.program, self.program
        for row, name in enumerate(old.cycles):
            if name in new.cycles:
                self._arrays["phase"][new.cycles.index(name)] = previous._arrays["phase"][row]
        for row, (machine, old_names) in enumerate(old.machines.items()):
            names = new.machines.get(machine)
            if names is None:
                continue
            mine = list(new.machines).index(machine)
            for animal, index in enumerate(previous._arrays["state"][row]):
                if old_names[index] in names:
                    self._arrays["state"][mine, animal] = names.index(old_names[index])
                    self._arrays["time_in_state"][mine, animal] = previous._arrays["time_in_state"][row, animal]
        for row, name in enumerate(old.sensors):
            if name in new.sensors and previous._arrays["sensor_ready"][row]:
                self._registers[new.sensors[name][0]] = previous._registers[old.sensors[name][0]]
                self._arrays["sensor_ready"][list(new.sensors).index(name)] = True

    def force_state(self, machine: str, state: str) -> None:
        """Put every animal's `machine` in `state`, its time in state back to 0.

        Raises:
            KeyError: no such machine or state.
        """
        names = self.program.machines[machine]
        if state not in names:
            raise KeyError(state)
        row = list(self.program.machines).index(machine)
        self._arrays["state"][row] = names.index(state)
        self._arrays["time_in_state"][row] = 0.0

    def state_of(self, machine: str) -> list[str]:
        """The current state of a machine, per animal."""
        names = self.program.machines[machine]
        return [names[i] for i in self._arrays["state"][list(self.program.machines).index(machine)]]


def compile_for(
    controller: str,
    placements: Sequence[Placement],
    parameters: Mapping[str, Any] | None = None,
    *,
    scene_parameters: Mapping[str, Any] | None = None,
    places: Mapping[str, Location] | None = None,
) -> tuple[CompiledController, tuple[str, ...]]:
    """Load a controller by name or path and compile it for the placed animals.

    Args:
        controller: a built-in controller name or a YAML path.
        placements: the animals it drives.
        parameters: parameter overrides (values as written in YAML); a name the controller
            does not declare is an error.
        scene_parameters: values a scene offers (its goals, a direction's path); only those
            the controller declares are used (`_scene_slots`), and `parameters` win over them.
        places: where each of `parameters` was written (a batch plan's line), for messages.

    The animals' species offer their gait repertoire the same way (`repertoire_parameters`:
    the Froude numbers of their gaits, the gallop's sequence), under the scene's values.

    Returns:
        the compiled controller (bind it with `ControllerRuntime`), and the files it was read
        from (the requested one first), for a caller that watches them.

    Raises:
        QuadpipeError: the files do not validate, or an override does not fit them;
            `mixed-repertoires` when the animals' species offer different values of a
            parameter the controller declares and the caller does not set.
    """
    entries = _declared_entries(controller)
    given = dict(parameters or {})
    species, species_places = _species_offers(placements, set(entries) - set(given))
    slots = _scene_slots(entries)
    offered = species | {name: value for name, value in (scene_parameters or {}).items() if name in slots}
    overrides = offered | given
    where = {**species_places, **(places or {})} or None
    spec = load_controller(controller, parameters=overrides or None, places=where)
    scale = scale_for_animals([p.built.animal for p in placements])
    return compile_controller(spec, scale), spec.sources


def _scene_slots(entries: Mapping[str, ParameterEntry]) -> set[str]:
    """The declared parameters a scene may set: all but those a controller file derives where
    the file it extends wrote a point (`direct`'s `goal: path_goal`, over `locomotion`'s
    `goal: [20 HP, 0, 0]`): a directed animal heads along its path, whatever goal the scene
    names for the others."""
    return {name for name, entry in entries.items() if not _derives_a_point(entry)}


def _declared_entries(controller: str) -> dict[str, ParameterEntry]:
    """The parameters (and tunables) a controller declares, its `extends` chain included, read
    without analysing it: what it can be offered before it is loaded once with its values.
    Empty when its files do not read (loading it then says why)."""
    try:
        merged = merge_controller(configs.find_config(CONTROLLER_KIND, controller), issues=[])
    except QuadpipeError:
        return {}
    return {} if merged is None else dict(merged.parameters)


def _derives_a_point(entry: ParameterEntry) -> bool:
    """Whether a parameter entry is an expression over the point its base file wrote out."""
    base = entry.replaces
    return isinstance(entry.value, str) and base is not None and isinstance(base.value, list)


def _species_offers(placements: Sequence[Placement], declared: set[str]) -> tuple[dict[str, str], dict[str, Location]]:
    """The repertoire parameters the animals' species offer among `declared`, and where each
    was written (the animal config's `gaits:`). A carriage parameter the species disagree on
    (`mixed_carriage`) is not offered: the controller keeps its own value.

    Raises:
        QuadpipeError: `mixed-repertoires` when two species offer different values of one.
    """
    values: dict[str, str] = {}
    places: dict[str, Location] = {}
    offered = declared - mixed_carriage([placement.built.animal for placement in placements])
    for placement in placements:
        animal = placement.built.animal
        for name, value in repertoire_parameters(animal).items():
            if name not in offered:
                continue
            if values.setdefault(name, value) != value:
                raise QuadpipeError.single(
                    "mixed-repertoires",
                    f"the animals' species set {name} to {values[name]} and {value} ({animal.name}); "
                    "one controller runs them all",
                    where=repertoire_place(animal, name),
                    hint=f"set it for all of them (--set {name}=VALUE), or run each species in its own scene",
                )
            place = repertoire_place(animal, name)
            if place is not None:
                places[name] = place
    return values, places
