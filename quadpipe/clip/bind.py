"""Bind poses whose joints point along their bones, for the formats animators open in Blender.

A clip's bone frames are world-aligned at rest (`quadpipe.clip.model`). Blender draws a joint
of a glTF or USD skeleton as a bone along the joint's local +Y axis, so world-aligned frames
show every bone pointing the same way (up in glTF, sideways in USD). `bound_poses` turns each
joint frame by a fixed *bind rotation*, the shortest turn taking the format's bone axis to the
bone's own direction (its joint to its end), and gives the local transforms of the turned
frames at rest and on every frame. The motion is the same: a joint frame is `R(t) B`, where
`R(t)` is the clip's rotation and `B` the bind rotation, and skinning through the inverse bind
matrix cancels `B`.

A track on a rig's own joints (`quadpipe.clip.retarget`) whose file gives every joint its
orientation (Maya's joint orient and rotations, a BVH's axes) is bound with those instead: each
joint's local axes at rest are the rig's own, in the format's axes, and each joint keeps that
bind offset while it follows the simulated bone it rides on.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from quadpipe.clip.kinematics import Y_UP_AXES, local_poses, multiply, normalize
from quadpipe.clip.model import AnimalTrack

GLTF_BONE_AXIS = np.array([0.0, 0.0, 1.0])
"""A glTF joint's local +Y, in quadpipe's frame (glTF is y up)."""

USD_BONE_AXIS = np.array([0.0, 1.0, 0.0])
"""A USD joint's local +Y, in quadpipe's frame (quadpipe's stages are z up)."""

HALF_TURN_AXIS = np.array([1.0, 0.0, 0.0])
"""The turn used when a bone points exactly against the bone axis: half a turn about +X."""

PARALLEL = 1e-9
"""`1 + cos(angle)` below which a bone points against the axis."""

FORMAT_AXES = (Y_UP_AXES, np.eye(3))
"""Rotations from quadpipe's frame to the formats' world axes (glTF's y up; USD stages keep
quadpipe's): each format's bone axis is its +Y in quadpipe's frame."""


@dataclass(frozen=True)
class BoundPoses:
    """Local transforms of the turned joint frames (each in its parent's turned frame).

    Attributes:
        bind: (B, 4) each joint's bind rotation (w, x, y, z), world.
        rest_translations: (B, 3) at rest; the root's is its world position.
        rest_rotations: (B, 4) at rest.
        translations: (F, B, 3) per frame.
        rotations: (F, B, 4) per frame, hemisphere-continuous.
    """

    bind: np.ndarray
    rest_translations: np.ndarray
    rest_rotations: np.ndarray
    translations: np.ndarray
    rotations: np.ndarray


def bind_rotations(track: AnimalTrack, axis: np.ndarray) -> np.ndarray:
    """(B, 4) the shortest rotation taking `axis` to each bone's direction (identity for a bone
    of no length); on a rig that gives its joints' orientations, those (`rig_bind_rotations`)."""
    rig = track.rig
    binds = rig.binds if rig is not None and track.roles == rig.names else None
    if binds is not None:
        return rig_bind_rotations(binds, axis)
    directions = track.rest_end - track.rest_start
    lengths = np.linalg.norm(directions, axis=-1, keepdims=True)
    unit = np.where(lengths > 0, directions / np.where(lengths > 0, lengths, 1.0), axis)
    cosine = unit @ axis
    quats = np.concatenate([1.0 + cosine[:, None], np.cross(axis, unit)], axis=-1)
    opposite = cosine + 1.0 < PARALLEL
    quats[opposite] = np.concatenate([[0.0], HALF_TURN_AXIS])
    return normalize(quats)


def rig_bind_rotations(binds: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """(J, 4) bind rotations that show each rig joint with its own local axes (`binds`, columns,
    quadpipe's frame) in the axes of the format whose bone axis is `axis`: a format writing a
    rotation `B` as `F B F^T` (F: `FORMAT_AXES`) shows the joint's axes as `F binds`, so
    `B = binds F`."""
    to_format = next(axes for axes in FORMAT_AXES if np.allclose(axes[1], axis))
    return matrix_quaternions(binds @ to_format)


def matrix_quaternions(matrices: np.ndarray) -> np.ndarray:
    """(..., 4) unit quaternions (w, x, y, z) of (..., 3, 3) rotation matrices: each from the
    largest of its four components, which is never small (exact for half turns too)."""
    m = matrices
    trace = np.stack([m[..., 0, 0], m[..., 1, 1], m[..., 2, 2]], axis=-1)
    signs = np.array([[1.0, 1.0, 1.0], [1.0, -1.0, -1.0], [-1.0, 1.0, -1.0], [-1.0, -1.0, 1.0]])
    sizes = np.sqrt(np.maximum(0.0, 1.0 + trace @ signs.T)) / 2.0  # |w|, |x|, |y|, |z|
    skew = [m[..., 2, 1] - m[..., 1, 2], m[..., 0, 2] - m[..., 2, 0], m[..., 1, 0] - m[..., 0, 1]]
    sym = [m[..., 0, 1] + m[..., 1, 0], m[..., 0, 2] + m[..., 2, 0], m[..., 1, 2] + m[..., 2, 1]]
    # 4 x (largest component) times each component, for each choice of the largest one
    branches = np.stack(
        [
            np.stack([4 * sizes[..., 0] ** 2, skew[0], skew[1], skew[2]], axis=-1),
            np.stack([skew[0], 4 * sizes[..., 1] ** 2, sym[0], sym[1]], axis=-1),
            np.stack([skew[1], sym[0], 4 * sizes[..., 2] ** 2, sym[2]], axis=-1),
            np.stack([skew[2], sym[1], sym[2], 4 * sizes[..., 3] ** 2], axis=-1),
        ],
        axis=-2,
    )
    largest = np.argmax(sizes, axis=-1)[..., None, None]
    return normalize(np.take_along_axis(branches, largest, axis=-2)[..., 0, :])


def bound_poses(track: AnimalTrack, axis: np.ndarray) -> BoundPoses:
    """The joint frames turned to point along their bones (see the module docstring)."""
    bind = bind_rotations(track, axis)
    moving = dataclasses.replace(track, rotations=multiply(normalize(track.rotations), bind))
    rest = dataclasses.replace(track, positions=track.rest_start[None], rotations=bind[None])
    translations, rotations = local_poses(moving)
    rest_translations, rest_rotations = local_poses(rest)
    return BoundPoses(bind, rest_translations[0], rest_rotations[0], translations, rotations)
