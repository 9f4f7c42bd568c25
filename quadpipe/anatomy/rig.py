"""Rigs with any joint count: role chains, synthesised roles, extra bones, and the binding back.

A production rig rarely has the 39 reference bones. A role map may give one joint a *chain* of
roles (`Spine1: [spine0, spine1, spine2]`): the roles are spread over that joint's bone and the
unmapped joints below it, in proportion to their lengths, and a bone holding several roles is
split along its length. Leg roles may be written without their leg (`shoulder`, `knee`): a
joint on the animal's left takes the left leg's role. Roles the rig has no bone for are
synthesised where they can be: a scapula above and behind the shoulder, a toe chain forward
from the foot's end site. Joints left without a role are *extra bones*: the model leaves them
out, and in a clip they ride rigidly on their parent.

`assemble_rig` expands the rig into one joint per role (the new joints are named
`<rig joint>.<role>`), assembles that (`quadpipe.anatomy.skeleton.assemble`) and binds the rig's
own joints to the bones (`quadpipe.anatomy.binding.RigBinding`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace

import numpy as np

from quadpipe.anatomy.binding import RigBinding, RigJoint
from quadpipe.anatomy.roles import FRONT_CHAIN, HIND_CHAIN, LEGS, ROLES, leg_chain
from quadpipe.anatomy.skeleton import (
    UP_AXES,
    JointRecord,
    RawSkeleton,
    Skeleton,
    assemble,
    body_frame,
    check_structure,
)
from quadpipe.core.errors import Issue, QuadpipeError

RoleValue = str | tuple[str, ...]
"""What a role map gives a joint: one role, or a chain of roles."""

LEG_KINDS: frozenset[str] = frozenset(FRONT_CHAIN + HIND_CHAIN)
"""Leg roles without their leg prefix; a role map may give these and let the joint's side decide."""

SCAPULA_PER_HUMERUS = (-0.58, -0.15, 0.74)
"""Where a synthesised scapula starts, from the shoulder joint, in humerus lengths along
(forward, outward, up): the thesis dog's proportions (configs/skeletons/dog.xml: scapula at
3.93 67.81 52.1 cm, shoulder 7.21 51.69 64.7 cm, elbow 7.21 37.69 48.02 cm)."""

TOE_CHAIN_PER_FOOT = 0.5
"""Length of a synthesised toe chain as a fraction of its foot bone (metacarpus or metatarsus):
between the dog's fore toes (0.68 of its metacarpus) and hind toes (0.45 of its metatarsus)."""

SEPARATOR = "."
"""Joints made by `expand` are named `<rig joint>.<role>`."""

Vector = tuple[float, float, float]


def roles_in(value: RoleValue) -> tuple[str, ...]:
    """The roles of a role-map value, one or a chain."""
    return (value,) if isinstance(value, str) else value


@dataclass(frozen=True)
class Expansion:
    """`expand`'s result: a joint per role, and where each came from.

    Attributes:
        joints: the rig's joints (re-parented where a bone was split) and the new ones.
        roles: joint name -> role, for every joint that has one.
        carrier: role -> the rig joint whose bone carries it.
        synthesised: roles made where the rig has no bone.
    """

    joints: tuple[JointRecord, ...]
    roles: dict[str, str]
    carrier: dict[str, str]
    synthesised: tuple[str, ...]


def assemble_rig(raw: RawSkeleton, role_of: Mapping[str, RoleValue], file_raw: RawSkeleton | None = None) -> Skeleton:
    """`assemble` for a rig of any joint count: expand chains and synthesise missing roles
    first, then bind the rig's own joints to the assembled bones.

    `raw` is rooted at the pelvis; `file_raw` is the same joints as the file has them (its
    own root and hierarchy, which the binding and so the baked clip keep; default `raw`).

    Raises:
        QuadpipeError: what `assemble` raises, and `missing-end` for a chain with no end.
    """
    check_structure(raw)
    expansion = expand(raw, role_of)
    expanded = replace(raw, joints=expansion.joints)
    skeleton = assemble(expanded, expansion.roles)
    notes = _synthesis_notes(raw, expansion)
    binding = make_binding(file_raw or raw, expansion, skeleton)
    return replace(skeleton, warnings=skeleton.warnings + notes, rig=binding)


def expand(raw: RawSkeleton, role_of: Mapping[str, RoleValue]) -> Expansion:
    """A joint per role: chains split, leg kinds given their side, missing scapulae and toes
    synthesised (see the module docstring). Joints that give their own role keep it.

    Raises:
        QuadpipeError: `missing-end` for a chain that runs out with no end to split.
    """
    values: dict[str, RoleValue] = {j.name: j.role for j in raw.joints if j.role}
    values.update(role_of)
    frame = _Frame.of(raw, values)
    expander = _Expander({j.name: j for j in raw.joints}, values)
    for joint in raw.joints:
        if joint.name in values:
            expander.split(joint, tuple(frame.sided(role, joint) for role in roles_in(values[joint.name])))
    if frame.forward is not None:
        for leg in LEGS:
            expander.synthesise_scapula(leg, frame)
            expander.synthesise_toes(leg, frame)
    return expander.expansion()


@dataclass(frozen=True)
class _Frame:
    """The rig's own axes, enough to tell left from right and forward from back (file axes)."""

    up: np.ndarray
    forward: np.ndarray | None = None
    pelvis: np.ndarray | None = None

    @classmethod
    def of(cls, raw: RawSkeleton, values: Mapping[str, RoleValue]) -> _Frame:
        up = UP_AXES.get(raw.up, UP_AXES["y"])
        first = {roles_in(value)[0]: name for name, value in values.items()}
        holder = {role: name for name, value in values.items() for role in roles_in(value)}
        if "pelvis" not in first or "thorax" not in holder:
            return cls(up)
        position = {joint.name: np.asarray(joint.position, dtype=float) for joint in raw.joints}
        pelvis = position[first["pelvis"]]
        forward = position[holder["thorax"]] - pelvis
        forward = forward - forward.dot(up) * up
        norm = float(np.linalg.norm(forward))
        return cls(up, forward / norm, pelvis) if norm > 0 else cls(up)

    @property
    def left(self) -> np.ndarray:
        """The animal's left, in the file's axes (needs `forward`)."""
        assert self.forward is not None, "left needs a forward direction"
        return np.cross(self.up, self.forward)

    def sided(self, role: str, joint: JointRecord) -> str:
        """`role`, or for a leg kind (`elbow`) the role of that kind on the joint's side."""
        if role not in LEG_KINDS or self.forward is None or self.pelvis is None:
            return role
        lateral = float((np.asarray(joint.position, dtype=float) - self.pelvis).dot(self.left))
        return f"{'l' if lateral > 0 else 'r'}{'f' if role in FRONT_CHAIN else 'h'}_{role}"


class _Expander:
    """The joints being expanded: the rig's, re-parented as bones split, and the new ones."""

    def __init__(self, records: dict[str, JointRecord], values: Mapping[str, RoleValue]) -> None:
        self.records = records
        self.values = values
        self.rig_names = tuple(records)
        self.roles: dict[str, str] = {}
        self.carrier: dict[str, str] = {}
        self.origin: dict[str, str] = {name: name for name in records}
        self.synthesised: list[str] = []

    def expansion(self) -> Expansion:
        """The result, the rig's joints first in file order, then the new ones."""
        return Expansion(tuple(self.records.values()), self.roles, self.carrier, tuple(self.synthesised))

    def children(self, name: str) -> list[JointRecord]:
        """The joints whose parent is `name`."""
        return [j for j in self.records.values() if j.parent == name]

    def add(self, record: JointRecord, role: str, rig_joint: str, *, insert: bool) -> None:
        """Give `record` its role; a new joint with `insert` takes over its parent's children."""
        if record.name not in self.records and insert:
            for child in self.children(record.parent or ""):
                self.records[child.name] = replace(child, parent=record.name)
        self.records[record.name] = record
        self.roles[record.name] = role
        self.carrier[role] = rig_joint
        self.origin[record.name] = rig_joint

    def split(self, joint: JointRecord, chain: tuple[str, ...]) -> None:
        """Spread a chain of roles over `joint`'s bone and the unmapped joints below it."""
        path = self.chain_path(joint, len(chain))
        points = [np.asarray(j.position, dtype=float) for j in path]
        if len(chain) > 1:
            points.append(self.chain_end(path[-1]))
        lengths = [float(np.linalg.norm(b - a)) for a, b in zip(points, points[1:])]
        roles = iter(chain)
        for index, (rig_joint, count) in enumerate(zip(path, chain_shares(lengths, len(chain)))):
            self.add(self.records[rig_joint.name], next(roles), rig_joint.name, insert=False)
            previous = rig_joint.name
            for part in range(1, count):
                role = next(roles)
                at = points[index] + (points[index + 1] - points[index]) * part / count
                piece = JointRecord(
                    f"{rig_joint.name}{SEPARATOR}{role}", previous, _point(at), line=joint.line, column=joint.column
                )
                self.add(piece, role, rig_joint.name, insert=True)
                previous = piece.name
            if count > 1 and rig_joint.end is not None:
                self.records[previous] = replace(self.records[previous], end=rig_joint.end)

    def chain_path(self, joint: JointRecord, count: int) -> list[JointRecord]:
        """`joint` and the unmapped joints below it, down the one branch that goes on, at most `count`."""
        path = [joint]
        while len(path) < count:
            onward = [
                j
                for j in self.children(path[-1].name)
                if j.name not in self.values and (j.end is not None or self.children(j.name))
            ]
            if len(onward) != 1:
                break
            path.append(onward[0])
        return path

    def chain_end(self, last: JointRecord) -> np.ndarray:
        """Where a chain ends: the last joint's mapped child, its end site, or its one end joint.

        Raises:
            QuadpipeError: `missing-end` when there is none.
        """
        children = self.children(last.name)
        mapped = [j for j in children if j.name in self.values]
        if mapped:
            return np.asarray(mapped[0].position, dtype=float)
        if last.end is not None:
            return np.asarray(last.end, dtype=float)
        if len(children) == 1:
            return np.asarray(children[0].position, dtype=float)
        raise QuadpipeError.single(
            "missing-end",
            f"a chain of roles ends at {last.name!r}, and the file does not say where its bone ends",
            hint="add an end site below it, or give the chain fewer roles",
        )

    def joint_of(self, role: str) -> JointRecord | None:
        """The joint that has `role` so far."""
        name = next((name for name, given in self.roles.items() if given == role), None)
        return None if name is None else self.records[name]

    def synthesise(self, record: JointRecord, role: str, rig_joint: str, *, insert: bool) -> None:
        """Add a synthesised role's joint."""
        self.add(record, role, rig_joint, insert=insert)
        self.synthesised.append(role)

    def synthesise_scapula(self, leg: str, frame: _Frame) -> None:
        """A scapula for a fore leg with a shoulder but no scapula: a joint above and behind the
        shoulder (`SCAPULA_PER_HUMERUS`), inserted between the shoulder and its parent; the
        rig joint above the shoulder carries it."""
        shoulder, elbow = self.joint_of(f"{leg}_shoulder"), self.joint_of(f"{leg}_elbow")
        role = f"{leg}_scapula"
        if not leg.endswith("f") or self.joint_of(role) or shoulder is None or elbow is None or not shoulder.parent:
            return
        assert frame.forward is not None, "synthesis needs the rig's forward direction"
        start = np.asarray(shoulder.position, dtype=float)
        humerus = float(np.linalg.norm(np.asarray(elbow.position, dtype=float) - start))
        outward = frame.left if leg.startswith("l") else -frame.left
        forward, out, up = (humerus * share for share in SCAPULA_PER_HUMERUS)
        at = start + forward * frame.forward + out * outward + up * frame.up
        record = JointRecord(f"{shoulder.name}{SEPARATOR}{role}", shoulder.parent, _point(at), line=shoulder.line)
        self.records[shoulder.name] = replace(shoulder, parent=record.name)
        self.synthesise(record, role, self.origin[shoulder.parent], insert=False)

    def synthesise_toes(self, leg: str, frame: _Frame) -> None:
        """A toe chain for a leg whose foot bone has no toes: level and straight forward from
        the foot's end site, `TOE_CHAIN_PER_FOOT` of the foot's length, split evenly; the foot's
        rig joint carries it."""
        chain = leg_chain(leg)
        first_toe = next(index for index, bone in enumerate(chain) if "pha" in bone)
        toes = [f"{leg}_{bone}" for bone in chain[first_toe:]]
        foot = self.joint_of(f"{leg}_{chain[first_toe - 1]}")
        if foot is None or any(self.joint_of(toe) for toe in toes):
            return
        assert frame.forward is not None, "synthesis needs the rig's forward direction"
        ends = [j for j in self.children(foot.name) if j.name not in self.roles]
        if foot.end is None and len(ends) != 1:
            return
        end = np.asarray(foot.end if foot.end is not None else ends[0].position, dtype=float)
        step = TOE_CHAIN_PER_FOOT * float(np.linalg.norm(end - np.asarray(foot.position, dtype=float))) / len(toes)
        parent = foot.name
        for index, role in enumerate(toes):
            start = end + frame.forward * step * index
            tip = _point(start + frame.forward * step) if index == len(toes) - 1 else None
            record = JointRecord(f"{foot.name}{SEPARATOR}{role}", parent, _point(start), end=tip, line=foot.line)
            self.synthesise(record, role, self.origin[foot.name], insert=False)
            parent = record.name


def _point(vector: np.ndarray) -> Vector:
    return float(vector[0]), float(vector[1]), float(vector[2])


def chain_shares(lengths: list[float], count: int) -> list[int]:
    """Roles per bone of a chain: one each, and each further role to the bone whose pieces are
    longest (with fewer roles than bones, the first bones take one each)."""
    if count <= len(lengths) or not lengths:
        return [1] * count
    shares = [1] * len(lengths)
    for _ in range(count - len(lengths)):
        longest = max(range(len(lengths)), key=lambda i: (lengths[i] / shares[i], -i))
        shares[longest] += 1
    return shares


def _synthesis_notes(raw: RawSkeleton, expansion: Expansion) -> tuple[Issue, ...]:
    if not expansion.synthesised:
        return ()
    return (
        Issue(
            "synthesised-roles",
            f"the rig has no bone for {len(expansion.synthesised)} role(s), made from its neighbours: "
            + ", ".join(expansion.synthesised),
            raw.where(),
            "map them (--roles) to bones of the rig if it has them",
            severity="note",
        ),
    )


def order_parents_first(names: list[str], parent: Mapping[str, str | None]) -> list[str]:
    """`names` reordered so that every parent comes before its children (stable otherwise)."""
    placed: dict[str, None] = {}

    def place(name: str) -> None:
        up = parent.get(name)
        if up is not None and up in parent and up not in placed:
            place(up)
        placed[name] = None

    for name in names:
        if name not in placed:
            place(name)
    return list(placed)


def make_binding(raw: RawSkeleton, expansion: Expansion, skeleton: Skeleton) -> RigBinding | None:
    """The binding of the rig's own joints (`raw`'s) to the assembled bones.

    Returns:
        None when the rig is the reference hierarchy itself (every joint named after its one
        role, nothing split, synthesised or extra): writing the roles is writing the rig.
    """
    own: dict[str, list[str]] = {}
    for role, rig_joint in expansion.carrier.items():
        if role not in expansion.synthesised:
            own.setdefault(rig_joint, []).append(role)
    if not expansion.synthesised and all(own.get(j.name) == [j.name] for j in raw.joints):
        return None
    axes, scale = body_frame(replace(raw, joints=expansion.joints), expansion.roles)

    def to_body(point: Vector) -> np.ndarray:
        return axes @ (np.asarray(point, dtype=float) * scale)

    order = {role: index for index, role in enumerate(ROLES)}
    parent = {j.name: j.parent for j in raw.joints}
    by_name = {j.name: j for j in raw.joints}
    drive: dict[str, str] = {}
    joints = []
    for name in order_parents_first(list(parent), parent):
        joint = by_name[name]
        roles = tuple(sorted(own.get(name, ()), key=order.__getitem__))
        above = joint.parent
        drive[name] = roles[0] if roles else drive.get(above or "", "pelvis")
        position = to_body(joint.position)
        end = None if joint.end is None else to_body(joint.end) - position
        offset = position - skeleton[drive[name]].start
        joints.append(RigJoint(name, joint.parent, roles, drive[name], offset, end, joint.line))
    return RigBinding(raw.source, tuple(joints), dict(expansion.carrier), expansion.synthesised, raw.units, axes)
