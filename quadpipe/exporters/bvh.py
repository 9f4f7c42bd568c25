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
  units and axes instead (a z-up rig in millimetres comes back z-up in millimetres), and each
  joint keeps the BVH rig's own CHANNELS line: its channel order and so its rotation order
  (`Xrotation Yrotation Zrotation` is Rx Ry Rz), position channels where the file had them
  (and in front of its rotations where it moves and the file had none). A joint whose
  rotation channels do not name each axis once gets the layout above instead. A BVH rig
  keeps its zero pose too: each joint's OFFSET and channels are in its parent's frame at the
  file's zero pose (`joint_frames`), so a mocap file read at `--rest-frame` comes back with
  its own OFFSETs.
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

POSITION_CHANNELS = ("Xposition", "Yposition", "Zposition")
ROTATION_CHANNELS = ("Zrotation", "Xrotation", "Yrotation")
"""The channels quadpipe writes: positions (root and moving joints), then rotations Rz Rx Ry."""

AXES = "XYZ"

MOVING_JOINT_M = 1e-6
"""A joint whose offset from its parent strays more than this (1 micrometre) from its rest offset
during the clip gets position channels."""

DECIMALS = 6
"""Digits after the point: 1e-6 cm and 1e-6 degrees."""

INDENT = "\t"


def euler_degrees(matrices: np.ndarray, order: str) -> np.ndarray:
    """Angles in degrees about the axes of `order` ("ZXY": R = Rz(a) @ Rx(b) @ Ry(c)), in that
    order, for (..., 3, 3) rotations; `order` names each of X, Y and Z once."""
    i, j, k = (AXES.index(axis) for axis in order)
    sign = 1.0 if (j - i) % 3 == 1 else -1.0  # +1 for the cyclic orders XYZ, YZX, ZXY
    middle = np.arcsin(np.clip(sign * matrices[..., i, k], -1.0, 1.0))
    first = np.arctan2(-sign * matrices[..., j, k], matrices[..., k, k])
    last = np.arctan2(-sign * matrices[..., i, j], matrices[..., i, i])
    return np.degrees(np.stack([first, middle, last], axis=-1))


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
    layout = channel_layout(track)
    frames = joint_frames(track)
    lines = ["HIERARCHY"]
    _write_joint(track, 0, 0, (layout, frames, _into_parent(track, frames)), lines)
    lines += ["MOTION", f"Frames: {track.positions.shape[0]}", f"Frame Time: {1.0 / clip.fps:.8f}"]
    lines += [_numbers(row) for row in motion_rows(track, layout, frames)]
    return "\n".join(lines) + "\n"


def _numbers(values: np.ndarray) -> str:
    """Values with DECIMALS digits, never written as -0.000000."""
    return " ".join(f"{v:.{DECIMALS}f}" for v in np.round(values, DECIMALS) + 0.0)


def on_its_rig(track: AnimalTrack) -> bool:
    """Whether the track is on its rig's own joints (`quadpipe.clip.retarget.on_rig`)."""
    return track.rig is not None and track.roles == track.rig.names


def file_frame(track: AnimalTrack) -> tuple[np.ndarray, float]:
    """Rows taking quadpipe's frame to the file's axes, and file units per metre: the rig's own
    units and axes for a track on a rig's joints, else y up in centimetres."""
    if track.rig is not None and on_its_rig(track):
        return track.rig.axes.T, 1.0 / UNIT_TO_METRES[track.rig.units]
    return Y_UP_AXES, CM_PER_M


def joint_frames(track: AnimalTrack) -> np.ndarray:
    """(B, 3, 3) each joint's axes (columns, quadpipe's frame) at the file's zero pose, where its
    channels are all zero: the file's own axes, or a BVH rig's own joint frames (the turn of
    each joint at `--rest-frame`: `quadpipe.anatomy.binding.RigJoint.bind`), so that the file
    keeps its zero pose (its OFFSETs) and its channels turn from it."""
    axes, _ = file_frame(track)
    rig = track.rig
    if rig is not None and on_its_rig(track) and all(joint.channels for joint in rig.joints):
        binds = rig.binds
        if binds is not None:
            return binds
    return np.tile(axes.T, (len(track.roles), 1, 1))


def _into_parent(track: AnimalTrack, frames: np.ndarray) -> np.ndarray:
    """(B, 3, 3) rows taking quadpipe's frame to each joint's parent's zero-pose axes (the file's
    axes for the root), where its OFFSET, positions and rotations are written."""
    axes, _ = file_frame(track)
    return np.array([axes if parent < 0 else frames[parent].T for parent in track.parents])


def channel_layout(track: AnimalTrack) -> list[tuple[str, ...]]:
    """Each joint's CHANNELS: `POSITION_CHANNELS` for the root and moving joints, then
    `ROTATION_CHANNELS`; a rig joint keeps its own (see the module docstring)."""
    moving = moving_joints(track)
    own = [joint.channels for joint in track.rig.joints] if track.rig is not None and on_its_rig(track) else []
    return [_joint_channels(own[index] if own else (), bool(moves)) for index, moves in enumerate(moving)]


def _joint_channels(own: tuple[str, ...], moves: bool) -> tuple[str, ...]:
    """A joint's own channels when its rotations name each axis once and its positions are
    complete; positions prepended where it moves and has none; else quadpipe's layout."""
    positions = sorted(c[0].upper() for c in own if c.lower().endswith("position"))
    rotations = tuple(c for c in own if c.lower().endswith("rotation"))
    if sorted(c[0].upper() for c in rotations) != list(AXES):
        return (POSITION_CHANNELS if moves else ()) + ROTATION_CHANNELS
    if positions == list(AXES):
        return own
    return (POSITION_CHANNELS if moves else ()) + rotations


def moving_joints(track: AnimalTrack) -> np.ndarray:
    """(B,) whether each joint needs position channels: the root, and the joints whose offset
    from their parent changes (by more than `MOVING_JOINT_M`)."""
    translations, _ = local_poses(track)
    strays = np.abs(translations - rest_offsets(track)).max(axis=(0, 2), initial=0.0)
    return (track.parents < 0) | (strays > MOVING_JOINT_M)


def _write_joint(
    track: AnimalTrack,
    index: int,
    depth: int,
    joints: tuple[list[tuple[str, ...]], np.ndarray, np.ndarray],
    lines: list[str],
) -> None:
    """Append the HIERARCHY block of joint `index` and, recursively, of its children; `joints`
    holds every joint's channels, zero-pose frame (`joint_frames`) and `_into_parent` rows."""
    layout, frames, into = joints
    pad = INDENT * depth
    _, per_metre = file_frame(track)
    offset = into[index] @ rest_offsets(track)[index] * per_metre
    root = track.parents[index] < 0
    lines += [
        f"{pad}{'ROOT' if root else 'JOINT'} {track.roles[index]}",
        f"{pad}{{",
        f"{pad}{INDENT}OFFSET {_numbers(offset)}",
        f"{pad}{INDENT}CHANNELS {len(layout[index])} {' '.join(layout[index])}",
    ]
    children = np.flatnonzero(track.parents == index)
    for child in children:
        _write_joint(track, int(child), depth + 1, joints, lines)
    if children.size == 0:
        end = frames[index].T @ (track.rest_end[index] - track.rest_start[index]) * per_metre
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


def motion_rows(track: AnimalTrack, layout: list[tuple[str, ...]], frames: np.ndarray) -> np.ndarray:
    """(F, C) channel values per frame, joints in hierarchy order, each joint's channels in its
    `layout` order: positions (file units, its parent's zero-pose axes) and angles in its
    rotation order (its turn from its zero-pose frame `frames`, in its parent's)."""
    translations, rotations = local_poses(track)
    _, per_metre = file_frame(track)
    into = _into_parent(track, frames)
    matrices = into[None] @ to_matrix(rotations) @ frames[None]
    positions = np.einsum("bij,fbj->fbi", into, translations) * per_metre
    columns = []
    for index in hierarchy_order(track):
        order = "".join(c[0].upper() for c in layout[index] if c.lower().endswith("rotation"))
        angles = np.degrees(np.unwrap(np.radians(euler_degrees(matrices[:, index], order)), axis=0))
        turns = iter(angles.T)
        for channel in layout[index]:
            is_position = channel.lower().endswith("position")
            columns.append(positions[:, index, AXES.index(channel[0].upper())] if is_position else next(turns))
    return np.stack(columns, axis=1)


def export_bvh(clip: Clip, path: Path) -> None:
    """BVH motion capture: one animal's skeleton (cm, y up) and joint rotations per frame."""
    write_text(path, bvh_text(clip))
