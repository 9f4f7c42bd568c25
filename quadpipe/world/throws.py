"""Objects thrown at the animals: planning each throw (`ThrowPlan`: when, from where, how
fast, on which arc) and `ThrowEvent`, which launches it during the simulation."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from quadpipe.anatomy.skeleton import Skeleton
from quadpipe.core.errors import QuadpipeError
from quadpipe.core.yamlio import dotted
from quadpipe.quantities.expressions import ZERO_NORM, resolve_point_name
from quadpipe.world.format import THROW_DISTANCE_HP, THROWN_PREFIX, RandomThrows, Throw
from quadpipe.world.loading import SceneSpec, animal_exists, animal_hint
from quadpipe.world.placement import WORLD_CONAFFINITY, WORLD_CONTYPE, yaw_matrix, yaw_quat
from quadpipe.world.props import add_shape, mujoco_size
from quadpipe.world.values import Values

FROM_DIRECTIONS: dict[str, tuple[float, float, float]] = {
    "left": (0.0, 1.0, 0.0),
    "right": (0.0, -1.0, 0.0),
    "front": (1.0, 0.0, 0.0),
    "back": (-1.0, 0.0, 0.0),
}
"""Where a throw comes from, in the target animal's heading frame (x where it faces, y its left)."""

THROW_RANGE_FRACTION = 0.5
"""A default throw distance is at most this fraction of the farthest the speed can carry
(half of it: a 15 degree throw when level), unless the animal is in the way (`CLEAR_HP`)."""

CLEAR_RANGE_FRACTION = 0.9
"""To start clear of the animal a default throw may come from up to this fraction of the
farthest its speed can carry (a lob); a throw too slow even for that is made faster."""

CLEAR_HP = 0.15
"""A default throw starts at least this far (HP, about a body's half thickness) beyond the
animal's farthest bone end toward where it comes from, plus the object's own radius: a throw
from the front does not appear inside the head, nor one from behind inside the tail."""

BONE_SAMPLES = 9
"""Points per bone, ends included, at which the animal is looked for in a throw's way."""

ANCHOR_FRACTIONS = {"start": 0.0, "mid": 0.5, "end": 1.0}
"""Where a target point (`thorax.mid`) lies along its bone, from its start to its end."""

PARK_DEPTH_HP = 50.0
"""Thrown objects wait this many pelvis heights under the floor, without collisions and held
against gravity, until their throw (well inside `quadpipe.core.limits.FAR_AWAY_HP`)."""

THROWN_RGBA = (0.90, 0.65, 0.15, 1.0)
"""Display colour of thrown objects."""

TIME_TOLERANCE_S = 1e-9
"""An event due at t fires at the first step whose time is within this of t or past it."""


@dataclass(frozen=True)
class ThrowPlan:
    """One throw, resolved for the scene's animals.

    The object appears `distance` from the target point, on the side `direction` (in the
    target animal's heading frame at the throw time), already moving at `launch_velocity`
    (heading frame), and reaches the point `flight_time` later at `speed`, gravity included.

    Attributes:
        body: the thrown body's name (`thrown0`).
        time: when it is thrown, seconds.
        animal: name of the target animal.
        point: the target body point (`pelvis.start`).
        shape: `box`, `sphere` or `capsule`.
        size: MuJoCo geom size (half sizes for a box, half length for a capsule), metres.
        mass: kg.
        speed: arrival speed, m/s.
        direction: unit vector from the target toward where it comes from, heading frame.
        distance: metres from the target where it appears.
        flight_time: seconds from the throw to the target.
        launch_velocity: velocity when thrown, heading frame, m/s.
        room: metres kept between the animal's bones and the object's centre along its way
            (its radius and `CLEAR_HP`): the half width of the corridor in which bones count.
        rest_reach: how far the rest pose's bones reach from the target toward `direction`
            within that corridor, metres (see `clear_distance`).
    """

    body: str
    time: float
    animal: str
    point: str
    shape: str
    size: tuple[float, ...]
    mass: float
    speed: float
    direction: np.ndarray
    distance: float
    flight_time: float
    launch_velocity: np.ndarray
    room: float
    rest_reach: float


def add_thrown(spec: mujoco.MjSpec, throws: list[ThrowPlan], tau: float, hp: float) -> None:
    """Add every thrown object, parked under the floor, held against gravity, touching nothing."""
    for plan in throws:
        body = spec.worldbody.add_body(name=plan.body, pos=[0.0, 0.0, -PARK_DEPTH_HP * hp], gravcomp=1.0)
        body.add_freejoint(name=plan.body)
        add_shape(body, plan.body, plan.shape, plan.size, plan.mass, THROWN_RGBA, tau, hp, colliding=False)


def plan_throws(scene: SceneSpec, values: Values, skeletons: dict[str, Skeleton], gravity: float) -> list[ThrowPlan]:
    """Every throw of the scene, random series drawn, in declaration order.

    Args:
        scene: the scene.
        values: its resolved values.
        skeletons: each animal's skeleton by instance name, in scene order (a default throw
            starts clear of its target's rest pose).
        gravity: m/s², downward.
    """
    plans: list[ThrowPlan] = []
    names = list(skeletons)
    for index, item in enumerate(scene.file.throws):
        base = ("throws", index)
        animal = _target_animal(scene, item.animal, names, base + ("animal",))
        size = mujoco_size(item.shape, values.items(base + ("size",), len(item.size)))
        point = resolve_point_name(item.target)
        if isinstance(item, Throw):
            shots = [
                (values[base + ("at",)], values[base + ("mass",)], values[base + ("speed",)], from_vector(item.from_))
            ]
            speed_path: tuple[Any, ...] = base + ("speed",)
        else:
            shots = random_shots(item.random, values, base + ("random",))
            speed_path = base + ("random", "speed")
        for time, mass, speed, direction in shots:
            room = bounding_radius(item.shape, size) + CLEAR_HP * values.hp
            rest_reach = clear_distance(skeletons[animal], point, direction, room)
            clear = rest_reach + room
            distance, flight, speed = _aim(
                speed,
                direction,
                values.get(base + ("distance",)),
                clear,
                gravity,
                values.hp,
                scene,
                speed_path,
            )
            launch = -distance * direction / flight + np.array([0.0, 0.0, gravity * flight / 2])
            plans.append(
                ThrowPlan(
                    f"{THROWN_PREFIX}{len(plans)}",
                    float(time),
                    animal,
                    point,
                    item.shape,
                    size,
                    float(mass),
                    float(speed),
                    direction,
                    distance,
                    flight,
                    launch,
                    room,
                    rest_reach,
                )
            )
    return plans


def _target_animal(scene: SceneSpec, ref: int | str, names: list[str], path: tuple[Any, ...]) -> str:
    if not animal_exists(ref, names):
        raise QuadpipeError.single(
            "unknown-animal-ref",
            f"there is no animal {ref!r} in this scene",
            where=scene.locate(path),
            hint=animal_hint(names),
        )
    return names[ref] if isinstance(ref, int) else ref


def from_vector(direction: str | list[float]) -> np.ndarray:
    """A throw's `from` as a unit vector in the heading frame."""
    vector = np.array(FROM_DIRECTIONS[direction] if isinstance(direction, str) else direction, dtype=float)
    return vector / np.linalg.norm(vector)


def random_shots(
    series: RandomThrows, values: Values, base: tuple[Any, ...]
) -> list[tuple[float, float, float, np.ndarray]]:
    """The (time, mass, speed, direction) of each throw of a random series, drawn from its seed."""
    rng = np.random.default_rng(series.seed)
    start, every = values[base + ("start",)], values[base + ("every",)]
    mass_low, mass_high = _range(values, base + ("mass",))
    speed_low, speed_high = _range(values, base + ("speed",))
    shots = []
    for k in range(series.count):
        mass_draw, speed_draw = rng.random(2)
        side = series.from_[int(rng.integers(len(series.from_)))]
        mass = mass_low + mass_draw * (mass_high - mass_low)
        speed = speed_low + speed_draw * (speed_high - speed_low)
        shots.append((start + k * every, mass, speed, from_vector(side)))
    return shots


def _range(values: Values, path: tuple[Any, ...]) -> tuple[float, float]:
    low, high = values.items(path, 2)
    if low > high:
        raise QuadpipeError.single(
            "invalid-range",
            f"{dotted(path)}: the lowest value comes first: [lowest, highest]",
            where=values.scene.locate(path),
        )
    return float(low), float(high)


def _aim(
    speed: float,
    direction: np.ndarray,
    distance: float | None,
    clear: float,
    gravity: float,
    hp: float,
    scene: SceneSpec,
    path: tuple[Any, ...],
) -> tuple[float, float, float]:
    """The throw's distance, flight time and arrival speed; it starts as fast as it arrives
    when level.

    A default distance is `THROW_DISTANCE_HP`, or half the farthest the speed carries if that
    is shorter, but at least `clear` (metres: clear of the animal). A throw too slow to come
    from there (`CLEAR_RANGE_FRACTION` of its reach) comes as slowly as it can: it arrives
    faster than asked.

    Raises:
        QuadpipeError: the speed cannot carry the object `distance` from that direction.
    """
    lift = 1.0 + direction[2]
    reach = speed**2 / (gravity * lift) if lift > 0 else math.inf
    if distance is None:
        distance = max(min(THROW_DISTANCE_HP * hp, THROW_RANGE_FRACTION * reach), clear)
        speed = max(speed, math.sqrt(gravity * lift * distance / CLEAR_RANGE_FRACTION))
    flight = flight_time(speed, distance, direction[2], gravity)
    if flight is None:
        raise QuadpipeError.single(
            "throw-out-of-reach",
            f"{dotted(path)}: at {speed:.3g} m/s a throw reaches at most {reach:.3g} m from this direction, not {distance:.3g} m",
            where=scene.locate(path),
            hint="throw faster, or from closer (`distance`)",
        )
    return float(distance), flight, speed


def point_on_bone(skeleton: Skeleton, point: str) -> tuple[str, np.ndarray]:
    """The bone of a body point (`thorax.mid`) and the point's offset from the bone's joint,
    in the rest pose (the bone's body frame), metres."""
    role, anchor = point.split(".")
    bone = skeleton[role]
    return role, ANCHOR_FRACTIONS[anchor] * (np.asarray(bone.end) - np.asarray(bone.start))


def clear_distance(skeleton: Skeleton, point: str, direction: np.ndarray, corridor: float) -> float:
    """How far the animal's rest pose reaches from its target `point` (`thorax.mid`) toward
    `direction` (its heading frame, x forward), metres: the farthest point of its bones that
    way within `corridor` metres of the line the object comes along."""
    role, offset = point_on_bone(skeleton, point)
    target = skeleton[role].start + offset
    lines = [(np.asarray(bone.start), np.asarray(bone.end)) for bone in skeleton.bones.values()]
    return reach(lines, target, direction, corridor)


def reach(
    lines: list[tuple[np.ndarray, np.ndarray]], target: np.ndarray, direction: np.ndarray, corridor: float
) -> float:
    """How far bones (start and end points) reach from `target` toward the unit `direction`,
    metres (0 if none is that way): the farthest of `BONE_SAMPLES` points along each bone
    within `corridor` metres of the line through `target` along `direction`."""
    along = np.linspace(0.0, 1.0, BONE_SAMPLES)[:, None]
    points = np.concatenate([start + along * (end - start) for start, end in lines])
    offsets = points - target
    ahead = offsets @ direction
    aside = np.linalg.norm(offsets - ahead[:, None] * direction, axis=1)
    return max(0.0, float(ahead[aside < corridor].max(initial=0.0)))


def bounding_radius(shape: str, size: tuple[float, ...]) -> float:
    """The radius of the smallest sphere around an object of MuJoCo geom `size`, metres."""
    if shape == "box":
        return float(np.linalg.norm(size))
    return float(sum(size))


def flight_time(speed: float, distance: float, up: float, gravity: float) -> float | None:
    """Time for a ballistic throw to reach a point `distance` away and arrive at `speed`.

    The object starts at `distance` x (direction with vertical part `up`) from the target;
    the direct (flatter) of the two possible arcs is taken. With a launch velocity
    v0 = D/T - g T/2 (D the displacement) the arrival velocity is D/T + g T/2, whose squared
    length, solved for T^2, gives a quadratic; its smaller root is the direct arc.

    Returns:
        the flight time in seconds, or None if that speed cannot get there.
    """
    b = speed**2 - gravity * distance * up
    discriminant = b * b - (gravity * distance) ** 2
    if b <= 0 or discriminant < 0:
        return None
    return math.sqrt(2 * distance**2 / (b + math.sqrt(discriminant)))


class ThrowEvent:
    """Event: at its time, a parked object appears and flies to its target point.

    It aims where the target point will be after the flight time if it keeps its horizontal
    velocity, from the side given relative to where the animal then faces, and is placed
    where it would be at the step's time had it left exactly on time. It starts at least its
    distance out from where the point is at the throw (an animal running away from it does
    not bring its start into the animal), and farther out by what the animal's bones then
    reach beyond their rest pose's reach that way (a tail carried out behind, a head stretched
    forward), flying faster by what that adds. Going back before the throw time (a reset)
    parks the object again.

    Args:
        model: the compiled scene.
        plan: the throw.
        target: name of the body carrying the target point, and the point in that body's
            frame, metres.
        start_heading: the animal's start heading, used when it faces straight up or down.
        bones: the animal's bones: the name of each bone's body, and the bone from that body's
            origin (its start) to its end, in the body's frame, metres.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        plan: ThrowPlan,
        target: tuple[str, np.ndarray],
        start_heading: float,
        bones: list[tuple[str, np.ndarray]],
    ):
        self.plan = plan
        body = model.body(plan.body)
        self.body = int(body.id)
        joint = int(body.jntadr[0])
        self.qpos = int(model.jnt_qposadr[joint])
        self.dof = int(model.jnt_dofadr[joint])
        self.geoms = slice(int(body.geomadr[0]), int(body.geomadr[0] + body.geomnum[0]))
        self.target = int(model.body(target[0]).id)
        self.offset = np.asarray(target[1], dtype=float)
        self.pelvis = int(model.body(f"{plan.animal}/pelvis").id)
        self.bones = [(int(model.body(name).id), np.asarray(vector, dtype=float)) for name, vector in bones]
        self.start_heading = start_heading
        self.parked = model.qpos0[self.qpos : self.qpos + 7].copy()
        self.thrown = False
        self._park(model)

    def __call__(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        if data.time < self.plan.time - TIME_TOLERANCE_S:
            if self.thrown:
                self._park(model, data)
            return
        if not self.thrown:
            self._launch(model, data)

    def _collide(self, model: mujoco.MjModel, on: bool) -> None:
        """Switch the object's collisions (MuJoCo filters by body bits first, then by geom bits)."""
        contype, conaffinity = (WORLD_CONTYPE, WORLD_CONAFFINITY) if on else (0, 0)
        model.geom_contype[self.geoms] = contype
        model.geom_conaffinity[self.geoms] = conaffinity
        model.body_contype[self.body] = contype
        model.body_conaffinity[self.body] = conaffinity

    def _park(self, model: mujoco.MjModel, data: mujoco.MjData | None = None) -> None:
        self._collide(model, False)
        model.body_gravcomp[self.body] = 1.0
        if data is not None:
            data.qpos[self.qpos : self.qpos + 7] = self.parked
            data.qvel[self.dof : self.dof + 6] = 0.0
        self.thrown = False

    def heading(self, data: mujoco.MjData) -> float:
        """Where the target animal faces now: its pelvis's forward axis, horizontally."""
        forward = data.xmat[self.pelvis].reshape(3, 3)[:, 0]
        if math.hypot(forward[0], forward[1]) < ZERO_NORM:
            return self.start_heading
        return math.atan2(forward[1], forward[0])

    def launch_state(self, model: mujoco.MjModel, data: mujoco.MjData) -> tuple[np.ndarray, np.ndarray, float]:
        """Position, velocity and heading of the object at the current time (state must be forward-computed)."""
        plan = self.plan
        rotation = data.xmat[self.target].reshape(3, 3)
        point = data.xpos[self.target] + rotation @ self.offset
        motion = np.zeros(6)
        mujoco.mj_objectVelocity(model, data, mujoco.mjtObj.mjOBJ_XBODY, self.target, motion, 0)
        point_velocity = motion[3:] + np.cross(motion[:3], point - data.xpos[self.target])
        lead = plan.flight_time * np.array([point_velocity[0], point_velocity[1], 0.0])
        heading = self.heading(data)
        turn = yaw_matrix(heading)
        side = turn @ plan.direction
        # A lead toward the object's side (an animal running from a throw from behind) would
        # bring its start into the animal: it starts as far out from where the point is now,
        # and farther by what the bones reach now beyond their rest pose's reach; it flies
        # that much faster to arrive on time.
        closer = max(0.0, -float(lead @ side))
        farther = max(0.0, self.reach_now(data, point, side) - plan.rest_reach)
        out = plan.distance + closer + farther
        start = point + lead + out * side
        velocity = turn @ plan.launch_velocity - (out - plan.distance) / plan.flight_time * side
        late = data.time - plan.time
        gravity = np.asarray(model.opt.gravity)
        return start + velocity * late + gravity * late**2 / 2, velocity + gravity * late, heading

    def reach_now(self, data: mujoco.MjData, point: np.ndarray, side: np.ndarray) -> float:
        """How far the animal's bones reach now from `point` toward `side` (see `reach`), metres."""
        lines = []
        for body, vector in self.bones:
            start = data.xpos[body]
            lines.append((start, start + data.xmat[body].reshape(3, 3) @ vector))
        return reach(lines, point, side, self.plan.room)

    def _launch(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        mujoco.mj_forward(model, data)
        position, velocity, heading = self.launch_state(model, data)
        data.qpos[self.qpos : self.qpos + 3] = position
        data.qpos[self.qpos + 3 : self.qpos + 7] = yaw_quat(heading)
        data.qvel[self.dof : self.dof + 3] = velocity
        data.qvel[self.dof + 3 : self.dof + 6] = 0.0
        self._collide(model, True)
        model.body_gravcomp[self.body] = 0.0
        self.thrown = True
