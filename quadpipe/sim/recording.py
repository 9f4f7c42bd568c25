"""Recording a MuJoCo simulation into a `Clip`, one frame at a time."""

from __future__ import annotations

from collections.abc import Sequence

import mujoco
import numpy as np

from quadpipe.anatomy.roles import FOOT_BONES, LEGS, PARENT, ROLES
from quadpipe.clip.model import AnimalTrack, Clip, PropTrack, Shape, ShapeKind
from quadpipe.world.placement import Placement

_SHAPE_KINDS: dict[int, ShapeKind] = {
    int(mujoco.mjtGeom.mjGEOM_CAPSULE): "capsule",
    int(mujoco.mjtGeom.mjGEOM_BOX): "box",
    int(mujoco.mjtGeom.mjGEOM_SPHERE): "sphere",
    int(mujoco.mjtGeom.mjGEOM_PLANE): "plane",
}
_SHAPE_SIZES = {"capsule": 2, "box": 3, "sphere": 1, "plane": 2}


def geom_shape(model: mujoco.MjModel, geom: int) -> Shape:
    """A geom as a `Shape` in its body's frame."""
    kind = _SHAPE_KINDS.get(int(model.geom_type[geom]))
    if kind is None:
        raise ValueError(f"geom {model.geom(geom).name!r} has a type clips cannot carry")
    return Shape(
        kind=kind,
        size=tuple(float(v) for v in model.geom_size[geom][: _SHAPE_SIZES[kind]]),
        pos=_triple(model.geom_pos[geom]),
        quat=_quadruple(model.geom_quat[geom]),
        rgba=_quadruple(model.geom_rgba[geom]),
    )


def _triple(values: np.ndarray) -> tuple[float, float, float]:
    """Three numbers (a position) as plain floats."""
    x, y, z = (float(v) for v in values)
    return x, y, z


def _quadruple(values: np.ndarray) -> tuple[float, float, float, float]:
    """Four numbers (a quaternion, a colour) as plain floats."""
    a, b, c, d = (float(v) for v in values)
    return a, b, c, d


class Recorder:
    """Collects the poses of every animal bone and prop of a world, frame by frame.

    Args:
        model: the compiled world.
        placements: the animals in it, as placed by `quadpipe.world.placement.build_world`.
        fps: frame rate of the clip.
    """

    def __init__(self, model: mujoco.MjModel, placements: Sequence[Placement], fps: float):
        self.model, self.placements, self.fps = model, list(placements), fps
        self._bones = [np.array([model.body(f"{p.name}/{role}").id for role in ROLES]) for p in placements]
        animal_bodies = np.concatenate(self._bones) if self._bones else np.zeros(0, int)
        self._props = [
            body
            for body in range(1, model.nbody)
            if model.body_jntnum[body] == 1
            and model.jnt_type[model.body_jntadr[body]] == mujoco.mjtJoint.mjJNT_FREE
            and body not in animal_bodies
        ]
        self._leg_of_body = np.full(model.nbody, -1)
        for animal_index, placement in enumerate(placements):
            for leg_index, leg in enumerate(LEGS):
                for bone in FOOT_BONES[leg]:
                    self._leg_of_body[model.body(f"{placement.name}/{bone}").id] = animal_index * len(LEGS) + leg_index
        self._positions: list[np.ndarray] = []
        self._rotations: list[np.ndarray] = []
        self._contacts: list[np.ndarray] = []
        self._present: list[np.ndarray] = []
        self._extras: dict[str, list[np.ndarray]] = {}

    def capture(self, data: mujoco.MjData, extras: dict[str, np.ndarray] | None = None) -> None:
        """Record the current state as the next frame.

        Args:
            data: the simulation state.
            extras: per-frame values to keep in the clip's `sensors` (same keys every frame).
        """
        self._positions.append(data.xpos.copy())
        self._rotations.append(data.xquat.copy())
        self._contacts.append(self._feet_down(data))
        self._present.append(self._props_present())
        for key, value in (extras or {}).items():
            self._extras.setdefault(key, []).append(np.array(value, dtype=float))

    def _feet_down(self, data: mujoco.MjData) -> np.ndarray:
        down = np.zeros(len(self.placements) * len(LEGS), dtype=bool)
        if data.ncon:
            bodies1 = self.model.geom_bodyid[data.contact.geom1[: data.ncon]]
            bodies2 = self.model.geom_bodyid[data.contact.geom2[: data.ncon]]
            legs = np.concatenate([self._leg_of_body[bodies1], self._leg_of_body[bodies2]])
            down[legs[legs >= 0]] = True
        return down

    def _props_present(self) -> np.ndarray:
        """Which props are in the scene now: those that collide (a thrown object waits, parked
        without collisions, until its throw; `quadpipe.world.throws`)."""
        props = np.asarray(self._props, dtype=int)
        return (self.model.body_contype[props] | self.model.body_conaffinity[props]) != 0

    def clip(self, metadata: dict[str, str] | None = None) -> Clip:
        """The frames recorded so far, as a `Clip`."""
        positions = np.array(self._positions).reshape(-1, self.model.nbody, 3)
        rotations = np.array(self._rotations).reshape(-1, self.model.nbody, 4)
        contacts = np.array(self._contacts).reshape(len(self._positions), -1)
        present = np.array(self._present, dtype=bool).reshape(len(self._positions), len(self._props))
        animals = [
            self._animal_track(index, placement, positions, rotations, contacts)
            for index, placement in enumerate(self.placements)
        ]
        props = [
            PropTrack(
                name=self.model.body(body).name,
                shape=geom_shape(self.model, self.model.body_geomadr[body]),
                positions=positions[:, body],
                rotations=rotations[:, body],
                mass_kg=float(self.model.body_mass[body]),
                present=None if present[:, index].all() else present[:, index],
            )
            for index, body in enumerate(self._props)
        ]
        terrain = [
            geom_shape(self.model, geom)
            for geom in range(self.model.ngeom)
            if self.model.geom_bodyid[geom] == 0 and int(self.model.geom_type[geom]) in _SHAPE_KINDS
        ]
        sensors = {key: np.array(values) for key, values in self._extras.items()}
        return Clip(self.fps, animals, props, terrain, sensors=sensors, metadata=dict(metadata or {}))

    def _animal_track(
        self, index: int, placement: Placement, positions: np.ndarray, rotations: np.ndarray, contacts: np.ndarray
    ) -> AnimalTrack:
        bones = self._bones[index]
        skeleton = placement.built.animal.skeleton
        offset = self.model.body_pos[bones[0]] - skeleton["pelvis"].start  # bind pose faces +x, see Clip
        shapes = [
            [
                geom_shape(self.model, g)
                for g in range(self.model.body_geomadr[b], self.model.body_geomadr[b] + self.model.body_geomnum[b])
            ]
            for b in bones
        ]
        return AnimalTrack(
            name=placement.name,
            species=placement.built.animal.name,
            roles=ROLES,
            parents=np.array([ROLES.index(PARENT[r]) if PARENT[r] else -1 for r in ROLES]),
            rest_start=np.array([skeleton[r].start for r in ROLES]) + offset,
            rest_end=np.array([skeleton[r].end for r in ROLES]) + offset,
            shapes=shapes,
            positions=positions[:, bones],
            rotations=rotations[:, bones],
            pelvis_height=placement.built.animal.pelvis_height,
            mass_kg=placement.built.animal.mass_kg,
            foot_contacts=contacts[:, index * len(LEGS) : (index + 1) * len(LEGS)],
            rig=skeleton.rig,
        )
