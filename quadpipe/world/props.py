"""Loose objects: the shapes of props and thrown objects, props added to the world, and
`PropStart`, the event that sets a prop moving."""

from __future__ import annotations

import mujoco
import numpy as np

from quadpipe.animals import sizing
from quadpipe.world.loading import SceneSpec
from quadpipe.world.placement import WORLD_CONAFFINITY, WORLD_CONTYPE, euler_quat
from quadpipe.world.values import Values

PROP_RGBA = (0.85, 0.30, 0.20, 1.0)
"""Display colour of props."""


def mujoco_size(shape: str, size: np.ndarray) -> tuple[float, ...]:
    """A scene `size` (full box sides, capsule straight length) as MuJoCo's geom size."""
    if shape == "box":
        return tuple(float(v) / 2 for v in size)
    if shape == "capsule":
        return (float(size[0]), float(size[1]) / 2)
    return (float(size[0]),)


_GEOM_TYPES = {"box": "mjGEOM_BOX", "sphere": "mjGEOM_SPHERE", "capsule": "mjGEOM_CAPSULE"}


def add_shape(
    body: mujoco.MjsBody,
    name: str,
    shape: str,
    size: tuple[float, ...],
    mass: float,
    rgba: tuple[float, ...],
    tau: float,
    hp: float,
    colliding: bool,
) -> None:
    """A loose object's geom: it touches the world and the animals, softened for the scene's size."""
    body.add_geom(
        name=name,
        type=getattr(mujoco.mjtGeom, _GEOM_TYPES[shape]),
        size=[*size, *[0.0] * (3 - len(size))],
        mass=mass,
        rgba=list(rgba),
        solref=[tau, 1.0],
        solimp=sizing.constraint_impedance(hp),
        contype=WORLD_CONTYPE if colliding else 0,
        conaffinity=WORLD_CONAFFINITY if colliding else 0,
    )


def add_props(spec: mujoco.MjSpec, scene: SceneSpec, values: Values, tau: float) -> dict[str, np.ndarray]:
    """Add every prop as a free body; returns the start velocities of those that move."""
    velocities = {}
    for index, prop in enumerate(scene.file.props):
        base = ("props", index)
        body = spec.worldbody.add_body(
            name=prop.name, pos=values[base + ("at",)], quat=euler_quat(values[base + ("euler",)])
        )
        body.add_freejoint(name=prop.name)
        size = mujoco_size(prop.type, values.items(base + ("size",), len(prop.size)))
        add_shape(body, prop.name, prop.type, size, values[base + ("mass",)], PROP_RGBA, tau, values.hp, colliding=True)
        velocity = values[base + ("velocity",)]
        if np.any(velocity):
            velocities[prop.name] = velocity
    return velocities


class PropStart:
    """Event: sets a prop moving at the start (MuJoCo models hold no initial velocity)."""

    def __init__(self, model: mujoco.MjModel, name: str, velocity: np.ndarray):
        self.dof = int(model.jnt_dofadr[model.body(name).jntadr[0]])
        self.velocity = np.asarray(velocity, dtype=float)
        self.first_step_end = model.opt.timestep / 2

    def __call__(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        if data.time < self.first_step_end:
            data.qvel[self.dof : self.dof + 3] = self.velocity
