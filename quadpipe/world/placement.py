"""The world around the animals: floor, light, and the animals placed in it.

Animal models (`quadpipe.animals.model`) carry no floor or light, as in mujoco_menagerie: a world
attaches one or more of them, each under a name prefix (`dog/lf_elbow`), lifted so that its
lowest point just touches the ground.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import mujoco
import numpy as np

from quadpipe.animals import sizing
from quadpipe.animals.model import FRICTION, BuiltAnimal

WORLD_CONTYPE, WORLD_CONAFFINITY = 1, 3
"""Collision bits of world geoms: they touch each other (bit 1) and the animals (bit 2)."""

FLOOR_HALF_SIZE_HP = 200.0
"""Half the floor's side, in pelvis heights of the largest animal."""

DROP_CLEARANCE_HP = 0.002
"""Gap left under an animal's lowest point when it is placed, in pelvis heights."""


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


def build_world(placements: Sequence[Placement], *, floor: bool = True) -> mujoco.MjSpec:
    """A world spec with a floor and a sun, and each animal attached at its placement.

    The time step is the smallest any animal needs (see `quadpipe.animals.sizing`).
    """
    spec = mujoco.MjSpec()
    spec.modelname = "+".join(p.name for p in placements) or "world"
    spec.compiler.degree = False
    spec.option.timestep = min((p.built.timestep for p in placements), default=sizing.FRAME_STEP_S)
    spec.option.iterations = sizing.SOLVER_ITERATIONS
    largest = max((p.built.animal.pelvis_height for p in placements), default=1.0)
    add_sky_and_light(spec, largest)
    if floor:
        add_floor(spec, largest)
    for placement in placements:
        lift = lowest_point_offset(placement.built.spec) + DROP_CLEARANCE_HP * placement.built.animal.pelvis_height
        frame = spec.worldbody.add_frame(pos=[placement.xy[0], placement.xy[1], lift], quat=yaw_quat(placement.heading))
        animal_spec = placement.built.spec.copy()
        animal_spec.option.timestep = spec.option.timestep
        spec.attach(animal_spec, prefix=f"{placement.name}/", frame=frame)
    return spec


def lowest_point_offset(animal_spec: mujoco.MjSpec) -> float:
    """How far to lift an animal spec so that its lowest geom touches z = 0."""
    model = animal_spec.copy().compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    lowest = np.inf
    for geom in range(model.ngeom):
        centre = data.geom_xpos[geom] + data.geom_xmat[geom].reshape(3, 3) @ model.geom_aabb[geom, :3]
        reach = np.abs(data.geom_xmat[geom].reshape(3, 3)[2]) @ model.geom_aabb[geom, 3:]
        lowest = min(lowest, centre[2] - reach)
    return -float(lowest)


def add_floor(spec: mujoco.MjSpec, scale: float, friction: float = FRICTION[0]) -> None:
    """A checkered `floor` plane sized for animals of pelvis height `scale`."""
    spec.add_texture(
        name="grid", type=mujoco.mjtTexture.mjTEXTURE_2D, builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER,
        rgb1=[0.32, 0.36, 0.40], rgb2=[0.24, 0.27, 0.30], width=300, height=300,
    )
    spec.add_material(name="floor", textures=["", "grid"], texrepeat=[1.0 / scale, 1.0 / scale], texuniform=True, reflectance=0.1)
    spec.worldbody.add_geom(
        name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[FLOOR_HALF_SIZE_HP * scale] * 2 + [0.1],
        material="floor", contype=WORLD_CONTYPE, conaffinity=WORLD_CONAFFINITY, friction=[friction, *FRICTION[1:]],
    )


def add_sky_and_light(spec: mujoco.MjSpec, scale: float) -> None:
    """A gradient sky and a sun (directional light with shadows) high above."""
    spec.add_texture(
        name="sky", type=mujoco.mjtTexture.mjTEXTURE_SKYBOX, builtin=mujoco.mjtBuiltin.mjBUILTIN_GRADIENT,
        rgb1=[0.55, 0.7, 0.85], rgb2=[0.1, 0.12, 0.15], width=256, height=256,
    )
    spec.worldbody.add_light(
        name="sun", type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL, pos=[0, 0, 10 * scale],
        dir=[0.3, 0.2, -1.0], diffuse=[0.8, 0.8, 0.8], castshadow=True,
    )
