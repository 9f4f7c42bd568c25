"""Write tests/fixtures/rigs_out/: production-like rigs made from a built-in skeleton.

`dog_short.bvh` is the dog (configs/skeletons/dog.xml) as an animator's rig would have it:
two spine bones, two neck bones, two tail bones, three-bone legs with no scapula and no toes
(each foot ends at an End Site on the toe tip), and extra bones the model does not need: a
jaw and two ears. `dog_short_roles.yaml` maps it in nine lines. `dog_short_zup_mm.bvh` is the
same rig as a z-up tool in millimetres would save it (+X the animal's right, +Y forward), with
its role map saying so. `dog_short.ma` is the same rig saved by Maya: joints with local
translations, an end joint (`<joint>_end`) where each leaf bone ends. Deterministic: the same
skeleton gives the same bytes. Usage: `python tools/make_rig_fixtures.py [OUTPUT_FOLDER]`.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from quadpipe.core import configs
from quadpipe.importers import read_raw_skeleton

OUT = Path(__file__).resolve().parent.parent / "tests" / "fixtures" / "rigs_out"

ROLE_MAP = """\
roles:
  Hips: pelvis
  Spine1: [spine0, spine1, spine2]
  Chest: thorax
  Neck1: [neck0, neck1, neck2, neck3, neck4]
  Head: head
  Tail1: [tail0, tail1, tail2, tail3]
  "*_UpperArm": [shoulder, elbow, wrist]
  "*_Thigh": [hip, knee, ankle]
"""
"""The rig's role map: nine lines (scapulae and toes are synthesised, jaw and ears are extras)."""

ZUP_MM = np.array([[-10.0, 0.0, 0.0], [0.0, 0.0, 10.0], [0.0, 10.0, 0.0]])
"""From the dog file's axes (cm; +X left, +Y up, +Z forward) to the z-up file's (mm; +X right,
+Y forward, +Z up): a proper rotation, scaled."""

ROOT_CHANNELS = "CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation"
JOINT_CHANNELS = "CHANNELS 3 Zrotation Xrotation Yrotation"


@dataclass
class Joint:
    """A joint of the rig being written: its position (cm, y up) and children."""

    name: str
    position: np.ndarray
    end: np.ndarray | None = None
    children: list[Joint] = field(default_factory=list)

    def add(self, child: Joint) -> Joint:
        self.children.append(child)
        return child


def dog_short() -> Joint:
    """The dog with fewer bones and a few extras (see the module docstring)."""
    raw = read_raw_skeleton(configs.config_root() / "skeletons" / "dog.xml")
    at = {joint.role: np.array(joint.position) for joint in raw.joints}
    end = {joint.role: np.array(joint.end) for joint in raw.joints if joint.end is not None}
    hips = Joint("Hips", at["pelvis"])
    spine = hips.add(Joint("Spine1", at["spine0"])).add(Joint("Spine2", at["spine2"]))
    chest = spine.add(Joint("Chest", at["thorax"]))
    head = chest.add(Joint("Neck1", at["neck0"])).add(Joint("Neck2", at["neck2"])).add(Joint("Head", at["head"]))
    head.end = end["head"]
    snout = end["head"] - at["head"]
    head.add(Joint("Jaw", at["head"] + 0.2 * snout + [0, -3.0, 0], end=at["head"] + 0.8 * snout + [0, -4.0, 0]))
    for side, sign in (("L", 1.0), ("R", -1.0)):
        ear = at["head"] + [sign * 3.0, 2.0, 1.0]
        head.add(Joint(f"Ear_{side}", ear, end=ear + [sign * 2.0, 6.0, -1.0]))
    hips.add(Joint("Tail1", at["tail0"])).add(Joint("Tail2", at["tail2"], end=end["tail3"]))
    for side, leg in (("L", "l"), ("R", "r")):
        arm = chest.add(Joint(f"{side}_UpperArm", at[f"{leg}f_shoulder"]))
        arm = arm.add(Joint(f"{side}_Forearm", at[f"{leg}f_elbow"]))
        arm.add(Joint(f"{side}_Hand", at[f"{leg}f_wrist"], end=end[f"{leg}f_fpha1"]))
        thigh = hips.add(Joint(f"{side}_Thigh", at[f"{leg}h_hip"]))
        shin = thigh.add(Joint(f"{side}_Shin", at[f"{leg}h_knee"]))
        shin.add(Joint(f"{side}_Foot", at[f"{leg}h_ankle"], end=end[f"{leg}h_hpha2"]))
    return hips


def transformed(joint: Joint, matrix: np.ndarray) -> Joint:
    """A copy of a rig with every point multiplied by `matrix`."""
    end = None if joint.end is None else matrix @ joint.end
    copy = Joint(joint.name, matrix @ joint.position, end)
    copy.children = [transformed(child, matrix) for child in joint.children]
    return copy


def numbers(values: np.ndarray) -> str:
    """Coordinates with four decimals, never -0.0000."""
    return " ".join(f"{v:.4f}" for v in np.round(values, 4) + 0.0)


def bvh_text(root: Joint) -> str:
    """A BVH file of the rig, centimetres, y up, with one frame of its rest pose."""
    lines = ["HIERARCHY"]
    channels = 0

    def write(joint: Joint, parent: np.ndarray | None, depth: int) -> None:
        nonlocal channels, lines
        pad = "\t" * depth
        offset = joint.position - (parent if parent is not None else 0.0)
        lines.extend([f"{pad}{'ROOT' if parent is None else 'JOINT'} {joint.name}", f"{pad}{{"])
        lines.append(f"{pad}\tOFFSET {numbers(offset)}")
        lines.append(f"{pad}\t{ROOT_CHANNELS if parent is None else JOINT_CHANNELS}")
        channels += 6 if parent is None else 3
        for child in joint.children:
            write(child, joint.position, depth + 1)
        if joint.end is not None:
            lines += [f"{pad}\tEnd Site", f"{pad}\t{{", f"{pad}\t\tOFFSET {numbers(joint.end - joint.position)}"]
            lines.append(f"{pad}\t}}")
        lines.append(f"{pad}}}")

    write(root, None, 0)
    rest = np.zeros(channels)
    rest[:3] = root.position
    lines += ["MOTION", "Frames: 1", "Frame Time: 0.0333333", numbers(rest)]
    return "\n".join(lines) + "\n"


def ma_text(root: Joint) -> str:
    """A Maya ASCII file of the rig: a joint per rig joint (local `.t`, cm), end joints for the
    End Sites, listed first under their joint (the bone's end is its first child)."""
    lines = ["//Maya ASCII 2020 scene", "//Name: dog_short.ma", 'requires maya "2020";']
    lines.append("currentUnit -l centimeter -a degree -t film;")

    def write(joint: Joint, parent: Joint | None) -> None:
        where = f' -p "{parent.name}"' if parent is not None else ""
        local = joint.position - (parent.position if parent is not None else 0.0)
        lines.extend(
            [f'createNode joint -n "{joint.name}"{where};', f'\tsetAttr ".t" -type "double3" {numbers(local)} ;']
        )
        if joint.end is not None:
            end = joint.end - joint.position
            lines.append(f'createNode joint -n "{joint.name}_end" -p "{joint.name}";')
            lines.append(f'\tsetAttr ".t" -type "double3" {numbers(end)} ;')
        for child in joint.children:
            write(child, joint)

    write(root, None)
    return "\n".join(lines) + "\n"


def main(out: Path = OUT) -> None:
    """Write the fixtures into `out`."""
    out.mkdir(parents=True, exist_ok=True)
    (out / "dog_short.bvh").write_text(bvh_text(dog_short()))
    (out / "dog_short_roles.yaml").write_text(ROLE_MAP)
    (out / "dog_short.ma").write_text(ma_text(dog_short()))
    (out / "dog_short_zup_mm.bvh").write_text(bvh_text(transformed(dog_short(), ZUP_MM)))
    (out / "dog_short_zup_mm_roles.yaml").write_text("units: mm\nup: z\n" + ROLE_MAP)


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else OUT)
