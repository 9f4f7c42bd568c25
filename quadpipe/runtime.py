"""The controller runtime: a compiled controller turned into forces, every physics step.

One `ControllerRuntime` drives every animal of a world at once: each value is an array over
animals, and each element's forces are computed for all animals in one go. Forces enter
MuJoCo as Cartesian forces through `data.xfrc_applied` (laid out [force, torque], the torque
taken about the body's centre of mass) for segments, pairs, pulls and cycles, and as joint
torques through `data.qfrc_applied` for the stiffness of angular springs. Their damping goes
into the model's `dof_damping`, which MuJoCo's Euler integrator applies implicitly: explicit
damping torques are unstable on small bones (a rat's toes), implicit damping never is. The
runtime therefore owns its model's `dof_damping` (base values restored and added to each step).

Each step (between `mj_step1` and `mj_step2`, so positions and velocities are current):
1. the env is refreshed: time, heading frames, foot contacts; body points, sensors and
   other keys are computed on first use (`_StepEnv`);
2. sensors update (with their low-pass smoothing), cycles advance their phase;
3. state machines fire their transitions (first that fires wins, per animal);
4. every force element adds its forces, in the form its machine's current state gives it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

import mujoco
import numpy as np

from quadpipe import roles as R
from quadpipe.controller_dsl import expressions as X
from quadpipe.controller_dsl import schema as S
from quadpipe.controller_dsl.compile import CompiledController, CompiledElement, compile_controller
from quadpipe.controller_dsl.semantics import load_controller
from quadpipe.controller_dsl.units import scale_for_animals
from quadpipe.recording import FOOT_BONES
from quadpipe.world import Placement

WORLD_GEOM_GROUPS = np.array([1, 0, 0, 0, 0, 0], dtype=np.uint8)
"""Geom groups a ground ray may hit: group 0 only (terrain and props; bones are in
`quadpipe.model.ANIMAL_GEOM_GROUP`)."""

UP = np.array([0.0, 0.0, 1.0])


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


class _StepEnv(dict):
    """The expression env of one step: keys are computed the first time they are read."""

    def __init__(self, runtime: "ControllerRuntime", data: mujoco.MjData):
        super().__init__()
        self.runtime, self.data = runtime, data

    def __missing__(self, key: str) -> np.ndarray:
        value = self.runtime._compute(key, self)
        self[key] = value
        return value


class ControllerRuntime:
    """Executes one compiled controller on every animal of a compiled world.

    Args:
        compiled: the controller compiled for the placements' animals (same order).
        model: the compiled world.
        placements: the animals, in the order of `compiled.scale`.
    """

    def __init__(self, compiled: CompiledController, model: mujoco.MjModel, placements: Sequence[Placement]):
        self.compiled, self.model, self.placements = compiled, model, list(placements)
        self.name = compiled.name
        self.n = len(placements)
        self.dt = model.opt.timestep
        self.gravity = np.array(model.opt.gravity)
        self._bodies = np.array([[model.body(f"{p.name}/{role}").id for role in R.ROLES] for p in placements])
        self._offsets = self._point_offsets()
        self._point_index = {point: index for index, point in enumerate(self._offsets)}
        self._point_bodies = np.stack(
            [self._bodies[:, R.ROLES.index(point.partition(".")[0])] for point in self._offsets], axis=1
        )
        self._point_offsets = np.stack(list(self._offsets.values()), axis=1)
        self._feet = self._foot_geoms()
        self._animal_of_geom = np.full(model.ngeom, -1)
        self._leg_of_geom = np.full(model.ngeom, -1)
        for leg_index, leg in enumerate(R.LEGS):
            for animal, geoms in enumerate(self._feet[leg]):
                self._leg_of_geom[geoms] = leg_index
        for animal, row in enumerate(self._bodies):
            self._animal_of_geom[np.isin(model.geom_bodyid, row)] = animal
        self._animal_of_body = np.full(model.nbody, -1)
        for index, row in enumerate(self._bodies):
            self._animal_of_body[row] = index
        self._sensors = {name: e for name, e in compiled_sensors(compiled).items()}
        self._smoothed: dict[str, np.ndarray] = {}
        self._phase = {name: np.zeros(self.n) for name, e in compiled.elements.items() if e.type == "cycle"}
        self._state = {name: np.zeros(self.n, dtype=int) for name in compiled.machines}
        self._state_names = {name: list(m.states) for name, m in compiled.machines.items()}
        for name, machine in compiled.machines.items():
            self._state[name][:] = self._state_names[name].index(machine.initial)
        self._time_in_state = {name: np.zeros(self.n) for name in compiled.machines}
        self._owner = {element: name for name, m in compiled.machines.items() for element in m.owned}
        self._state_masks: dict[str, list[tuple[str, np.ndarray]]] = {}
        self._dofs = {}
        self._base_damping = model.dof_damping.copy()
        self._damping = np.zeros(model.nv)
        self.last = AppliedForces(np.zeros(0, int), np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, int))

    # ------------------------------------------------------------------ set-up

    def _point_offsets(self) -> dict[str, np.ndarray]:
        """Canonical point `role.anchor` -> offset in the role's body frame, (n, 3)."""
        offsets = {}
        for role in R.ROLES:
            vectors = np.array([p.built.animal.skeleton[role].end - p.built.animal.skeleton[role].start for p in self.placements])
            offsets[f"{role}.start"] = np.zeros((self.n, 3))
            offsets[f"{role}.end"] = vectors
            offsets[f"{role}.mid"] = vectors / 2.0
        return offsets

    def _foot_geoms(self) -> dict[str, np.ndarray]:
        """Leg -> (n, G) geom ids of its foot bones."""
        feet = {}
        for leg in R.LEGS:
            rows = []
            for placement in self.placements:
                geoms = []
                for bone in FOOT_BONES[leg]:
                    body = self.model.body(f"{placement.name}/{bone}").id
                    start = self.model.body_geomadr[body]
                    geoms.extend(range(start, start + self.model.body_geomnum[body]))
                rows.append(geoms)
            feet[leg] = np.array(rows)
        return feet

    def _joint_dofs(self, roles: Sequence[str]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(n, J) dof addresses, qpos addresses, and whether each is a twist, for roles' hinges."""
        key = tuple(roles)
        if key not in self._dofs:
            dofs, qpos, twist = [], [], []
            for placement in self.placements:
                row_d, row_q, row_t = [], [], []
                for role in roles:
                    for suffix in ("", "_swing1", "_swing2"):
                        name = f"{placement.name}/{role}{suffix}"
                        joint = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_JOINT, name)
                        if joint >= 0:
                            row_d.append(self.model.jnt_dofadr[joint])
                            row_q.append(self.model.jnt_qposadr[joint])
                            row_t.append(suffix == "")
                dofs.append(row_d), qpos.append(row_q), twist.append(row_t)
            self._dofs[key] = (np.array(dofs), np.array(qpos), np.array(twist))
        return self._dofs[key]

    # ------------------------------------------------------------------ env

    def _compute(self, key: str, env: _StepEnv) -> np.ndarray:
        kind, _, rest = key.partition(":")
        data = env.data
        if kind == "point":
            return env["all:points"][:, self._point_index[rest]]
        if kind == "velocity":
            return env["all:velocities"][:, self._point_index[rest]]
        if key == "all:points":
            return self._all_points(data)
        if key == "all:velocities":
            return self._all_velocities(data, env["all:points"])
        if key == X.HEADING_FRAME_KEY:
            return self.heading_frames(data)
        if kind == "contact":
            return self.foot_contact(data, rest)
        if kind == "sensor":
            return self._sensor(rest, env)
        if kind == "phase":
            return self._phase[rest] % 1.0
        if kind == "time_in_state":
            return self._time_in_state[rest]
        if key == "t":
            return np.full(self.n, data.time)
        raise KeyError(f"the runtime does not provide {key!r}")

    def _all_points(self, data: mujoco.MjData) -> np.ndarray:
        """World positions of every canonical point of every animal, (n, P, 3)."""
        bodies = self._point_bodies
        rotations = data.xmat[bodies].reshape(self.n, -1, 3, 3)
        return data.xpos[bodies] + np.einsum("npij,npj->npi", rotations, self._point_offsets)

    def _all_velocities(self, data: mujoco.MjData, points: np.ndarray) -> np.ndarray:
        """World linear velocities of every canonical point of every animal, (n, P, 3)."""
        bodies = self._point_bodies
        roots = data.subtree_com[self.model.body_rootid[bodies]]
        return data.cvel[bodies, 3:] + _cross(data.cvel[bodies, :3], points - roots)

    def point(self, data: mujoco.MjData, point: str) -> np.ndarray:
        """World position of a canonical body point for every animal, (n, 3)."""
        role = point.partition(".")[0]
        bodies = self._bodies[:, R.ROLES.index(role)]
        rotations = data.xmat[bodies].reshape(-1, 3, 3)
        return data.xpos[bodies] + np.einsum("nij,nj->ni", rotations, self._offsets[point])

    def point_velocity(self, data: mujoco.MjData, point: str) -> np.ndarray:
        """World linear velocity of a canonical body point, (n, 3)."""
        role = point.partition(".")[0]
        bodies = self._bodies[:, R.ROLES.index(role)]
        return self._velocity_at(data, bodies, self.point(data, point))

    def _velocity_at(self, data: mujoco.MjData, bodies: np.ndarray, points: np.ndarray) -> np.ndarray:
        """Linear velocity of world points fixed to bodies (from MuJoCo's com-based cvel)."""
        roots = data.subtree_com[self.model.body_rootid[bodies]]
        angular, linear = data.cvel[bodies, :3], data.cvel[bodies, 3:]
        return linear + _cross(angular, points - roots)

    def heading_frames(self, data: mujoco.MjData) -> np.ndarray:
        """(n, 3, 3) rotations from each animal's heading frame to the world.

        The heading's x is the horizontal direction from pelvis to thorax, z is up.
        """
        forward = self.point(data, "thorax.start") - self.point(data, "pelvis.start")
        forward[:, 2] = 0.0
        norm = np.linalg.norm(forward, axis=1, keepdims=True)
        forward = np.where(norm > 1e-9, forward / np.maximum(norm, 1e-12), np.array([1.0, 0.0, 0.0]))
        left = _cross(UP, forward)
        return np.stack([forward, left, np.broadcast_to(UP, forward.shape)], axis=-1)

    def _foot_contacts(self, data: mujoco.MjData) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Contacts between a foot and anything but its own animal: (animal, leg, normal up, count).

        Each row is one such contact; the normal points from the other geom into the foot.
        """
        g1, g2 = data.contact.geom1[: data.ncon], data.contact.geom2[: data.ncon]
        normals = data.contact.frame[: data.ncon, :3]
        rows = []
        for foot, other, sign in ((g1, g2, -1.0), (g2, g1, 1.0)):
            animal = self._animal_of_geom[foot]
            keep = (self._leg_of_geom[foot] >= 0) & (self._animal_of_geom[other] != animal)
            rows.append((animal[keep], self._leg_of_geom[foot][keep], sign * normals[keep]))
        animals, legs, ups = (np.concatenate(parts) for parts in zip(*rows))
        return animals, legs, ups, np.array(len(animals))

    def foot_contact(self, data: mujoco.MjData, leg: str) -> np.ndarray:
        """Whether each animal's foot `leg` touches anything but its own body, (n,) bool."""
        down = np.zeros(self.n, dtype=bool)
        if data.ncon:
            animals, legs, _, _ = self._foot_contacts(data)
            down[animals[legs == R.LEGS.index(leg)]] = True
        return down

    def _ground_normal(self, data: mujoco.MjData, legs: Sequence[str]) -> np.ndarray:
        """Mean contact normal under the given feet, pointing up from the ground; up if none."""
        normals = np.zeros((self.n, 3))
        if data.ncon:
            animals, feet, ups, _ = self._foot_contacts(data)
            chosen = np.isin(feet, [R.LEGS.index(leg) for leg in legs])
            np.add.at(normals, animals[chosen], ups[chosen])
        norm = np.linalg.norm(normals, axis=1, keepdims=True)
        return np.where(norm > 1e-9, normals / np.maximum(norm, 1e-12), UP)

    def _height(self, data: mujoco.MjData, points: np.ndarray) -> np.ndarray:
        """Height of points above the terrain or prop right below them."""
        heights = np.zeros(self.n)
        hit = np.zeros(1, dtype=np.int32)
        for animal, point in enumerate(points):
            distance = mujoco.mj_ray(self.model, data, point, -UP, WORLD_GEOM_GROUPS, 1, -1, hit)
            heights[animal] = distance if distance >= 0 else point[2]
        return heights

    def _sensor(self, name: str, env: _StepEnv) -> np.ndarray:
        element = self._sensors[name]
        spec: S.Sensor = element.spec
        data = env.data
        if spec.kind == "balance":
            horizon = element.value("horizon")(env) if ("horizon",) in element.values else 1.0
            raw = self.gravity + env[f"velocity:{spec.at}"] / np.reshape(horizon, (-1, 1))
        elif spec.kind == "velocity":
            raw = env[f"velocity:{spec.at}"]
        elif spec.kind == "height":
            raw = self._height(data, env[f"point:{spec.at}"])
        else:
            raw = self._ground_normal(data, spec.feet or R.LEGS)
        return self._smooth(name, raw, element.value("smoothing")(env))

    def _smooth(self, name: str, raw: np.ndarray, time_constant: np.ndarray) -> np.ndarray:
        previous = self._smoothed.get(name)
        if previous is None:
            value = raw
        else:
            weight = self.dt / (np.asarray(time_constant) + self.dt)
            value = previous + np.reshape(weight, (-1,) + (1,) * (raw.ndim - 1)) * (raw - previous)
        self._smoothed[name] = value
        return value

    # ------------------------------------------------------------------ step

    def apply(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """Add this step's forces to `data.xfrc_applied` and `data.qfrc_applied`."""
        env = _StepEnv(self, data)
        for name in self._sensors:
            env[f"sensor:{name}"] = self._sensor(name, env)
        self._advance_cycles(env)
        self._run_machines(env)
        batch = _ForceBatch()
        self._damping[:] = 0.0
        for name, base in self.compiled.elements.items():
            if base.type == "sensor":
                continue
            for element, mask in self._forms(name, base):
                self._add_element(element, mask, env, data, batch)
        self.last = batch.apply(data, self._bodies, self._animal_of_body)
        model.dof_damping[:] = self._base_damping + self._damping
        for name in self._time_in_state:
            self._time_in_state[name] += self.dt

    def _advance_cycles(self, env: _StepEnv) -> None:
        for name, phase in self._phase.items():
            period = self.compiled.elements[name].value("period")(env)
            phase += self.dt / np.maximum(period, 1e-9)

    def _run_machines(self, env: _StepEnv) -> None:
        for name, machine in self.compiled.machines.items():
            state, names = self._state[name], self._state_names[name]
            switched = np.zeros(self.n, dtype=bool)
            for transition in machine.transitions:
                sources = np.isin(state, [names.index(s) for s in transition.sources])
                ready = self._time_in_state[name] >= transition.after(env)
                fires = sources & ready & ~switched
                if transition.when is not None and fires.any():
                    fires &= np.asarray(transition.when(env), dtype=bool)
                if fires.any():
                    state[fires] = names.index(transition.target)
                    self._time_in_state[name][fires] = 0.0
                    switched |= fires
            env[f"time_in_state:{name}"] = self._time_in_state[name]
            self._state_masks[name] = [(state_name, state == index) for index, state_name in enumerate(names)]

    def _forms(self, name: str, base: CompiledElement) -> list[tuple[CompiledElement, np.ndarray]]:
        """The forms an element takes this step, each with the animals it applies to."""
        machine = self._owner.get(name)
        if machine is None:
            return [(base, np.ones(self.n, dtype=bool))] if base.enabled else []
        forms = []
        for index, (state_name, mask) in enumerate(self._state_masks[machine]):
            if not mask.any():
                continue
            form = self.compiled.machines[machine].states[state_name].elements.get(name, base)
            if form.enabled:
                forms.append((form, mask))
        return forms

    def frame_values(self, data: mujoco.MjData) -> dict[str, np.ndarray]:
        """Values recorded once per frame into the clip, per animal: every sensor
        (`<sensor>:<animal>`), the net controller force (`controller_force:<animal>`, N) and
        the power of the controller's forces (`controller_power:<animal>`, W: sum of force x
        velocity of the point it acts on, at the last step)."""
        values = {}
        forces = self.last
        velocities = self._velocity_at(data, forces.bodies, forces.points) if len(forces.bodies) else np.zeros((0, 3))
        power = np.einsum("ki,ki->k", forces.forces, velocities)
        env = _StepEnv(self, data)
        sensors = {name: self._smoothed[name] if name in self._smoothed else self._sensor(name, env) for name in self._sensors}
        for index, placement in enumerate(self.placements):
            mine = forces.animals == index
            values[f"controller_force:{placement.name}"] = forces.forces[mine].sum(axis=0)
            values[f"controller_power:{placement.name}"] = np.array(power[mine].sum())
            for name, value in sensors.items():
                values[f"{name}:{placement.name}"] = value[index]
        return values

    def adopt(self, previous: "ControllerRuntime") -> None:
        """Take over the running state of the runtime this one replaces (a hot reload).

        Cycle phases, machine states (with their time in state) and smoothed sensor values are
        kept for every cycle, machine, state and sensor this controller still has, so a
        reloaded walk keeps its footfalls.
        """
        if previous.n != self.n:
            return
        for name, phase in previous._phase.items():
            if name in self._phase:
                self._phase[name][:] = phase
        for machine, old_names in previous._state_names.items():
            names = self._state_names.get(machine)
            if names is None:
                continue
            for animal, index in enumerate(previous._state[machine]):
                if old_names[index] in names:
                    self._state[machine][animal] = names.index(old_names[index])
                    self._time_in_state[machine][animal] = previous._time_in_state[machine][animal]
        for name, value in previous._smoothed.items():
            if name in self._sensors:
                self._smoothed[name] = value

    def force_state(self, machine: str, state: str) -> None:
        """Put every animal's `machine` in `state`, its time in state back to 0.

        Raises:
            KeyError: no such machine or state.
        """
        names = self._state_names[machine]
        if state not in names:
            raise KeyError(state)
        self._state[machine][:] = names.index(state)
        self._time_in_state[machine][:] = 0.0

    def state_of(self, machine: str) -> list[str]:
        """The current state of a machine, per animal."""
        names = self._state_names[machine]
        return [names[i] for i in self._state[machine]]

    # ------------------------------------------------------------------ elements

    def _add_element(self, element: CompiledElement, mask: np.ndarray, env: _StepEnv, data: mujoco.MjData, batch: "_ForceBatch") -> None:
        spec = element.spec
        kind = element.type
        if kind == "spring":
            self._spring(element, mask, env, data)
        elif kind == "segment":
            start, end = env[f"point:{spec.from_}"], env[f"point:{spec.to}"]
            if spec.direction is not None:
                direction = self._direction(element, spec.direction, start, env)
                force = direction * _column(element.value("strength")(env) * mask)
                batch.add(self._body_of(spec.to), end, force, kind)
                batch.add(self._body_of(spec.from_), start, -force, kind)
            if spec.elastic is not None:
                self._elastic(element, mask, env, start, end, batch)
        elif kind == "force_pair":
            at = env[f"point:{spec.at}"]
            force = self._direction(element, spec.direction, at, env) * _column(element.value("strength")(env) * mask)
            batch.add(self._body_of(spec.at), at, force, kind)
            for point in spec.reaction:
                weight = element.value("reaction", point)(env)
                batch.add(self._body_of(point), env[f"point:{point}"], -force * _column(weight), kind)
        elif kind == "pull":
            at = env[f"point:{spec.at}"]
            gain = self._pull_gain(element, env) * mask
            force = self._direction(element, spec.direction, at, env) * _column(element.value("strength")(env) * gain)
            batch.add(self._body_of(spec.at), at, force, kind)
        elif kind == "cycle":
            self._cycle(element, mask, env, batch)

    def _body_of(self, point: str) -> np.ndarray:
        return self._point_bodies[:, self._point_index[point]]

    def _frame_vectors(self, vectors: np.ndarray, frame: str, env: _StepEnv) -> np.ndarray:
        """Vectors given in `frame` (heading, world or a role's body frame) in the world."""
        if frame == "world":
            return vectors
        if frame == "heading":
            return np.einsum("nij,nj->ni", env[X.HEADING_FRAME_KEY], vectors)
        bodies = self._bodies[:, R.ROLES.index(frame)]
        return np.einsum("nij,nj->ni", env.data.xmat[bodies].reshape(-1, 3, 3), vectors)

    def _direction(self, element: CompiledElement, direction: S.Direction, acting: np.ndarray, env: _StepEnv) -> np.ndarray:
        """Unit direction of a force, (n, 3); zero where it is undefined."""
        if direction.vector is not None:
            vector = self._frame_vectors(np.broadcast_to(element.value("direction", "vector")(env), (self.n, 3)), direction.frame, env)
        elif direction.toward is not None:
            vector = element.value("direction", "toward")(env) - acting
        else:
            horizon = element.value("direction", "horizon")(env)
            vector = self.gravity + env[f"velocity:{direction.balance}"] / _column(horizon)
        if direction.horizontal:
            vector = vector * np.array([1.0, 1.0, 0.0])
        return _unit(vector)

    def _elastic(self, element: CompiledElement, mask: np.ndarray, env: _StepEnv, start: np.ndarray, end: np.ndarray, batch: "_ForceBatch") -> None:
        spec = element.spec
        span = end - start
        length = np.linalg.norm(span, axis=1)
        along = _unit(span)
        target = element.value("elastic", "rest_length")(env) * element.value("elastic", "ratio")(env)
        speed = np.einsum("ni,ni->n", env[f"velocity:{spec.to}"] - env[f"velocity:{spec.from_}"], along)
        tension = element.value("elastic", "stiffness")(env) * (target - length) - element.value("elastic", "damping")(env) * speed
        force = along * _column(tension * mask)
        batch.add(self._body_of(spec.to), end, force, "elastic")
        batch.add(self._body_of(spec.from_), start, -force, "elastic")

    def _spring(self, element: CompiledElement, mask: np.ndarray, env: _StepEnv, data: mujoco.MjData) -> None:
        dofs, qpos, twist = self._joint_dofs(element.spec.joints)
        if dofs.size == 0:
            return
        target = np.where(twist, _column(element.value("target")(env)), 0.0)
        stiffness, damping = _column(element.value("stiffness")(env) * mask), _column(element.value("damping")(env) * mask)
        np.add.at(data.qfrc_applied, dofs, -stiffness * (data.qpos[qpos] - target))
        np.add.at(self._damping, dofs, np.broadcast_to(damping, dofs.shape))

    def _pull_gain(self, element: CompiledElement, env: _StepEnv) -> np.ndarray:
        """0..1: how much of a pull acts now (fading in after start, out before stop)."""
        t = env["t"]
        start, ramp = element.value("start")(env), np.maximum(element.value("ramp")(env), 1e-9)
        gain = np.clip((t - start) / ramp, 0.0, 1.0)
        if ("stop",) in element.values:
            gain = np.minimum(gain, np.clip((element.value("stop")(env) - t) / ramp, 0.0, 1.0))
        return gain

    def _cycle(self, element: CompiledElement, mask: np.ndarray, env: _StepEnv, batch: "_ForceBatch") -> None:
        spec: S.Cycle = element.spec
        axis = _unit(self._frame_vectors(np.broadcast_to(element.value("axis")(env), (self.n, 3)), spec.frame, env))
        reference = self._frame_vectors(np.broadcast_to(element.value("reference")(env), (self.n, 3)), spec.frame, env)
        reference = _unit(reference - axis * _column(np.einsum("ni,ni->n", reference, axis)))
        strength = element.value("strength")(env) * mask
        phase = self._phase[element.name]
        for point in spec.sites:
            angle = 2.0 * np.pi * (phase + element.value("sites", point)(env))
            direction = reference * _column(np.cos(angle)) + _cross(axis, reference) * _column(np.sin(angle))
            batch.add(self._body_of(point), env[f"point:{point}"], direction * _column(strength), "cycle")


class _ForceBatch:
    """Collects Cartesian forces during a step, then applies them all at once."""

    def __init__(self) -> None:
        self.bodies: list[np.ndarray] = []
        self.points: list[np.ndarray] = []
        self.forces: list[np.ndarray] = []
        self.kinds: list[str] = []

    def add(self, bodies: np.ndarray, points: np.ndarray, forces: np.ndarray, kind: str) -> None:
        self.bodies.append(bodies)
        self.points.append(points)
        self.forces.append(forces)
        self.kinds.extend([kind] * len(bodies))

    def apply(self, data: mujoco.MjData, animal_bodies: np.ndarray, animal_of_body: np.ndarray) -> AppliedForces:
        if not self.bodies:
            return AppliedForces(np.zeros(0, int), np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, int))
        bodies = np.concatenate(self.bodies)
        points, forces = np.concatenate(self.points), np.concatenate(self.forces)
        torques = _cross(points - data.xipos[bodies], forces)
        np.add.at(data.xfrc_applied, bodies, np.concatenate([forces, torques], axis=1))
        return AppliedForces(bodies, points, forces, animal_of_body[bodies], self.kinds)


def _column(values: Any) -> np.ndarray:
    """A scalar per animal as an (n, 1) column, to scale (n, 3) vectors."""
    return np.reshape(np.asarray(values, dtype=float), (-1, 1))


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise cross product of (..., 3) arrays (numpy's np.cross costs ~15 us per call here)."""
    a, b = np.broadcast_arrays(a, b)
    out = np.empty(a.shape)
    out[..., 0] = a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1]
    out[..., 1] = a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2]
    out[..., 2] = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    return out


def _unit(vectors: np.ndarray) -> np.ndarray:
    norm = np.sqrt(np.einsum("ni,ni->n", vectors, vectors))[:, None]
    return np.where(norm > 1e-12, vectors / np.maximum(norm, 1e-12), 0.0)


def compiled_sensors(compiled: CompiledController) -> dict[str, CompiledElement]:
    """The controller's sensors, in order."""
    return {name: e for name, e in compiled.elements.items() if e.type == "sensor"}


def build_runtime(
    controller: str,
    model: mujoco.MjModel,
    placements: Sequence[Placement],
    parameters: Mapping[str, Any] | None = None,
    *,
    scene_parameters: Mapping[str, Any] | None = None,
) -> ControllerRuntime:
    """Load a controller by name or path, compile it for the placed animals and bind it to a model.

    Args:
        controller: a built-in controller name or a YAML path.
        model: the compiled world.
        placements: the animals it drives.
        parameters: parameter overrides (values as written in YAML); a name the controller
            does not declare is an error.
        scene_parameters: values a scene offers (its goals); only those the controller
            declares are used, and `parameters` win over them.
    """
    spec = load_controller(controller)
    offered = {name: value for name, value in (scene_parameters or {}).items() if name in spec.parameters}
    overrides = offered | dict(parameters or {})
    if overrides:
        spec = load_controller(controller, parameters=overrides)
    scale = scale_for_animals([p.built.animal for p in placements])
    return ControllerRuntime(compile_controller(spec, scale), model, placements)
