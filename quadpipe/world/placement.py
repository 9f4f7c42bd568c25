"""The world around the animals: floor, light, and the animals placed in it.

Animal models (`quadpipe.animals.model`) carry no floor or light, as in mujoco_menagerie: a world
attaches one or more of them, each under a name prefix (`dog/lf_elbow`), turned to its heading
and lifted so that its lowest point just touches whatever lies under it (the floor, a scene's
terrain, or z = 0 when there is nothing). `build_world` makes such a world for animals alone;
scenes (`quadpipe.world.build`) add terrain before the animals, and props after them.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from quadpipe.animals import sizing
from quadpipe.animals.model import ANIMAL_CONAFFINITY, ANIMAL_CONTYPE, FRICTION, BuiltAnimal

WORLD_CONTYPE, WORLD_CONAFFINITY = 1, 3
"""Collision bits of world geoms: they touch each other (bit 1) and the animals (bit 2)."""

FLOOR_HALF_SIZE_HP = 200.0
"""Half the floor's side, in pelvis heights of the largest animal."""

DROP_CLEARANCE_HP = 0.002
"""Gap left under an animal's lowest point when it is placed, in pelvis heights."""

RAY_HEIGHT_HP = 1000.0
"""Height from which the ground under an animal is found by casting rays down, in HP."""


@dataclass(frozen=True)
class Placement:
    """Where one animal starts: its instance name (the prefix of its elements), ground position
    and heading (radians counter-clockwise from +x)."""

    name: str
    built: BuiltAnimal
    xy: tuple[float, float] = (0.0, 0.0)
    heading: float = 0.0

    def yaw(self) -> np.ndarray:
        """The 3x3 rotation of the heading about +z."""
        return yaw_matrix(self.heading)


def yaw_matrix(heading: float) -> np.ndarray:
    """Rotation matrix of a turn by `heading` radians about +z."""
    c, s = np.cos(heading), np.sin(heading)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def yaw_quat(heading: float) -> list[float]:
    """Quaternion (w, x, y, z) of a turn by `heading` radians about +z."""
    return [float(np.cos(heading / 2)), 0.0, 0.0, float(np.sin(heading / 2))]


def euler_quat(euler: np.ndarray) -> np.ndarray:
    """The quaternion of MuJoCo's default `xyz` Euler sequence (about x, then the new y, then the new z)."""
    quat = np.zeros(4)
    mujoco.mju_euler2Quat(quat, np.asarray(euler, dtype=float), "xyz")
    return quat


def build_world(placements: Sequence[Placement], *, floor: bool = True) -> mujoco.MjSpec:
    """A world spec with a floor and a sun, and each animal attached at its placement.

    The time step is the smallest any animal needs (see `quadpipe.animals.sizing`).
    """
    name = "+".join(p.name for p in placements) or "world"
    spec = world_spec(name, [p.built for p in placements], FRICTION[0] if floor else None)
    attach_animals(spec, placements, FRICTION[0])
    return spec


def world_mjcf(placements: Sequence[Placement], *, floor: bool = True) -> str:
    """The MJCF of `build_world(placements, floor=floor)`, compiled first (which checks it)."""
    spec = build_world(placements, floor=floor)
    spec.compile()
    return spec.to_xml()


def world_spec(name: str, animals: Sequence[BuiltAnimal], floor_friction: float | None = FRICTION[0]) -> mujoco.MjSpec:
    """An empty world for these animals: their smallest time step, a sky and a sun, and a
    floor of sliding friction `floor_friction` (None: no floor)."""
    spec = mujoco.MjSpec()
    spec.modelname = name
    spec.compiler.degree = False
    spec.option.timestep = min((built.timestep for built in animals), default=sizing.FRAME_STEP_S)
    spec.option.iterations = sizing.SOLVER_ITERATIONS
    largest = max((built.animal.pelvis_height for built in animals), default=1.0)
    add_sky_and_light(spec, largest)
    if floor_friction is not None:
        add_floor(spec, largest, floor_friction)
    return spec


def attach_animals(
    spec: mujoco.MjSpec, placements: Sequence[Placement], friction: float, collide: bool = False
) -> None:
    """Attach every animal, turned to its heading and lifted onto whatever lies under it.

    The ground is found on the world compiled before any animal is attached (compiling the
    spec itself: `MjSpec.copy()` of a spec whose material skips a texture role crashes
    MuJoCo 3.17). Every geom of the animals gets the sliding friction `friction` (MuJoCo lets
    the bones decide their contacts). With `collide`, the animals' bones touch each other's
    (never their own: see `animal_collision_bits`).
    """
    ground_model = spec.compile()
    ground_data = mujoco.MjData(ground_model)
    mujoco.mj_kinematics(ground_model, ground_data)
    bottoms: dict[int, np.ndarray] = {}
    for placement in placements:
        if id(placement.built) not in bottoms:
            bottoms[id(placement.built)] = geom_bottoms(placement.built.spec)
        lift = start_height(placement, bottoms[id(placement.built)], ground_model, ground_data)
        animal_spec = placement.built.spec.copy()
        animal_spec.option.timestep = spec.option.timestep
        bits = animal_collision_bits(placements.index(placement), len(placements)) if collide else None
        for geom in animal_spec.geoms:
            geom.friction = [friction, *geom.friction[1:]]
            if bits is not None:
                geom.contype, geom.conaffinity = bits
        frame = spec.worldbody.add_frame(pos=[*placement.xy, lift], quat=yaw_quat(placement.heading))
        spec.attach(animal_spec, prefix=f"{placement.name}/", frame=frame)


ANIMAL_BITS = range(2, 31)
"""Collision bits given to animals that collide with each other, one each in turn (bit 1 is
every bone's, which the world's geoms touch: `WORLD_CONAFFINITY`)."""


def animal_collision_bits(index: int, count: int) -> tuple[int, int]:
    """The contype and conaffinity of the bones of the `index`th of `count` animals that
    collide with each other: each its own bit (after 29 animals, bits are shared, and
    animals sharing one pass through each other), touching the world's geoms and every other
    animal's bit, never its own."""
    own = 1 << ANIMAL_BITS[index % len(ANIMAL_BITS)]
    others = sum(1 << ANIMAL_BITS[k % len(ANIMAL_BITS)] for k in range(count)) & ~own
    return ANIMAL_CONTYPE | own, ANIMAL_CONAFFINITY | others


def geom_bottoms(animal_spec: mujoco.MjSpec) -> np.ndarray:
    """The lowest point of each geom of an animal in its rest pose, in its own frame, (k, 3)."""
    model = animal_spec.copy().compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    rotations = data.geom_xmat.reshape(-1, 3, 3)
    centres = data.geom_xpos + np.einsum("kij,kj->ki", rotations, model.geom_aabb[:, :3])
    reach = np.einsum("kj,kj->k", np.abs(rotations[:, 2, :]), model.geom_aabb[:, 3:])
    return centres - np.outer(reach, [0.0, 0.0, 1.0])


def start_height(
    placement: Placement, bottoms: np.ndarray, ground_model: mujoco.MjModel, ground_data: mujoco.MjData
) -> float:
    """How high to attach an animal so that its lowest part rests on the ground or terrain below
    (on z = 0 where there is nothing below)."""
    hp = placement.built.animal.pelvis_height
    points = bottoms @ placement.yaw().T + np.array([*placement.xy, 0.0])
    top = RAY_HEIGHT_HP * hp
    lifts = [
        ground - point[2]
        for point in points
        if (ground := ground_height(ground_model, ground_data, point[0], point[1], top)) is not None
    ]
    lift = max(lifts) if lifts else -float(points[:, 2].min())
    return lift + DROP_CLEARANCE_HP * hp


def ground_height(model: mujoco.MjModel, data: mujoco.MjData, x: float, y: float, top: float) -> float | None:
    """Height of the highest static surface under (x, y) below `top`, or None if there is none."""
    geom = np.zeros(1, dtype=np.int32)
    distance = mujoco.mj_ray(model, data, np.array([x, y, top]), np.array([0.0, 0.0, -1.0]), None, 1, -1, geom)
    return None if distance < 0 else top - distance


def add_floor(spec: mujoco.MjSpec, scale: float, friction: float = FRICTION[0]) -> None:
    """A checkered `floor` plane sized for animals of pelvis height `scale`."""
    spec.add_texture(
        name="grid",
        type=mujoco.mjtTexture.mjTEXTURE_2D,
        builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER,
        rgb1=[0.32, 0.36, 0.40],
        rgb2=[0.24, 0.27, 0.30],
        width=300,
        height=300,
    )
    spec.add_material(
        name="floor", textures=["", "grid"], texrepeat=[1.0 / scale, 1.0 / scale], texuniform=True, reflectance=0.1
    )
    spec.worldbody.add_geom(
        name="floor",
        type=mujoco.mjtGeom.mjGEOM_PLANE,
        size=[FLOOR_HALF_SIZE_HP * scale] * 2 + [0.1],
        material="floor",
        contype=WORLD_CONTYPE,
        conaffinity=WORLD_CONAFFINITY,
        friction=[friction, *FRICTION[1:]],
    )


def add_sky_and_light(spec: mujoco.MjSpec, scale: float) -> None:
    """A gradient sky and a sun (directional light with shadows) high above."""
    spec.add_texture(
        name="sky",
        type=mujoco.mjtTexture.mjTEXTURE_SKYBOX,
        builtin=mujoco.mjtBuiltin.mjBUILTIN_GRADIENT,
        rgb1=[0.55, 0.7, 0.85],
        rgb2=[0.1, 0.12, 0.15],
        width=256,
        height=256,
    )
    spec.worldbody.add_light(
        name="sun",
        type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL,
        pos=[0, 0, 10 * scale],
        dir=[0.3, 0.2, -1.0],
        diffuse=[0.8, 0.8, 0.8],
        castshadow=True,
    )
