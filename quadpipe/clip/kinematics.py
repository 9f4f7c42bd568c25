"""Pose arithmetic shared by the exporters: quaternions, local joint transforms, axis changes.

Quaternions are (w, x, y, z) numpy arrays, as in `quadpipe.clip.model`; functions broadcast over
leading axes. A bone's body frame is world-aligned at rest with its origin at the joint, so a
joint's local transform (in its parent's body frame) is the rest offset at rest, and a pure
translation is each bone's bind transform.
"""

from __future__ import annotations

import numpy as np

from quadpipe.clip.model import AnimalTrack

Y_UP_AXES = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
"""Rotation from quadpipe's frame (+X forward, +Y left, +Z up) to the y-up frame of glTF and
BVH (+X left, +Y up, +Z forward): a cyclic permutation of the axes, so it keeps handedness."""


def normalize(quats: np.ndarray) -> np.ndarray:
    """Unit quaternions."""
    return quats / np.linalg.norm(quats, axis=-1, keepdims=True)


def conjugate(quats: np.ndarray) -> np.ndarray:
    """The inverse of unit quaternions."""
    return quats * np.array([1.0, -1.0, -1.0, -1.0])


def multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The Hamilton product a * b (apply b, then a)."""
    aw, ax, ay, az = np.moveaxis(a, -1, 0)
    bw, bx, by, bz = np.moveaxis(b, -1, 0)
    return np.stack(
        [
            aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
        ],
        axis=-1,
    )


def to_matrix(quats: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) of unit quaternions, acting on column vectors."""
    w, x, y, z = np.moveaxis(quats, -1, 0)
    rows = [
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ]
    return np.stack([np.stack(row, axis=-1) for row in rows], axis=-2)


def rotate(quats: np.ndarray, vectors: np.ndarray) -> np.ndarray:
    """Vectors rotated by unit quaternions (broadcast)."""
    return np.einsum("...ij,...j->...i", to_matrix(quats), vectors)


def continuous(quats: np.ndarray, axis: int = 0) -> np.ndarray:
    """Flip signs along `axis` (frames) so each quaternion lies in the same hemisphere as the last.

    q and -q are the same rotation, but interpolating between them swings the long way round.
    """
    quats = np.moveaxis(np.array(quats, dtype=float), axis, 0)
    for frame in range(1, quats.shape[0]):
        flip = np.sum(quats[frame] * quats[frame - 1], axis=-1) < 0.0
        quats[frame][flip] *= -1.0
    return np.moveaxis(quats, 0, axis)


def local_poses(track: AnimalTrack) -> tuple[np.ndarray, np.ndarray]:
    """Each joint's transform in its parent's body frame, per frame.

    Returns:
        (F, B, 3) translations and (F, B, 4) unit rotations (w, x, y, z), hemisphere-continuous
        frame to frame. The root's are its world pose.
    """
    rotations = normalize(track.rotations)
    parents = track.parents
    translations = track.positions.copy()
    local = rotations.copy()
    child = parents >= 0
    parent_inverse = conjugate(rotations[:, parents[child]])
    translations[:, child] = rotate(parent_inverse, track.positions[:, child] - track.positions[:, parents[child]])
    local[:, child] = multiply(parent_inverse, rotations[:, child])
    return translations, continuous(local)


def rest_offsets(track: AnimalTrack) -> np.ndarray:
    """(B, 3) each joint's rest position relative to its parent's joint (the root's: world)."""
    offsets = track.rest_start.copy()
    child = track.parents >= 0
    offsets[child] -= track.rest_start[track.parents[child]]
    return offsets


def quat_to_y_up(quats: np.ndarray) -> np.ndarray:
    """Quaternions (w, x, y, z) re-expressed in the y-up frame (see `Y_UP_AXES`)."""
    return np.concatenate([quats[..., :1], quats[..., 1:] @ Y_UP_AXES.T], axis=-1)


def to_y_up(vectors: np.ndarray) -> np.ndarray:
    """Points or vectors re-expressed in the y-up frame (see `Y_UP_AXES`)."""
    return vectors @ Y_UP_AXES.T
