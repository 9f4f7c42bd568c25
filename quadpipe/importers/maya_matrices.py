"""Maya's transformation matrices, for row vectors (`p' = p * M`), as in Maya's node docs."""

from __future__ import annotations

import math

import numpy as np

from quadpipe.anatomy.skeleton import Frame

MIN_SCALE = 1e-12
"""A world matrix scaling some direction by less than this has no orientation."""


def joint_frame(world: np.ndarray) -> Frame | None:
    """A joint's local X, Y and Z axes in the world (unit vectors) from its world matrix (row
    vectors: row i is where local axis i goes), scale and shear taken out (the nearest
    rotation); None for a degenerate or mirrored matrix."""
    u, scales, vt = np.linalg.svd(world[:3, :3])
    rotation = u @ vt
    if scales.min() < MIN_SCALE or np.linalg.det(rotation) < 0:
        return None
    x, y, z = (tuple(float(v) for v in row) for row in rotation)
    return (x[0], x[1], x[2]), (y[0], y[1], y[2]), (z[0], z[1], z[2])


def axis_rotation(axis: str, angle: float) -> np.ndarray:
    """Maya's 4x4 rotation about one axis, for row vectors (`p' = p * M`)."""
    c, s = math.cos(angle), math.sin(angle)
    i, j = {"x": (1, 2), "y": (2, 0), "z": (0, 1)}[axis]
    matrix = np.eye(4)
    matrix[i, i] = matrix[j, j] = c
    matrix[i, j] = s
    matrix[j, i] = -s
    return matrix


def euler_matrix(angles: np.ndarray, order: str = "xyz") -> np.ndarray:
    """Rotation from Euler angles (radians) applied in `order`: xyz is RX * RY * RZ."""
    matrix = np.eye(4)
    for axis in order:
        matrix = matrix @ axis_rotation(axis, float(angles["xyz".index(axis)]))
    return matrix


def translation_matrix(vector: np.ndarray) -> np.ndarray:
    """A translation by `vector` (in the matrix's last row)."""
    matrix = np.eye(4)
    matrix[3, :3] = vector
    return matrix


def scale_matrix(vector: np.ndarray) -> np.ndarray:
    """A scale by `vector`'s three factors."""
    return np.diag([*vector, 1.0])


def shear_matrix(values: np.ndarray) -> np.ndarray:
    """Maya's shear matrix from its (xy, xz, yz) values."""
    xy, xz, yz = values
    matrix = np.eye(4)
    matrix[1, 0], matrix[2, 0], matrix[2, 1] = xy, xz, yz
    return matrix
