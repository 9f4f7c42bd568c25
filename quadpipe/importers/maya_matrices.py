"""Maya's transformation matrices, for row vectors (`p' = p * M`), as in Maya's node docs."""

from __future__ import annotations

import math

import numpy as np


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
