"""The physical model of an animal, built with `mujoco.MjSpec` (no XML templates).

One body per bone, named by role; capsules for the bones, boxes for pelvis and thorax, five
fused capsules for the head (thesis §3.1). Each joint to a parent is a hinge about the bone's
main axis (the limits table's "twist"), plus a hinge for each non-zero swing (§3.2). Joint
limits live in default classes named after the joint's kind (`knee`, `hip_swing1`, ...), as in
mujoco_menagerie. The animal carries no floor or light: see `quadpipe.world.placement`.

Masses follow the thesis's rules — pelvis 20*HP, thorax 10*HP, head (Fig. 7) 280/65.56*HP, every
other bone by density — evaluated on the skeleton scaled to the thesis's dog, where the rules
were tuned (they mix a mass linear in HP with masses cubic in size, which only agree at one
size), then scaled so the animal weighs its real mass. The dog gets the thesis's Fig. 7
proportions; other animals keep the same rules relative to their own shape.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from quadpipe.anatomy import roles
from quadpipe.anatomy.limits import JointLimit
from quadpipe.anatomy.skeleton import Bone
from quadpipe.animals import sizing
from quadpipe.animals.library import Animal

THESIS_DOG_HP_CM = 65.56
"""Pelvis height of the thesis's dog, where its mass rules were set."""

PELVIS_MASS_PER_HP = 20.0
THORAX_MASS_PER_HP = 10.0
HEAD_MASS_PER_HP = 280.0 / THESIS_DOG_HP_CM
"""Thesis mass rules in its units per cm of HP. The text says 6*HP for the head, but its own Fig. 7
gives the dog's head 280 (4.27*HP); quadpipe follows the figure."""

CAPSULE_DENSITY_PER_CM3 = 0.96
"""Thesis mass units per cm^3 of capsule. The thesis says "density 10" without units; this value
makes the shipped dog's capsule bones weigh what its Fig. 7 says in total (tail 186 + spine 106
+ neck 106 + 2 x 266 front legs + 2 x 231 rear legs = 1392)."""

BOX_MIN_HALF_SIZE_RADII = 1.5
"""A pelvis or thorax box is at least this many bone radii thick in every direction."""

HEAD_WIDTH = 0.18
HEAD_DEPTH = 0.15
"""Lateral and vertical offsets of the head's side and top/jaw capsules, as fractions of its length."""

JOINT_DAMPING_PER_NATURAL_TIME = 0.02
"""Passive joint damping, as a fraction of (body weight * HP * natural time) per radian/s."""

SWING_STIFFNESS_PER_WEIGHT_HP = 0.02
"""Passive stiffness of the swing axes toward rest (ligaments that hold a leg under the body),
as a fraction of (body weight * HP) per radian."""

JOINT_ARMATURE = 0.002
"""Joint armature, as a fraction of (body mass * HP^2): numerical stability for the small bones."""

BONE_PRIORITY = 1
"""Bone geoms win contact parameter mixing, so each animal keeps its own softness."""

ANIMAL_GEOM_GROUP = 1
"""Geom group of bones: terrain and props stay in group 0, so ground rays can skip the animals."""

ANIMAL_CONTYPE, ANIMAL_CONAFFINITY = 2, 1
"""Collision bits: bones touch the world (bit 1) but not each other."""

FRICTION = (1.0, 0.005, 0.0001)
"""Sliding, torsional and rolling friction of bone geoms."""

BONE_RGBA = (0.86, 0.80, 0.68, 1.0)
"""Bone colour: ivory."""
"""Sliding, torsional and rolling friction of bone geoms."""


@dataclass(frozen=True)
class BuiltAnimal:
    """An animal's MjSpec and the sizes derived while building it.

    Attributes:
        spec: the animal alone (root body `pelvis` with a free joint), no floor.
        animal: what it was built from.
        radius: the uniform bone radius (before per-bone clamping), metres.
        radii: per-role capsule radius after clamping (boxes and head use the uniform one).
        masses: per-role mass in kg.
        timestep: the physics step this animal needs, seconds.
        tau: contact time constant, seconds.
    """

    spec: mujoco.MjSpec
    animal: Animal
    radius: float
    radii: dict[str, float]
    masses: dict[str, float]
    timestep: float
    tau: float


def build_animal(animal: Animal) -> BuiltAnimal:
    """Build an animal's MjSpec in its rest pose, pelvis joint at the skeleton's position."""
    skeleton = animal.skeleton
    hp = animal.pelvis_height
    radius = sizing.bone_radius(hp)
    radii = clamped_radii(skeleton.bones, radius)
    masses = part_masses(skeleton.bones, hp, animal.mass_kg)
    tau = sizing.constraint_time_constant(hp)

    spec = mujoco.MjSpec()
    spec.modelname = animal.name
    spec.compiler.degree = False
    spec.option.timestep = sizing.timestep(hp)
    spec.option.iterations = sizing.SOLVER_ITERATIONS
    classes = _add_defaults(spec, animal, tau)

    bodies: dict[str, mujoco.MjsBody] = {}
    for role, bone in skeleton.bones.items():
        parent_role = roles.PARENT[role]
        parent_body = spec.worldbody if parent_role is None else bodies[parent_role]
        parent_origin = np.zeros(3) if parent_role is None else skeleton[parent_role].start
        body = parent_body.add_body(name=role, pos=bone.start - parent_origin)
        bodies[role] = body
        if parent_role is None:
            body.add_freejoint(name="root")
        else:
            _add_joints(body, classes, role, bone, animal.limits[role])
        _add_geoms(body, classes["bone"], role, bone, skeleton.bones, radius, radii[role], masses[role])
    return BuiltAnimal(spec, animal, radius, radii, masses, spec.option.timestep, tau)


def clamped_radii(bones: dict[str, Bone], radius: float) -> dict[str, float]:
    """Per-bone radius: the uniform radius, never larger than the bone's or a neighbour's length."""
    radii = {}
    for role, bone in bones.items():
        parent = roles.PARENT[role]
        neighbours = [parent] if parent else []
        neighbours += list(roles.CHILDREN[role])
        lengths = [bone.length] + [bones[n].length for n in neighbours]
        radii[role] = min(radius, *lengths)
    return radii


def part_masses(bones: dict[str, Bone], pelvis_height: float, mass_kg: float) -> dict[str, float]:
    """Mass of each bone in kg: thesis rules at the thesis dog's scale, scaled to `mass_kg`."""
    to_dog_cm = THESIS_DOG_HP_CM / pelvis_height
    radius_cm = sizing.bone_radius(THESIS_DOG_HP_CM / 100.0) * 100.0
    thesis_units = {}
    for role, bone in bones.items():
        if role == "pelvis":
            thesis_units[role] = PELVIS_MASS_PER_HP * THESIS_DOG_HP_CM
        elif role == "thorax":
            thesis_units[role] = THORAX_MASS_PER_HP * THESIS_DOG_HP_CM
        elif role == roles.HEAD_BONE:
            thesis_units[role] = HEAD_MASS_PER_HP * THESIS_DOG_HP_CM
        else:
            length_cm = bone.length * to_dog_cm
            volume = np.pi * radius_cm**2 * length_cm + 4.0 / 3.0 * np.pi * radius_cm**3
            thesis_units[role] = CAPSULE_DENSITY_PER_CM3 * volume
    scale = mass_kg / sum(thesis_units.values())
    return {role: units * scale for role, units in thesis_units.items()}


def joint_frame(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The main axis and the two swing axes: swing1 along the body's forward axis, swing2 across both."""
    forward = np.array([1.0, 0.0, 0.0])
    swing1 = forward - forward.dot(axis) * axis
    if np.linalg.norm(swing1) < 1e-6:
        swing1 = np.array([0.0, 0.0, 1.0]) - axis[2] * axis
    swing1 /= np.linalg.norm(swing1)
    return axis, swing1, np.cross(axis, swing1)


def _add_defaults(spec: mujoco.MjSpec, animal: Animal, tau: float) -> dict[str, mujoco.MjsDefault]:
    """Default classes: `bone` (contact, damping) and one per joint kind and axis (limits)."""
    hp, mass = animal.pelvis_height, animal.mass_kg
    bone = spec.add_default("bone", spec.default)
    bone.geom.contype = ANIMAL_CONTYPE
    bone.geom.conaffinity = ANIMAL_CONAFFINITY
    bone.geom.priority = BONE_PRIORITY
    bone.geom.group = ANIMAL_GEOM_GROUP
    bone.geom.rgba = list(BONE_RGBA)
    bone.geom.solref = [tau, 1.0]
    bone.geom.solimp = sizing.constraint_impedance(hp)
    bone.geom.friction = list(FRICTION)
    bone.joint.limited = mujoco.mjtLimited.mjLIMITED_TRUE
    bone.joint.solref_limit = [sizing.joint_limit_time_constant(hp), 1.0]
    bone.joint.solimp_limit = sizing.constraint_impedance(hp)
    bone.joint.damping = [
        JOINT_DAMPING_PER_NATURAL_TIME * mass * sizing.GRAVITY * hp * sizing.natural_time(hp),
        0.0,
        0.0,
    ]
    bone.joint.armature = JOINT_ARMATURE * mass * hp**2
    classes = {"bone": bone}
    for role, limit in animal.limits.items():
        kind = roles.kind_of(role)
        if kind in classes:
            continue
        for suffix, low, high in _axis_ranges(limit):
            cls = spec.add_default(kind + suffix, bone)
            cls.joint.range = [low, high]
            if suffix:
                cls.joint.stiffness = [SWING_STIFFNESS_PER_WEIGHT_HP * mass * sizing.GRAVITY * hp, 0.0, 0.0]
            classes[kind + suffix] = cls
    return classes


def _axis_ranges(limit: JointLimit) -> list[tuple[str, float, float]]:
    ranges = [("", limit.twist_min, limit.twist_max)]
    if limit.swing1 > 0:
        ranges.append(("_swing1", -limit.swing1, limit.swing1))
    if limit.swing2 > 0:
        ranges.append(("_swing2", -limit.swing2, limit.swing2))
    return ranges


def _add_joints(body: mujoco.MjsBody, classes: dict, role: str, bone: Bone, limit: JointLimit) -> None:
    axes = dict(zip(("", "_swing1", "_swing2"), joint_frame(bone.axis)))
    kind = roles.kind_of(role)
    for suffix, _, _ in _axis_ranges(limit):
        body.add_joint(
            default=classes[kind + suffix],
            name=role + suffix,
            type=mujoco.mjtJoint.mjJNT_HINGE,
            axis=axes[suffix],
        )


def _add_geoms(
    body: mujoco.MjsBody,
    default: mujoco.MjsDefault,
    role: str,
    bone: Bone,
    bones: dict[str, Bone],
    radius: float,
    bone_radius: float,
    mass: float,
) -> None:
    """Shapes of one bone, in the body's frame (origin at the bone's joint, world-aligned)."""
    origin = bone.start
    if role in roles.BOX_BONES:
        centre, half = box_extent(bone, bones, radius)
        body.add_geom(
            default=default, name=role, type=mujoco.mjtGeom.mjGEOM_BOX, pos=centre - origin, size=half, mass=mass
        )
    elif role == roles.HEAD_BONE:
        segments = head_capsules(bone)
        lengths = [np.linalg.norm(b - a) for a, b in segments]
        for index, ((a, b), length) in enumerate(zip(segments, lengths)):
            body.add_geom(
                default=default,
                name=f"{role}_{index}",
                type=mujoco.mjtGeom.mjGEOM_CAPSULE,
                fromto=np.concatenate([a - origin, b - origin]),
                size=[min(radius, length), 0, 0],
                mass=mass * length / sum(lengths),
            )
    else:
        body.add_geom(
            default=default,
            name=role,
            type=mujoco.mjtGeom.mjGEOM_CAPSULE,
            fromto=np.concatenate([np.zeros(3), bone.end - origin]),
            size=[bone_radius, 0, 0],
            mass=mass,
        )


def box_extent(bone: Bone, bones: dict[str, Bone], radius: float) -> tuple[np.ndarray, np.ndarray]:
    """Centre and half sizes (world frame) of the box spanning a bone's joint and its children's."""
    points = np.array([bone.start] + [bones[child].start for child in roles.CHILDREN[bone.role]])
    low, high = points.min(axis=0), points.max(axis=0)
    centre = (low + high) / 2.0
    half = np.maximum((high - low) / 2.0, BOX_MIN_HALF_SIZE_RADII * radius)
    return centre, half


def head_capsules(bone: Bone) -> list[tuple[np.ndarray, np.ndarray]]:
    """Five fused capsules for the head: skull axis, two sides, crown and jaw."""
    start, length, forward = bone.start, bone.length, bone.direction
    left = np.cross(np.array([0.0, 0.0, 1.0]), forward)
    left = left / np.linalg.norm(left) if np.linalg.norm(left) > 1e-6 else np.array([0.0, 1.0, 0.0])
    up = np.cross(forward, left)
    side, depth = HEAD_WIDTH * length, HEAD_DEPTH * length

    def at(along: float, lateral: float = 0.0, vertical: float = 0.0) -> np.ndarray:
        return start + along * length * forward + lateral * left + vertical * up

    return [
        (at(0.0), at(1.0)),
        (at(0.1, side), at(0.55, 0.6 * side)),
        (at(0.1, -side), at(0.55, -0.6 * side)),
        (at(0.05, 0.0, depth), at(0.45, 0.0, 0.6 * depth)),
        (at(0.2, 0.0, -depth), at(0.85, 0.0, -0.5 * depth)),
    ]
