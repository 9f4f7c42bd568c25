"""BVH (Biovision hierarchy): one animal's skeleton and motion, for retargeting tools.

Conventions, as motion-capture tools (Blender, MotionBuilder, Maya's importers) expect them:
y up, the animal facing +Z, +X its left (quadpipe's frame with the axes cycled, so
handedness is kept), lengths in **centimetres** (quadpipe's BVH importer reads centimetres).

- `ROOT pelvis` with `OFFSET` = the pelvis joint's rest position in the world and six
  channels `Xposition Yposition Zposition Zrotation Xrotation Yrotation`; the position
  channels hold the pelvis's world position (absolute, equal to the OFFSET at rest).
- `JOINT <role>` for every other bone, `OFFSET` = its rest offset from its parent's joint,
  three channels `Zrotation Xrotation Yrotation` (degrees): the joint's rotation relative to
  its parent is Rz * Rx * Ry, in that order, as BVH readers compose channels.
- A joint whose offset from its parent changes during the clip (on a rig whose one bone
  carries a bending chain of roles, see `quadpipe.clip.retarget`) has the root's six channels,
  its position channels holding that offset; every other joint keeps its fixed OFFSET.
- An animal written on its rig's own joints (`quadpipe.clip.retarget`) keeps the rig file's
  units and axes instead (a z-up rig in millimetres comes back z-up in millimetres).
- `End Site` under each leaf bone (head, tail tip, toes) at the bone's end.
- `Frame Time` = 1 / fps. Angles are unwrapped frame to frame (no 360-degree jumps).

The rest pose is the clip's rest pose, in which every bone frame is world-aligned, so all
rotations are zero at rest.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from quadpipe.anatomy.skeleton import UNIT_TO_METRES
from quadpipe.clip.kinematics import Y_UP_AXES, local_poses, rest_offsets, to_matrix
from quadpipe.clip.model import AnimalTrack, Clip
from quadpipe.core.atomic import write_text
from quadpipe.core.errors import QuadpipeError

CM_PER_M = 100.0

ROOT_CHANNELS = "CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation"
JOINT_CHANNELS = "CHANNELS 3 Zrotation Xrotation Yrotation"

MOVING_JOINT_M = 1e-6
"""A joint whose offset from its parent strays more than this (1 micrometre) from its rest offset
during the clip gets position channels."""

DECIMALS = 6
"""Digits after the point: 1e-6 cm and 1e-6 degrees."""

INDENT = "\t"


def zxy_euler_degrees(matrices: np.ndarray) -> np.ndarray:
    """Angles (z, x, y) in degrees with R = Rz(z) @ Rx(x) @ Ry(y), for (..., 3, 3) rotations."""
    x = np.arcsin(np.clip(matrices[..., 2, 1], -1.0, 1.0))
    z = np.arctan2(-matrices[..., 0, 1], matrices[..., 1, 1])
    y = np.arctan2(-matrices[..., 2, 0], matrices[..., 2, 2])
    return np.degrees(np.stack([z, x, y], axis=-1))


def bvh_text(clip: Clip) -> str:
    """The BVH file of a one-animal clip.

    Raises:
        QuadpipeError: `bvh-one-animal` when the clip holds no animal or several.
    """
    if len(clip.animals) != 1:
        raise QuadpipeError.single(
            "bvh-one-animal",
            f"a BVH file holds one skeleton, and this clip has {len(clip.animals)} animals",
            hint="export the scene to .glb or .usd instead, or simulate one animal for BVH",
        )
    track = clip.animals[0]  # roles run parents first: bone 0 is the root
    moving = moving_joints(track)
    lines = ["HIERARCHY"]
    _write_joint(track, 0, 0, moving, lines)
    lines += ["MOTION", f"Frames: {track.positions.shape[0]}", f"Frame Time: {1.0 / clip.fps:.8f}"]
    lines += [_numbers(row) for row in motion_rows(track, moving)]
    return "\n".join(lines) + "\n"


def _numbers(values: np.ndarray) -> str:
    """Values with DECIMALS digits, never written as -0.000000."""
    return " ".join(f"{v:.{DECIMALS}f}" for v in np.round(values, DECIMALS) + 0.0)


def file_frame(track: AnimalTrack) -> tuple[np.ndarray, float]:
    """Rows taking quadpipe's frame to the file's axes, and file units per metre: the rig's own
    units and axes for a track on a rig's joints, else y up in centimetres."""
    rig = track.rig
    if rig is not None and track.roles == rig.names:
        return rig.axes.T, 1.0 / UNIT_TO_METRES[rig.units]
    return Y_UP_AXES, CM_PER_M


def moving_joints(track: AnimalTrack) -> np.ndarray:
    """(B,) whether each joint needs position channels: the root, and the joints whose offset
    from their parent changes (by more than `MOVING_JOINT_M`)."""
    translations, _ = local_poses(track)
    strays = np.abs(translations - rest_offsets(track)).max(axis=(0, 2), initial=0.0)
    return (track.parents < 0) | (strays > MOVING_JOINT_M)


def _write_joint(track: AnimalTrack, index: int, depth: int, moving: np.ndarray, lines: list[str]) -> None:
    """Append the HIERARCHY block of joint `index` and, recursively, of its children."""
    pad = INDENT * depth
    axes, per_metre = file_frame(track)
    offset = axes @ rest_offsets(track)[index] * per_metre
    root = track.parents[index] < 0
    lines += [
        f"{pad}{'ROOT' if root else 'JOINT'} {track.roles[index]}",
        f"{pad}{{",
        f"{pad}{INDENT}OFFSET {_numbers(offset)}",
        f"{pad}{INDENT}{ROOT_CHANNELS if moving[index] else JOINT_CHANNELS}",
    ]
    children = np.flatnonzero(track.parents == index)
    for child in children:
        _write_joint(track, int(child), depth + 1, moving, lines)
    if children.size == 0:
        end = axes @ (track.rest_end[index] - track.rest_start[index]) * per_metre
        lines += [
            f"{pad}{INDENT}End Site",
            f"{pad}{INDENT}{{",
            f"{pad}{INDENT * 2}OFFSET {_numbers(end)}",
            f"{pad}{INDENT}}}",
        ]
    lines.append(f"{pad}}}")


def hierarchy_order(track: AnimalTrack) -> list[int]:
    """Bone indices in the order the HIERARCHY lists them (depth first, children in role order)."""
    order: list[int] = []

    def visit(index: int) -> None:
        order.append(index)
        for child in np.flatnonzero(track.parents == index):
            visit(int(child))

    visit(0)
    return order


def motion_rows(track: AnimalTrack, moving: np.ndarray) -> np.ndarray:
    """(F, C) channel values per frame, joints in hierarchy order: each joint's position (the
    root's and the `moving` ones') then its angles."""
    translations, rotations = local_poses(track)
    axes, per_metre = file_frame(track)
    in_file = np.concatenate([rotations[..., :1], rotations[..., 1:] @ axes.T], axis=-1)  # a proper rotation
    angles = zxy_euler_degrees(to_matrix(in_file))
    angles = np.degrees(np.unwrap(np.radians(angles), axis=0))
    positions = translations @ axes.T * per_metre
    columns = []
    for index in hierarchy_order(track):
        if moving[index]:
            columns.append(positions[:, index])
        columns.append(angles[:, index])
    return np.concatenate(columns, axis=1)


def export_bvh(clip: Clip, path: Path) -> None:
    """BVH motion capture: one animal's skeleton (cm, y up) and joint rotations per frame."""
    write_text(path, bvh_text(clip))
