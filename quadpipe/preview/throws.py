"""Throws from the camera in a live preview: a pool of balls and boxes parked under the floor.

A compiled MuJoCo model cannot grow bodies, so a live world gets `POOL_SIZE` bodies of each
kind when it is built (`add_throw_pool`), parked until thrown (`ThrowPool`); a throw starts at
the camera and is aimed ballistically (`throw_origin`, `aim_velocity`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Literal

import mujoco
import numpy as np

from quadpipe.animals import sizing
from quadpipe.world.throws import PARK_DEPTH_HP, THROWN_RGBA

if TYPE_CHECKING:
    from quadpipe.controllers.runtime.runtime import ControllerRuntime

POOL_SIZE = 4
"""Throwable bodies of each kind (ball, box) preallocated in a live world; the oldest is reused."""

POOL_PREFIX = "preview-"
"""Prefix of the pool's body names (`preview-ball0`): a hyphen, which scene names cannot hold."""

THROW_MASS_BM = 0.1
"""Mass of a thrown ball or box, in body masses of the first animal (the scenes' default)."""

BALL_RADIUS_HP = 0.1
BOX_SIDE_HP = 0.2
"""Sizes of the thrown ball (radius) and box (side), in pelvis heights."""

THROW_FROUDE = 2.5
"""A throw's speed is `froude_speed(2.5)` of the first animal (about 4 m/s for the dog)."""

MAX_THROW_DISTANCE_HP = 4.0
"""A throw starts from the camera, but no farther than this from its target (pelvis heights):
the object then appears on the line from the camera, so a throw hits as hard from any distance."""

DEFAULT_THROW_FROM = (0.0, 1.0, 0.5)
"""Direction a throw comes from without a camera position, in the animal's heading frame (its left, above)."""

THROW_TARGET_POINTS = ("pelvis.start", "thorax.start")
"""A throw aims at the middle of these body points (the trunk's middle)."""

ThrowKind = Literal["ball", "box"]


class ThrowPool:
    """Throwable bodies preallocated in a world, parked until thrown.

    Args:
        model: the compiled world holding the bodies `add_throw_pool` added.
        names: kind -> body names.
    """

    def __init__(self, model: mujoco.MjModel, names: Mapping[str, Sequence[str]]):
        self.bodies = {kind: [int(model.body(name).id) for name in group] for kind, group in names.items()}
        self._next = {kind: 0 for kind in names}

    def park_all(self, model: mujoco.MjModel) -> None:
        """Every body back to colliding with nothing and held against gravity (positions: `qpos0`)."""
        for bodies in self.bodies.values():
            for body in bodies:
                _set_colliding(model, body, False)
        self._next = {kind: 0 for kind in self.bodies}

    def throw(
        self, model: mujoco.MjModel, data: mujoco.MjData, kind: str, position: np.ndarray, velocity: np.ndarray
    ) -> int:
        """Teleport the next body of `kind` to `position`, moving at `velocity`; returns its body id."""
        bodies = self.bodies[kind]
        body = bodies[self._next[kind] % len(bodies)]
        self._next[kind] += 1
        joint = int(model.body_jntadr[body])
        qpos, dof = int(model.jnt_qposadr[joint]), int(model.jnt_dofadr[joint])
        data.qpos[qpos : qpos + 3] = position
        data.qpos[qpos + 3 : qpos + 7] = (1.0, 0.0, 0.0, 0.0)
        data.qvel[dof : dof + 3] = velocity
        data.qvel[dof + 3 : dof + 6] = 0.0
        _set_colliding(model, body, True)
        return body


def _set_colliding(model: mujoco.MjModel, body: int, on: bool) -> None:
    """A loose body touches the world and the animals and falls (on), or nothing and floats (off)."""
    from quadpipe.world.placement import WORLD_CONAFFINITY, WORLD_CONTYPE

    contype, conaffinity = (WORLD_CONTYPE, WORLD_CONAFFINITY) if on else (0, 0)
    geoms = slice(int(model.body_geomadr[body]), int(model.body_geomadr[body] + model.body_geomnum[body]))
    model.geom_contype[geoms], model.geom_conaffinity[geoms] = contype, conaffinity
    model.body_contype[body], model.body_conaffinity[body] = contype, conaffinity
    model.body_gravcomp[body] = 0.0 if on else 1.0


def add_throw_pool(spec: mujoco.MjSpec, hp: float, mass_kg: float, count: int = POOL_SIZE) -> dict[str, list[str]]:
    """Add `count` balls and `count` boxes, parked under the floor, to a world spec.

    Args:
        spec: the world (scene) spec, before compiling.
        hp: the first animal's pelvis height (sizes, softness and parking depth), metres.
        mass_kg: the first animal's body mass.
        count: bodies of each kind.

    Returns:
        kind -> body names.
    """
    shapes = {
        "ball": (mujoco.mjtGeom.mjGEOM_SPHERE, [BALL_RADIUS_HP * hp, 0.0, 0.0]),
        "box": (mujoco.mjtGeom.mjGEOM_BOX, [BOX_SIDE_HP * hp / 2] * 3),
    }
    names: dict[str, list[str]] = {}
    for kind, (geom_type, size) in shapes.items():
        names[kind] = [f"{POOL_PREFIX}{kind}{k}" for k in range(count)]
        for name in names[kind]:
            body = spec.worldbody.add_body(name=name, pos=[0.0, 0.0, -PARK_DEPTH_HP * hp], gravcomp=1.0)
            body.add_freejoint(name=name)
            body.add_geom(
                name=name,
                type=geom_type,
                size=size,
                mass=THROW_MASS_BM * mass_kg,
                rgba=list(THROWN_RGBA),
                solref=[sizing.constraint_time_constant(hp), 1.0],
                solimp=sizing.constraint_impedance(hp),
                contype=0,
                conaffinity=0,
            )
    return names


def aim_velocity(origin: np.ndarray, target: np.ndarray, speed: float, gravity: np.ndarray) -> np.ndarray:
    """The launch velocity that carries a ballistic body from `origin` to `target`.

    The flight takes distance / `speed` seconds; over it gravity pulls the path down by
    g T² / 2, which the launch makes up for: v0 = D / T - g T / 2.
    """
    displacement = np.asarray(target, dtype=float) - np.asarray(origin, dtype=float)
    flight = float(np.linalg.norm(displacement)) / speed
    return displacement / flight - np.asarray(gravity, dtype=float) * flight / 2


def throw_origin(eye: np.ndarray | None, target: np.ndarray, heading: np.ndarray, hp: float) -> np.ndarray:
    """Where a throw at `target` starts: the camera, brought within `MAX_THROW_DISTANCE_HP` of the target.

    Without a camera (or with one at the target), it comes from `DEFAULT_THROW_FROM` in the
    animal's heading frame (`heading`, 3x3).
    """
    reach = MAX_THROW_DISTANCE_HP * hp
    offset = None if eye is None else np.asarray(eye, dtype=float) - target
    if offset is None or np.linalg.norm(offset) < 1e-6:
        direction = heading @ np.asarray(DEFAULT_THROW_FROM)
        offset = reach * direction / np.linalg.norm(direction)
    distance = float(np.linalg.norm(offset))
    return target + offset * min(1.0, reach / distance)


def throw_at_trunk(
    runtime: ControllerRuntime,
    model: mujoco.MjModel,
    data: mujoco.MjData,
    pool: ThrowPool,
    kind: ThrowKind,
    eye: np.ndarray | None,
    hp: float,
) -> tuple[int, float]:
    """Throw the next ball or box of `pool` at the first animal's trunk from the camera at `eye`.

    It starts at the camera (within `MAX_THROW_DISTANCE_HP` of the target), aimed where the
    trunk will be when it gets there, at the animal's `froude_speed(2.5)` (`hp`: its pelvis
    height); the state is then computed again (`mj_forward`).

    Returns:
        the thrown body's id, and its speed in m/s.
    """
    target = np.mean([runtime.point(data, p)[0] for p in THROW_TARGET_POINTS], axis=0)
    speed = math.sqrt(THROW_FROUDE * sizing.GRAVITY * hp)
    origin = throw_origin(eye, target, runtime.heading_frames(data)[0], hp)
    flight = float(np.linalg.norm(target - origin)) / speed
    drift = runtime.point_velocity(data, THROW_TARGET_POINTS[0])[0] * np.array([1.0, 1.0, 0.0])
    velocity = aim_velocity(origin, target + drift * flight, speed, model.opt.gravity)
    body = pool.throw(model, data, kind, origin, velocity)
    mujoco.mj_forward(model, data)
    return body, speed
