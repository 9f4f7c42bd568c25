"""Generate the production-style rig fixtures, `tests/fixtures/rigs/`, from the built-in skeletons.

Run from the repository root:

    PYTHONPATH=$PWD .venv/bin/python tools/make_rigs.py

Each rig takes a built-in animal's rest pose (`configs/skeletons/<animal>.xml`: centimetres,
y up, z forward, x to the animal's left) and rewrites it as an animator's file would be:
other joint names (Maya `L_`/`R_`, 3ds Max Biped, mocap `LeftArm`, Rigify `.L`/`.R`,
`F`/`B`), other roots (a centre-of-gravity joint, `Bip01`), fewer or extra bones, other
units, channel orders, and Maya's `setAttr` clutter (locks, keyable flags, value-less lines,
multi-line values, constraints and connections). `rigs.yaml` lists every rig with the truth
the tests check against (the source animal's pelvis height HP). The output is deterministic.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml

from quadpipe.anatomy.roles import CHILDREN, MAIN_CHILD, PARENT, ROLES
from quadpipe.importers import load_skeleton
from quadpipe.importers.bvh_motion import axis_rotation
from quadpipe.importers.quadpipe_xml import read_skeleton as read_xml

REPO = Path(__file__).resolve().parent.parent
SOURCES = REPO / "configs" / "skeletons"
OUTPUT_DIR = REPO / "tests" / "fixtures" / "rigs"

DECIMALS = 4
"""Digits written after the point (file units)."""

INCH_CM = 2.54
"""Centimetres per inch."""


@dataclass
class RigJoint:
    """One joint of a rig: its name, parent name, world position (cm) and leaf end (cm)."""

    name: str
    parent: str | None
    position: np.ndarray
    end: np.ndarray | None = None
    children: list[str] = field(default_factory=list)


@dataclass
class Rig:
    """Joints in parents-first order, by name."""

    joints: dict[str, RigJoint] = field(default_factory=dict)

    def add(self, name: str, parent: str | None, position: Sequence[float], end: Sequence[float] | None = None) -> None:
        self.joints[name] = RigJoint(
            name, parent, np.asarray(position, float), None if end is None else np.asarray(end, float)
        )
        if parent is not None:
            self.joints[parent].children.append(name)

    def roots(self) -> list[RigJoint]:
        return [j for j in self.joints.values() if j.parent is None]


def source_points(animal: str) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """Role -> joint position and role -> end (leaves), in cm, from a built-in skeleton."""
    raw = read_xml(SOURCES / f"{animal}.xml")
    positions = {j.role: np.asarray(j.position, float) for j in raw.joints if j.role}
    ends = {j.role: np.asarray(j.end, float) for j in raw.joints if j.role and j.end is not None}
    return positions, ends


def chain_end(role: str, kept: set[str], positions: dict[str, np.ndarray], ends: dict[str, np.ndarray]) -> np.ndarray:
    """Where a kept joint's bone ends when none of its children is kept: its chain's far end."""
    current = role
    while CHILDREN[current]:
        current = MAIN_CHILD.get(current, CHILDREN[current][0])
        if current in kept:
            return positions[current]
    return ends[current]


def rig_from_roles(
    animal: str, names: dict[str, str], parents: dict[str, str] | None = None, rig: Rig | None = None
) -> Rig:
    """A rig keeping the roles named in `names` (role -> joint name); dropped roles vanish.

    `parents` moves joints (joint name -> new parent joint name, already in `rig`).
    """
    positions, ends = source_points(animal)
    kept = set(names)
    rig = rig or Rig()
    for role in ROLES:
        if role not in kept:
            continue
        parent = PARENT[role]
        while parent is not None and parent not in kept:
            parent = PARENT[parent]
        name = names[role]
        parent_name = (parents or {}).get(name, names[parent] if parent else None)
        leaf = not any(child in kept for child in _descendants(role))
        end = chain_end(role, kept, positions, ends) if leaf else None
        rig.add(name, parent_name, positions[role], end)
    return rig


def _descendants(role: str) -> list[str]:
    found, stack = [], list(CHILDREN[role])
    while stack:
        current = stack.pop()
        found.append(current)
        stack.extend(CHILDREN[current])
    return found


def ordered(rig: Rig) -> list[RigJoint]:
    """Joints parents first (depth first from each root, children in insertion order)."""
    out: list[RigJoint] = []
    stack = list(reversed(rig.roots()))
    while stack:
        joint = stack.pop()
        out.append(joint)
        stack.extend(rig.joints[c] for c in reversed(joint.children))
    return out


def num(value: float) -> str:
    text = f"{value:.{DECIMALS}f}".rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


# -- BVH -------------------------------------------------------------------------------------


@dataclass
class BvhStyle:
    """How a BVH rig is written: channel order, unit, and joints posed away from standing.

    `bent` maps a joint name to degrees about the lateral (x) axis: its subtree's offsets are
    written turned by -angle, and the standing frame turns it back by +angle.
    """

    rotation_order: str = "ZXY"
    root_position_first: bool = True
    scale: float = 1.0
    bent: dict[str, float] = field(default_factory=dict)
    frames: int = 1


def write_bvh(rig: Rig, path: Path, style: BvhStyle) -> None:
    """A BVH file of the rig (with a MOTION section whose `standing frame` is the rest pose)."""
    lines = ["HIERARCHY"]
    channels: list[tuple[str, str]] = []
    turn = {name: np.eye(3) for name in rig.joints}
    for joint in ordered(rig):
        if joint.parent is not None:
            turn[joint.name] = turn[joint.parent]
        if joint.name in style.bent:
            turn[joint.name] = axis_rotation("x", -style.bent[joint.name]) @ turn[joint.name]

    def emit(joint: RigJoint, depth: int) -> None:
        pad = "\t" * depth
        keyword = "ROOT" if joint.parent is None else "JOINT"
        origin = rig.joints[joint.parent].position if joint.parent else np.zeros(3)
        basis = turn[joint.parent] if joint.parent else np.eye(3)
        offset = basis @ (joint.position - origin) * style.scale
        rotations = [f"{axis}rotation" for axis in style.rotation_order]
        names = rotations
        if joint.parent is None:
            positions = ["Xposition", "Yposition", "Zposition"]
            names = positions + rotations if style.root_position_first else rotations + positions
        channels.extend((joint.name, n) for n in names)
        lines.append(f"{pad}{keyword} {joint.name}")
        lines.append(f"{pad}{{")
        lines.append(f"{pad}\tOFFSET {' '.join(num(v) for v in offset)}")
        lines.append(f"{pad}\tCHANNELS {len(names)} {' '.join(names)}")
        for child in joint.children:
            emit(rig.joints[child], depth + 1)
        if joint.end is not None:
            end = turn[joint.name] @ (joint.end - joint.position) * style.scale
            lines.extend(
                [f"{pad}\tEnd Site", f"{pad}\t{{", f"{pad}\t\tOFFSET {' '.join(num(v) for v in end)}", f"{pad}\t}}"]
            )
        lines.append(f"{pad}}}")

    for root in rig.roots():
        emit(root, 0)
    lines += ["MOTION", f"Frames: {style.frames}", "Frame Time: 0.0333333"]
    for frame in range(style.frames):
        values = []
        for name, channel in channels:
            joint = rig.joints[name]
            if channel.endswith("position"):
                values.append(joint.position["XYZ".index(channel[0])] * style.scale)
            elif frame == 1 and channel == "Xrotation" and name in style.bent:
                values.append(style.bent[name])
            else:
                values.append(0.0)
        lines.append(" ".join(num(v) for v in values))
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")


# -- Maya ASCII ------------------------------------------------------------------------------


def world_rotation(rig: Rig, joint: RigJoint) -> float:
    """The angle gamma of a joint's world rotation Rz(gamma) Ry(90) (row vectors, Maya's
    convention): local Z is the lateral axis (+x), local X points along the bone."""
    child = rig.joints[joint.children[0]].position if joint.children else joint.end
    if child is None:
        return 0.0
    direction = child - joint.position
    return math.degrees(math.atan2(direction[1], -direction[2]))


def maya_rotation(gamma: float) -> np.ndarray:
    """Rz(gamma) Ry(90) for row vectors, as 3x3 (rows are the local axes in world space)."""
    from quadpipe.importers.maya_matrices import euler_matrix

    return (euler_matrix(np.radians([0.0, 0.0, gamma])) @ euler_matrix(np.radians([0.0, 90.0, 0.0])))[:3, :3]


CLUTTER = (
    '\tsetAttr -l on ".tx";',
    '\tsetAttr -k off ".v";',
    '\tsetAttr -av ".rx";',
    '\tsetAttr -k on -cb on ".ry";',
    '\tsetAttr -l on -k off ".sx";',
    '\tsetAttr ".mnrl" -type "double3" -360 -360 -360 ;',
    '\tsetAttr ".radi" 0.5;',
)
"""The `setAttr` lines riggers' files are full of, none of which places a joint."""


@dataclass
class MayaStyle:
    """Extras of a Maya rig: a top group, constraints and connections that place joints."""

    group: str
    parent_constrained: str | None = None
    point_constrained: str | None = None
    translate_connected: str | None = None
    keyed: str | None = None


def with_end_joints(rig: Rig) -> Rig:
    """The rig with each leaf end written as an end joint (`<name>_end`), as Maya rigs have."""
    out = Rig()
    for joint in ordered(rig):
        out.add(joint.name, joint.parent, joint.position)
        if joint.end is not None:
            out.add(f"{joint.name}_end", joint.name, joint.end)
    return out


def write_maya(rig: Rig, path: Path, style: MayaStyle) -> None:
    """A Maya ASCII file of the rig: joints with jointOrient and rotate values under a group."""
    rig = with_end_joints(rig)
    gammas = {name: world_rotation(rig, joint) for name, joint in rig.joints.items()}
    lines = [
        "//Maya ASCII 2022 scene",
        f"//Name: {path.name}",
        "//Last modified: generated by tools/make_rigs.py",
        "//Codeset: UTF-8",
        'requires maya "2022";',
        'requires "stereoCamera" "10.0";',
        "currentUnit -l centimeter -a degree -t ntsc;",
        'fileInfo "application" "maya";',
        f'createNode transform -n "{style.group}";',
        '\tsetAttr ".t" -type "double3"\n\t\t 0 0 0 ;',
        '\tsetAttr -l on -k off ".v";',
    ]
    connections: list[str] = []
    for index, joint in enumerate(ordered(rig)):
        parent = rig.joints[joint.parent] if joint.parent else None
        gamma_parent = gammas[parent.name] if parent else 0.0
        rotate = (index * 7) % 23 - 11.0  # an arbitrary animator's rotate value, about local z
        parent_rotation = maya_rotation(gamma_parent) if parent else np.eye(3)
        origin = parent.position if parent else np.zeros(3)
        translate = (joint.position - origin) @ parent_rotation.T
        orient = (0.0, 0.0, gammas[joint.name] - gamma_parent - rotate)
        lines.append(f'createNode joint -n "{joint.name}" -p "{parent.name if parent else style.group}";')
        lines.append('\taddAttr -ci true -sn "liw" -ln "lockInfluenceWeights" -min 0 -max 1 -at "bool";')
        lines.extend(CLUTTER[index % len(CLUTTER) :] + CLUTTER[: index % len(CLUTTER)])
        driven = joint.name in (style.parent_constrained, style.point_constrained, style.translate_connected)
        if not driven:
            lines.append(f'\tsetAttr ".t" -type "double3" {" ".join(num(v) for v in translate)} ;')
        else:
            lines.append('\tsetAttr ".t" -type "double3" 0 0 0 ;')
        if joint.name == style.parent_constrained:
            lines.append('\tsetAttr ".r" -type "double3" 0 0 0 ;')
        elif parent is None:  # the root turns in zyx order: Rz(gamma) Ry(90), no joint orient
            lines.append(f'\tsetAttr ".r" -type "double3" 0 90 {num(gammas[joint.name])} ;\n\tsetAttr ".ro" 5;')
            orient = (0.0, 0.0, 0.0)
        else:
            lines.append(f'\tsetAttr ".r" -type "double3" 0 0 {num(rotate)} ;')
        lines.append(f'\tsetAttr ".jo" -type "double3"\n\t\t{" ".join(num(v) for v in orient)} ;')
        lines.append('\tsetAttr ".bps" -type "matrix" 1 0 0 0 0 1 0 0 0 0 1 0\n\t\t 0 0 0 1;')
        if joint.name == style.translate_connected:
            driver = f"{joint.name}_drv"
            lines.append(f'createNode transform -n "{driver}" -p "{style.group}";')
            lines.append(f'\tsetAttr ".t" -type "double3" {" ".join(num(v) for v in translate)} ;')
            connections.append(f'connectAttr "{driver}.t" "{joint.name}.t";')
        if joint.name in (style.parent_constrained, style.point_constrained):
            lines.extend(_constraint(joint, gammas[joint.name], style, connections))
        if joint.name == style.keyed:
            curve = f"{joint.name}_rotateX"
            lines.append(f'createNode animCurveTA -n "{curve}";')
            lines.append('\tsetAttr ".tan" 18;\n\tsetAttr -s 2 ".ktv[0:1]"  1 0 24 0;')
            connections.append(f'connectAttr "{curve}.o" "{joint.name}.rx";')
    lines.append('select -ne :time1;\n\tsetAttr ".o" 1;')
    lines.extend(connections)
    lines.append(f"// End of {path.name}")
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")


def _constraint(joint: RigJoint, gamma: float, style: MayaStyle, connections: list[str]) -> list[str]:
    """A control placed where the joint belongs, and a one-target constraint from it."""
    kind = "parentConstraint" if joint.name == style.parent_constrained else "pointConstraint"
    control = f"{joint.name}_ctrl"
    node = f"{joint.name}_{kind}1"
    lines = [
        f'createNode transform -n "{control}" -p "{style.group}";',
        f'\tsetAttr ".t" -type "double3" {" ".join(num(v) for v in joint.position)} ;',
        '\tsetAttr ".ro" 5;',
        f'\tsetAttr ".r" -type "double3" 0 90 {num(gamma)} ;',
        f'createNode {kind} -n "{node}" -p "{joint.name}";',
        '\taddAttr -dcb 0 -ci true -k true -sn "w0" -ln "target0W0" -dv 1 -min 0 -at "double";',
        '\tsetAttr -k on ".nds";',
        '\tsetAttr -k off ".v";',
    ]
    outputs = ("ctx", "cty", "ctz", "crx", "cry", "crz") if kind == "parentConstraint" else ("ctx", "cty", "ctz")
    for output in outputs:
        connections.append(f'connectAttr "{node}.{output}" "{joint.name}.{output[1:]}";')
    connections.append(f'connectAttr "{control}.t" "{node}.tg[0].tt";')
    connections.append(f'connectAttr "{control}.pm" "{node}.tg[0].tpm";')
    connections.append(f'connectAttr "{node}.w0" "{node}.tg[0].tw";')
    return lines


# -- the rigs --------------------------------------------------------------------------------


def side_names(template: Callable[[str, str], str], bones: dict[str, str]) -> dict[str, str]:
    """Leg role -> name for the four legs, from `template(side, bone name)`."""
    names = {}
    for leg in ("lf", "rf", "lh", "rh"):
        for kind, bone in bones.items():
            if kind.startswith(("scapula", "shoulder", "elbow", "wrist", "fpha")) == leg.endswith("f"):
                names[f"{leg}_{kind}"] = template(leg, bone)
    return names


FRONT_KINDS = ("scapula", "shoulder", "elbow", "wrist", "fpha0", "fpha1")
HIND_KINDS = ("hip", "knee", "ankle", "hpha0", "hpha1", "hpha2")


def wolf_cog() -> tuple[Rig, dict]:
    """Maya: a COG root above the pelvis, `L_`/`R_` names, constraints and connections."""
    bones = dict(
        zip(
            FRONT_KINDS + HIND_KINDS,
            (
                "Scapula",
                "Shoulder",
                "Elbow",
                "Wrist",
                "FrontToe1",
                "FrontToe2",
                "Hip",
                "Knee",
                "Ankle",
                "Toe1",
                "Toe2",
                "Toe3",
            ),
        )
    )
    names = {
        "pelvis": "Pelvis",
        "spine0": "Spine1",
        "spine1": "Spine2",
        "spine2": "Spine3",
        "thorax": "Chest",
        "head": "Head",
    }
    names |= {f"neck{i}": f"Neck{i + 1}" for i in range(5)} | {f"tail{i}": f"Tail{i + 1}" for i in range(4)}
    names |= side_names(lambda leg, bone: f"{leg[0].upper()}_{bone}", bones)
    positions, _ = source_points("dog")
    rig = Rig()
    rig.add("COG", None, positions["pelvis"] + np.array([0.0, 4.0, 6.0]))
    rig_from_roles("dog", names, parents={"Pelvis": "COG", "Spine1": "COG"}, rig=rig)
    style = MayaStyle(
        "wolf_rig", parent_constrained="Head", point_constrained="Tail1", translate_connected="L_Hip", keyed="L_Knee"
    )
    return rig, {"animal": "dog", "maya": style}


def biped_lion() -> tuple[Rig, dict]:
    """3ds Max Biped BVH in inches: `Bip01` root, thighs and tail under `Bip01 Spine`."""
    bones = dict(
        zip(
            FRONT_KINDS + HIND_KINDS,
            (
                "Clavicle",
                "UpperArm",
                "Forearm",
                "Hand",
                "Finger0",
                "Finger01",
                "Thigh",
                "Calf",
                "HorseLink",
                "Foot",
                "Toe0",
                "Toe01",
            ),
        )
    )
    names = {
        "pelvis": "Bip01 Spine",
        "spine0": "Bip01 Spine1",
        "spine1": "Bip01 Spine2",
        "spine2": "Bip01 Spine3",
        "thorax": "Bip01 Ribcage",
        "head": "Bip01 Head",
    }
    names |= {f"neck{i}": f"Bip01 Neck{i or ''}" for i in range(5)} | {
        f"tail{i}": f"Bip01 Tail{i or ''}" for i in range(4)
    }
    names |= side_names(lambda leg, bone: f"Bip01 {leg[0].upper()} {bone}", bones)
    positions, _ = source_points("lion")
    rig = Rig()
    rig.add("Bip01", None, positions["pelvis"] * np.array([1.0, 0.0, 1.0]))
    rig.add("Bip01 Pelvis", "Bip01", positions["pelvis"] + np.array([0.0, 0.0, -1.5]))
    rig_from_roles("lion", names, parents={"Bip01 Spine": "Bip01 Pelvis"}, rig=rig)
    return rig, {"animal": "lion", "bvh": BvhStyle("ZXY", scale=1 / INCH_CM), "roles": {"units": "in"}}


def mocap_dog() -> tuple[Rig, dict]:
    """Mocap BVH in metres: `LeftArm` is a fore leg; the zero pose has the legs forward."""
    front = ("LeftShoulder", "LeftArm", "LeftForeArm", "LeftHand", "LeftFinger1", "LeftFinger2")
    hind = ("LeftUpLeg", "LeftLeg", "LeftFoot", "LeftToeBase", "LeftToe1", "LeftToe2")
    names = {
        "pelvis": "Hips",
        "spine0": "Spine",
        "spine1": "Spine1",
        "spine2": "Spine2",
        "thorax": "Spine3",
        "head": "Head",
    }
    names |= {f"neck{i}": f"Neck{i or ''}" for i in range(5)} | {f"tail{i}": f"Tail{i or ''}" for i in range(4)}
    for leg in ("lf", "rf", "lh", "rh"):
        chain = front if leg.endswith("f") else hind
        kinds = FRONT_KINDS if leg.endswith("f") else HIND_KINDS
        for kind, bone in zip(kinds, chain):
            names[f"{leg}_{kind}"] = bone.replace("Left", "Left" if leg[0] == "l" else "Right")
    rig = rig_from_roles("dog", names)
    bent = {name: 90.0 for name in ("LeftArm", "RightArm", "LeftUpLeg", "RightUpLeg")}
    return rig, {"animal": "dog", "bvh": BvhStyle("ZYX", scale=0.01, bent=bent, frames=3), "rest_frame": 1}


def deer_short() -> tuple[Rig, dict]:
    """Rigify `.L`/`.R` BVH: 2 spine, 2 neck and 3-bone legs, no toes (the guess gives chains and
    makes the scapulae and toes)."""
    names = {
        "pelvis": "hips",
        "spine0": "spine.001",
        "spine2": "spine.002",
        "thorax": "chest",
        "neck0": "neck.001",
        "neck3": "neck.002",
        "head": "head",
    }
    names |= {f"tail{i}": f"tail.00{i + 1}" for i in range(4)}
    for leg in ("lf", "rf", "lh", "rh"):
        side = "L" if leg[0] == "l" else "R"
        bones = (
            (("shoulder", "upper_arm"), ("elbow", "forearm"), ("wrist", "hand"))
            if leg.endswith("f")
            else (("hip", "thigh"), ("knee", "shin"), ("ankle", "foot"))
        )
        names |= {f"{leg}_{kind}": f"{bone}.{side}" for kind, bone in bones}
    return rig_from_roles("goat", names), {"animal": "goat", "bvh": BvhStyle("XYZ")}


def elephant_extras() -> tuple[Rig, dict]:
    """Maya, `F`/`B` leg names, with ears, jaw and a trunk under the head."""
    bones = dict(
        zip(
            FRONT_KINDS + HIND_KINDS,
            (
                "Scapula",
                "Humerus",
                "Radius",
                "Carpus",
                "Toe1",
                "Toe2",
                "Femur",
                "Tibia",
                "Tarsus",
                "Toe1",
                "Toe2",
                "Toe3",
            ),
        )
    )
    names = {
        "pelvis": "Root",
        "spine0": "Back1",
        "spine1": "Back2",
        "spine2": "Back3",
        "thorax": "Withers",
        "head": "Head",
    }
    names |= {f"neck{i}": f"Neck{i + 1}" for i in range(5)} | {f"tail{i}": f"Tail{i + 1}" for i in range(4)}
    names |= side_names(lambda leg, bone: f"{'F' if leg.endswith('f') else 'B'}{leg[0].upper()}_{bone}", bones)
    rig = rig_from_roles("elephant", names)
    head = rig.joints["Head"]
    tip = head.end
    assert tip is not None
    head.end = None
    down = np.array([0.0, -1.0, 0.25])
    rig.add("Trunk1", "Head", tip)
    for index in range(2, 5):
        rig.add(f"Trunk{index}", f"Trunk{index - 1}", tip + down * 40.0 * (index - 1))
    rig.joints["Trunk4"].end = tip + down * 160.0
    rig.add("Jaw", "Head", head.position + np.array([0.0, -25.0, 20.0]), head.position + np.array([0.0, -45.0, 60.0]))
    for side, x in (("L", 1.0), ("R", -1.0)):
        rig.add(f"{side}_Ear1", "Head", head.position + np.array([x * 30.0, 5.0, -10.0]))
        rig.add(
            f"{side}_Ear2",
            f"{side}_Ear1",
            head.position + np.array([x * 80.0, 0.0, -20.0]),
            head.position + np.array([x * 110.0, -40.0, -25.0]),
        )
    return rig, {"animal": "elephant", "maya": MayaStyle("elephant_rig")}


def horse_frontback() -> tuple[Rig, dict]:
    """BVH with `Front`/`Back` and `Left`/`Right` words, Xposition..Zrotation Yrotation Xrotation."""
    bones = dict(
        zip(
            FRONT_KINDS + HIND_KINDS,
            (
                "Scapula",
                "Upper",
                "Lower",
                "Cannon",
                "Pastern",
                "Hoof",
                "Upper",
                "Lower",
                "Cannon",
                "Fetlock",
                "Pastern",
                "Hoof",
            ),
        )
    )
    names = {
        "pelvis": "Pelvis",
        "spine0": "Lumbar1",
        "spine1": "Lumbar2",
        "spine2": "Thoracic1",
        "thorax": "Thoracic2",
        "head": "Skull",
    }
    names |= {f"neck{i}": f"Cervical{i + 1}" for i in range(5)} | {f"tail{i}": f"Dock{i + 1}" for i in range(4)}
    names |= side_names(
        lambda leg, bone: f"{'Front' if leg.endswith('f') else 'Back'}{'Left' if leg[0] == 'l' else 'Right'}{bone}",
        bones,
    )
    return rig_from_roles("horse", names), {"animal": "horse", "bvh": BvhStyle("ZYX", root_position_first=False)}


def bad_mirrored_tailless() -> tuple[Rig, dict]:
    """Bad: fore legs named for the other side, and no tail (two problems, one message)."""
    rig, options = horse_frontback()
    for name in [n for n in rig.joints if n.startswith("Dock")]:
        joint = rig.joints.pop(name)
        if joint.parent in rig.joints:
            rig.joints[joint.parent].children.remove(name)
    renamed = Rig()
    swap = {"FrontLeft": "FrontRight", "FrontRight": "FrontLeft"}
    rename = {n: next((n.replace(a, b) for a, b in swap.items() if n.startswith(a)), n) for n in rig.joints}
    for joint in ordered(rig):
        renamed.add(rename[joint.name], rename[joint.parent] if joint.parent else None, joint.position, joint.end)
    return renamed, options


def bad_cut_motion() -> tuple[Rig, dict]:
    """Bad: the mocap rig whose MOTION says 3 frames and holds fewer values."""
    rig, options = mocap_dog()
    return rig, options | {"cut_motion": True}


RIGS: dict[str, Callable[[], tuple[Rig, dict]]] = {
    "wolf_cog.ma": wolf_cog,
    "biped_lion.bvh": biped_lion,
    "mocap_dog.bvh": mocap_dog,
    "deer_short.bvh": deer_short,
    "elephant_extras.ma": elephant_extras,
    "horse_frontback.bvh": horse_frontback,
}
"""File name -> the function building its rig and options."""

BAD_RIGS: dict[str, Callable[[], tuple[Rig, dict]]] = {
    "bad/mirrored_tailless.bvh": bad_mirrored_tailless,
    "bad/cut_motion.bvh": bad_cut_motion,
}
"""Rigs that must fail (`tests/test_rigs_import.py` checks their messages)."""


def main(output_dir: Path = OUTPUT_DIR) -> None:
    """Write every rig, the bad ones under `bad/`, and the manifest `rigs.yaml`."""
    output_dir.mkdir(parents=True, exist_ok=True)
    manifest = {}
    for file_name, make in RIGS.items():
        rig, options = make()
        path = output_dir / file_name
        if "maya" in options:
            write_maya(rig, path, options["maya"])
        else:
            write_bvh(rig, path, options["bvh"])
        entry: dict = {
            "animal": options["animal"],
            "hp_cm": round(load_skeleton(SOURCES / f"{options['animal']}.xml").pelvis_height * 100, 2),
        }
        if "roles" in options:
            roles_path = path.with_suffix(".roles.yaml")
            roles_path.write_text(
                f"# {file_name}: 3ds Max exported it in inches\n" + yaml.safe_dump(options["roles"]), encoding="utf-8"
            )
            entry["roles"] = roles_path.name
        if "rest_frame" in options:
            entry["rest_frame"] = options["rest_frame"]
        manifest[file_name] = entry
        print(f"wrote {path} ({len(rig.joints)} joints, {path.stat().st_size} bytes)")
    (output_dir / "bad").mkdir(exist_ok=True)
    for file_name, make in BAD_RIGS.items():
        rig, options = make()
        path = output_dir / file_name
        write_bvh(rig, path, options["bvh"])
        if options.get("cut_motion"):
            text = path.read_text(encoding="utf-8").rstrip("\n").rsplit("\n", 2)[0]
            path.write_text(text[: text.rindex(" ", 0, len(text) - 40)] + "\n", encoding="utf-8")
        print(f"wrote {path}")
    header = "# Generated by tools/make_rigs.py: rig file -> source animal and truth (HP in cm); do not edit.\n"
    (output_dir / "rigs.yaml").write_text(header + yaml.safe_dump(manifest, sort_keys=False), encoding="utf-8")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else OUTPUT_DIR)
