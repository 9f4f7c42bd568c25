"""Bind poses whose joints point along their bones, for the formats animators open in Blender.

A clip's bone frames are world-aligned at rest (`quadpipe.clip.model`). Blender draws a joint
of a glTF or USD skeleton as a bone along the joint's local +Y axis, so world-aligned frames
show every bone pointing the same way (up in glTF, sideways in USD). `bound_poses` turns each
joint frame by a fixed *bind rotation*, the shortest turn taking the format's bone axis to the
bone's own direction (its joint to its end), and gives the local transforms of the turned
frames at rest and on every frame. The motion is the same: a joint frame is `R(t) B`, where
`R(t)` is the clip's rotation and `B` the bind rotation, and skinning through the inverse bind
matrix cancels `B`.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from quadpipe.clip.kinematics import local_poses, multiply, normalize
from quadpipe.clip.model import AnimalTrack

GLTF_BONE_AXIS = np.array([0.0, 0.0, 1.0])
"""A glTF joint's local +Y, in quadpipe's frame (glTF is y up)."""

USD_BONE_AXIS = np.array([0.0, 1.0, 0.0])
"""A USD joint's local +Y, in quadpipe's frame (quadpipe's stages are z up)."""

HALF_TURN_AXIS = np.array([1.0, 0.0, 0.0])
"""The turn used when a bone points exactly against the bone axis: half a turn about +X."""

PARALLEL = 1e-9
"""`1 + cos(angle)` below which a bone points against the axis."""


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
    of no length)."""
    directions = track.rest_end - track.rest_start
    lengths = np.linalg.norm(directions, axis=-1, keepdims=True)
    unit = np.where(lengths > 0, directions / np.where(lengths > 0, lengths, 1.0), axis)
    cosine = unit @ axis
    quats = np.concatenate([1.0 + cosine[:, None], np.cross(axis, unit)], axis=-1)
    opposite = cosine + 1.0 < PARALLEL
    quats[opposite] = np.concatenate([[0.0], HALF_TURN_AXIS])
    return normalize(quats)


def bound_poses(track: AnimalTrack, axis: np.ndarray) -> BoundPoses:
    """The joint frames turned to point along their bones (see the module docstring)."""
    bind = bind_rotations(track, axis)
    moving = dataclasses.replace(track, rotations=multiply(normalize(track.rotations), bind))
    rest = dataclasses.replace(track, positions=track.rest_start[None], rotations=bind[None])
    translations, rotations = local_poses(moving)
    rest_translations, rest_rotations = local_poses(rest)
    return BoundPoses(bind, rest_translations[0], rest_rotations[0], translations, rotations)
