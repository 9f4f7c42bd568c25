"""The format-free skeleton: what every importer produces and every later stage consumes.

Importers read a file into a `RawSkeleton` (joints as the file names them, in the file's units
and axes). `assemble` checks it, gives each joint a role, converts it to quadpipe's body frame
(metres, +X forward, +Y left, +Z up) and returns a `Skeleton` keyed by role.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace

import numpy as np

from quadpipe.anatomy.binding import RigBinding
from quadpipe.anatomy.roles import CHILDREN, FRONT_CHAIN, HIND_CHAIN, LEAVES, LEGS, MAIN_CHILD, PARENT, ROLES, TOE_BONES
from quadpipe.core.errors import Issue, Location, QuadpipeError, did_you_mean
from quadpipe.core.limits import SKELETON_COORDINATE_M

MIN_BONE_LENGTH_M = 1e-5
"""Bones shorter than this (0.01 mm) are degenerate: an error."""

MIN_AXIS_LENGTH = 1e-9
"""Joint axes shorter than this (a direction, no unit) give no direction: an error."""

UP_AXES = {"y": np.array([0.0, 1.0, 0.0]), "z": np.array([0.0, 0.0, 1.0])}
"""Up axes a file may declare."""

UNIT_TO_METRES = {"m": 1.0, "cm": 0.01, "mm": 0.001, "in": 0.0254, "ft": 0.3048}
"""Length units a file may declare."""


@dataclass(frozen=True)
class JointRecord:
    """One joint as a file describes it, before roles and unit conversion.

    Attributes:
        name: the file's name for the joint (and for the bone that starts there).
        parent: the parent joint's name, None for a root.
        position: world position of the joint, in the file's units and axes.
        axis: main rotation axis in the file's axes, or None to use the lateral axis.
        end: where a leaf bone ends (an end site), in file units and axes, if given.
        role: the role the file itself assigns, if any.
        line: line of the joint in the file, for messages.
        column: column of the joint in the file, for messages.
    """

    name: str
    parent: str | None
    position: tuple[float, float, float]
    axis: tuple[float, float, float] | None = None
    end: tuple[float, float, float] | None = None
    role: str | None = None
    line: int | None = None
    column: int | None = None


@dataclass(frozen=True)
class RawSkeleton:
    """A skeleton as read from a file: joints in file order, units and up axis declared, and
    the reader's warnings (guessed units, joints it could not place exactly)."""

    name: str
    source: str
    joints: tuple[JointRecord, ...]
    units: str = "cm"
    up: str = "y"
    warnings: tuple[Issue, ...] = ()

    def where(self, joint: JointRecord | None = None) -> Location:
        """Location of a joint (or of the file) for messages."""
        if joint is None:
            return Location(self.source)
        return Location(self.source, joint.line, joint.column if joint.line is not None else None)


@dataclass(frozen=True)
class Bone:
    """One bone in the rest pose, in metres in the body frame.

    Attributes:
        role: its role in the reference hierarchy.
        name: the source file's name for it.
        start: world position of its proximal joint.
        end: world position of its distal end.
        axis: unit main rotation axis (the thesis's twist axis), pointing to the left side.
    """

    role: str
    name: str
    start: np.ndarray
    end: np.ndarray
    axis: np.ndarray

    @property
    def length(self) -> float:
        """Distance from start to end, in metres."""
        return float(np.linalg.norm(self.end - self.start))

    @property
    def direction(self) -> np.ndarray:
        """Unit vector from start to end."""
        return (self.end - self.start) / self.length


@dataclass(frozen=True)
class Skeleton:
    """A quadruped skeleton: the 39 reference bones by role, in the body frame.

    Attributes:
        name: the skeleton's name.
        source: the file it came from.
        bones: role -> Bone, in hierarchy order (parents first).
        warnings: non-fatal issues found while assembling (unplaced bones, ...).
        rig: the source rig's own joints and the roles they follow, when they are not simply
            the 39 roles (`quadpipe.anatomy.rig`).
    """

    name: str
    source: str
    bones: dict[str, Bone]
    warnings: tuple[Issue, ...] = field(default=())
    rig: RigBinding | None = None

    def __getitem__(self, role: str) -> Bone:
        return self.bones[role]

    @property
    def ground_height(self) -> float:
        """Height of the lowest foot end in the rest pose, in metres."""
        return min(float(self.bones[toe].end[2]) for toe in TOE_BONES.values())

    @property
    def pelvis_height(self) -> float:
        """Height of the pelvis joint above the lowest foot, in metres (the thesis's HP)."""
        return float(self.bones["pelvis"].start[2]) - self.ground_height


def assemble(raw: RawSkeleton, role_of: Mapping[str, str] | None = None) -> Skeleton:
    """Check a raw skeleton, assign roles and convert it to the body frame.

    Args:
        raw: the joints as read from a file.
        role_of: file joint name -> role, for joints whose role the file does not give.

    Returns:
        The skeleton, with warnings for joints that were left without a role.

    Raises:
        QuadpipeError: duplicate names, unknown parents, a cycle; unknown, duplicate or missing
            roles and bones hanging under the wrong parent, all of them at once; a zero-length
            bone, a leaf without an end, or left legs on the right side.
    """
    by_name = check_structure(raw)
    role_of = dict(role_of or {})
    joint_of_role, issues = _assign_roles(raw, by_name, role_of)
    issues += _check_parents(raw, by_name, joint_of_role)
    if issues:
        raise QuadpipeError(issues)

    rotation = _body_rotation(raw, joint_of_role)
    scale = UNIT_TO_METRES[raw.units]

    def to_body(point: tuple[float, float, float]) -> np.ndarray:
        return rotation @ (np.asarray(point, dtype=float) * scale)

    bones: dict[str, Bone] = {}
    for role in ROLES:
        joint = joint_of_role[role]
        start = to_body(joint.position)
        end = to_body(_end_point(raw, by_name, joint_of_role, role))
        if np.linalg.norm(end - start) < MIN_BONE_LENGTH_M:
            raise QuadpipeError.single(
                "zero-length-bone",
                f"bone {joint.name!r} (role {role}) has zero length: its end lies on its joint",
                where=raw.where(joint),
                hint="move the joint or its child apart; every bone needs a length",
            )
        axis = _main_axis(joint, rotation)
        bones[role] = Bone(role, joint.name, start, end, axis)

    placed = {joint.name for joint in joint_of_role.values()}
    end_sites = _end_sites(raw, joint_of_role)
    unplaced = [j.name for j in raw.joints if j.name not in placed and j.name not in end_sites]
    warnings = _unplaced_warning(raw, unplaced)
    skeleton = Skeleton(raw.name, raw.source, bones, warnings)
    _check_sides(raw, skeleton)
    return skeleton


def reroot(raw: RawSkeleton, name: str) -> RawSkeleton:
    """The same joints with `name` as the root: parents reversed on the path from it up to the
    file's root (a centre-of-gravity or `Bip01` root above the pelvis hangs under it), joints
    listed parents first. Positions do not change."""
    by_name = {joint.name: joint for joint in raw.joints}
    path = [name]
    while (parent := by_name[path[-1]].parent) is not None:
        path.append(parent)
    parents = {joint.name: joint.parent for joint in raw.joints}
    parents.update({child: parent for parent, child in zip(path, path[1:])})
    parents[name] = None
    children: dict[str | None, list[str]] = {}
    for joint in raw.joints:
        children.setdefault(parents[joint.name], []).append(joint.name)
    order, stack = [], [name]
    while stack:
        current = stack.pop()
        order.append(replace(by_name[current], parent=parents[current]))
        stack.extend(reversed(children.get(current, [])))
    others = [joint for joint in raw.joints if joint.name not in {j.name for j in order}]
    return replace(raw, joints=tuple(order + others))


def body_frame(raw: RawSkeleton, role_of: Mapping[str, str]) -> tuple[np.ndarray, float]:
    """The rotation from the file's axes to the body frame and the file unit in metres, for a
    skeleton whose joints `role_of` (name -> role) includes the pelvis and the thorax."""
    joint_of_role = {role: joint for joint in raw.joints if (role := role_of.get(joint.name, joint.role))}
    return _body_rotation(raw, joint_of_role), UNIT_TO_METRES[raw.units]


def check_coordinates(raw: RawSkeleton) -> RawSkeleton:
    """`raw` when every joint's position, axis and end is finite and within
    `SKELETON_COORDINATE_M` of the origin (in metres, once its units apply).

    Raises:
        QuadpipeError: `out-of-range` at the first joint with a point that is not.
    """
    scale = UNIT_TO_METRES[raw.units]
    for joint in raw.joints:
        for name, point in (("position", joint.position), ("axis", joint.axis), ("end", joint.end)):
            if point is None:
                continue
            factor = 1.0 if name == "axis" else scale  # an axis is a direction, not a length
            problems = [SKELETON_COORDINATE_M.problem(float(value) * factor) for value in point]
            problem = next((p for p in problems if p is not None), None)
            if problem is not None:
                raise QuadpipeError.single(
                    "out-of-range",
                    f"joint {joint.name!r}, {name} {' '.join(f'{float(v):g}' for v in point)} {raw.units}: {problem}",
                    where=raw.where(joint),
                    hint=f"{SKELETON_COORDINATE_M.hint} (is the file's unit, {raw.units!r}, right?)",
                )
        _check_axis_length(raw, joint)
    return raw


def _check_axis_length(raw: RawSkeleton, joint: JointRecord) -> None:
    """Refuse a joint axis too short to give a direction (`0 0 0`).

    Raises:
        QuadpipeError: `zero-axis` at the joint.
    """
    if joint.axis is not None and np.linalg.norm(np.asarray(joint.axis, dtype=float)) < MIN_AXIS_LENGTH:
        raise QuadpipeError.single(
            "zero-axis",
            f"joint {joint.name!r}, axis {' '.join(f'{float(v):g}' for v in joint.axis)}: "
            "an axis of length zero has no direction",
            where=raw.where(joint),
            hint="write the joint's main rotation axis, e.g. 1 0 0, or leave `axis` out to use the lateral axis",
        )


def check_structure(raw: RawSkeleton) -> dict[str, JointRecord]:
    """Check names are unique, parents exist and the hierarchy has no cycle; index joints by name.

    Raises:
        QuadpipeError: `duplicate-joint`, `empty-skeleton`, `unknown-parent` or `hierarchy-cycle`.
    """
    by_name = _index_joints(raw)
    _check_hierarchy(raw, by_name)
    return by_name


def _index_joints(raw: RawSkeleton) -> dict[str, JointRecord]:
    by_name: dict[str, JointRecord] = {}
    for joint in raw.joints:
        if joint.name in by_name:
            raise QuadpipeError.single(
                "duplicate-joint",
                f"joint name {joint.name!r} is used twice (first at line {by_name[joint.name].line})",
                where=raw.where(joint),
                hint="joint names must be unique; rename one of them",
            )
        by_name[joint.name] = joint
    if not by_name:
        raise QuadpipeError.single("empty-skeleton", "the file has no joints", where=raw.where())
    return by_name


def _check_hierarchy(raw: RawSkeleton, by_name: Mapping[str, JointRecord]) -> None:
    for joint in raw.joints:
        if joint.parent is not None and joint.parent not in by_name:
            raise QuadpipeError.single(
                "unknown-parent",
                f"joint {joint.name!r} names parent {joint.parent!r}, which is not in the file",
                where=raw.where(joint),
                hint=did_you_mean(joint.parent, by_name, listing=False) or "check the parent's name",
            )
    acyclic: set[str] = set()
    for joint in raw.joints:
        chain: dict[str, None] = {joint.name: None}
        current = joint
        while current.parent is not None and current.parent not in acyclic:
            current = by_name[current.parent]
            if current.name in chain:
                names = list(chain)
                loop = " -> ".join(names[names.index(current.name) :] + [current.name])
                raise QuadpipeError.single(
                    "hierarchy-cycle",
                    f"the hierarchy loops: {loop}",
                    where=raw.where(joint),
                    hint="a joint cannot be its own ancestor; fix one of these parents",
                )
            chain[current.name] = None
        acyclic.update(chain)


def _assign_roles(
    raw: RawSkeleton, by_name: Mapping[str, JointRecord], role_of: dict[str, str]
) -> tuple[dict[str, JointRecord], list[Issue]]:
    """Each role's joint, and every problem with them: unknown roles, roles given twice, and the
    roles no joint has when there are more of them than refused joints (each joint whose role
    was refused stands for the role it was meant to have: the first two issues say so)."""
    joint_of_role: dict[str, JointRecord] = {}
    issues: list[Issue] = []
    for joint in raw.joints:
        role = joint.role or role_of.get(joint.name)
        if role is None:
            continue
        if role not in PARENT:
            hint = did_you_mean(role, ROLES, listing=False) or "see `quadpipe roles` for the 39 roles"
            message = f"joint {joint.name!r} has role {role!r}, which is not a role of the reference hierarchy"
            issues.append(Issue("unknown-role", message, raw.where(joint), hint))
        elif role in joint_of_role:
            message = f"role {role!r} is given to both {joint_of_role[role].name!r} and {joint.name!r}"
            issues.append(Issue("duplicate-role", message, raw.where(joint), "each role belongs to exactly one bone"))
        else:
            joint_of_role[role] = joint
    missing = [role for role in ROLES if role not in joint_of_role]
    if len(missing) > len(issues):
        shown = ", ".join(missing[:12]) + (" ..." if len(missing) > 12 else "")
        issues.append(
            Issue(
                "missing-roles",
                f"{len(missing)} of the 39 roles have no bone: {shown}",
                raw.where(),
                "give these joints a role (role attribute, or a role map with --roles)",
            )
        )
    return joint_of_role, issues


def _mapped_ancestor(joint: JointRecord, by_name: Mapping[str, JointRecord], mapped: Mapping[str, str]) -> str | None:
    """Role of the nearest ancestor joint that has a role (unplaced joints are skipped)."""
    current = joint
    while current.parent is not None:
        current = by_name[current.parent]
        if current.name in mapped:
            return mapped[current.name]
    return None


def _check_parents(
    raw: RawSkeleton, by_name: Mapping[str, JointRecord], joint_of_role: Mapping[str, JointRecord]
) -> list[Issue]:
    """A `wrong-parent` issue for every bone not under its reference parent (bones whose parent
    role has no joint are left to `missing-roles`)."""
    role_by_joint = {joint.name: role for role, joint in joint_of_role.items()}
    issues = []
    for role, joint in joint_of_role.items():
        found = _mapped_ancestor(joint, by_name, role_by_joint)
        expected = PARENT[role]
        if found != expected and (expected is None or expected in joint_of_role):
            under = f"under {found!r}" if found else "at the root"
            message = (
                f"bone {joint.name!r} (role {role}) hangs {under}; the reference hierarchy puts it under {expected!r}"
            )
            issues.append(Issue("wrong-parent", message, raw.where(joint), "fix the joint's parent, or its role"))
    return issues


def _end_point(
    raw: RawSkeleton,
    by_name: Mapping[str, JointRecord],
    joint_of_role: Mapping[str, JointRecord],
    role: str,
) -> tuple[float, float, float]:
    children = CHILDREN[role]
    if children:
        child = MAIN_CHILD.get(role, children[0])
        return joint_of_role[child].position
    joint = joint_of_role[role]
    if joint.end is not None:
        return joint.end
    sites = [j for j in raw.joints if j.parent == joint.name]
    if sites:
        return sites[0].position
    raise QuadpipeError.single(
        "missing-end",
        f"bone {joint.name!r} (role {role}) is a leaf and the file does not say where it ends",
        where=raw.where(joint),
        hint="add an end point (an `end` attribute, an End Site, or an end joint below it)",
    )


def _end_sites(raw: RawSkeleton, joint_of_role: Mapping[str, JointRecord]) -> set[str]:
    """Unplaced childless joints that only mark where a leaf bone ends (Maya end joints)."""
    leaves = {joint_of_role[role].name for role in LEAVES}
    parents = {joint.parent for joint in raw.joints}
    return {j.name for j in raw.joints if j.parent in leaves and j.name not in parents and j.role is None}


def _body_rotation(raw: RawSkeleton, joint_of_role: Mapping[str, JointRecord]) -> np.ndarray:
    """Rotation from the file's axes to the body frame: up to +Z, pelvis-to-thorax to +X."""
    if raw.up not in UP_AXES:
        raise QuadpipeError.single(
            "bad-up-axis", f"up axis {raw.up!r} is not supported", where=raw.where(), hint="use 'y' or 'z'"
        )
    up = UP_AXES[raw.up]
    pelvis = np.asarray(joint_of_role["pelvis"].position, dtype=float)
    thorax = np.asarray(joint_of_role["thorax"].position, dtype=float)
    forward = thorax - pelvis
    forward -= forward.dot(up) * up
    norm = np.linalg.norm(forward)
    if norm < 1e-9:
        raise QuadpipeError.single(
            "no-forward",
            "the thorax sits straight above the pelvis, so the body has no forward direction",
            where=raw.where(joint_of_role["thorax"]),
            hint="is the up axis right? (the file says up=" + raw.up + ")",
        )
    forward /= norm
    left = np.cross(up, forward)
    return np.vstack([forward, left, up])


def _main_axis(joint: JointRecord, rotation: np.ndarray) -> np.ndarray:
    """The joint's main axis in the body frame, unit length, turned to point left."""
    if joint.axis is None:
        return np.array([0.0, 1.0, 0.0])
    axis = rotation @ np.asarray(joint.axis, dtype=float)
    norm = np.linalg.norm(axis)
    if norm < MIN_AXIS_LENGTH:
        return np.array([0.0, 1.0, 0.0])
    axis /= norm
    return -axis if axis[1] < 0 else axis


def _unplaced_warning(raw: RawSkeleton, unplaced: list[str]) -> tuple[Issue, ...]:
    if not unplaced:
        return ()
    shown = ", ".join(unplaced[:10]) + (" ..." if len(unplaced) > 10 else "")
    return (
        Issue(
            "unplaced-joints",
            f"{len(unplaced)} joint(s) have no role and are left out: {shown}",
            raw.where(),
            "map them in a role map (--roles) if they should be bones; end sites need nothing; "
            "baked onto the rig (bake --skeleton rig), they ride on their parent",
            severity="warning",
        ),
    )


def _check_sides(raw: RawSkeleton, skeleton: Skeleton) -> None:
    for leg in LEGS:
        first = FRONT_CHAIN[0] if leg.endswith("f") else HIND_CHAIN[0]
        bone = skeleton[f"{leg}_{first}"]
        lateral = bone.end[1] - skeleton["pelvis"].start[1]
        if (leg[0] == "l") != (lateral > 0):
            raise QuadpipeError.single(
                "mirrored-legs",
                f"the {leg} leg ({bone.name!r}) lies on the animal's {'right' if lateral <= 0 else 'left'} side",
                where=raw.where(),
                hint="left and right are swapped: fix the role map, or the file's handedness",
            )
