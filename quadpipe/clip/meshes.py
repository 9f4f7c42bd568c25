"""Clip shapes (capsules, boxes, spheres, planes) as triangle meshes with normals and colours.

Blender, Maya and game engines skin and draw meshes, not analytic primitives, so every exporter
tessellates shapes here. Output is deterministic: the same shape gives the same arrays, bit for
bit. Capsules and spheres come from trimesh with exact analytic normals (smooth shading);
boxes and planes are built here with one normal per face (flat shading).
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from quadpipe.clip.kinematics import rotate
from quadpipe.clip.model import Shape

CAPSULE_SEGMENTS = (16, 16)
"""trimesh capsule resolution (around the axis, along the caps): 258 vertices."""

SPHERE_SUBDIVISIONS = 2
"""Icosphere subdivisions: 162 vertices."""

UNBOUNDED_PLANE_HALF_SIZE_M = 50.0
"""Half side drawn for a plane whose size is 0 (MuJoCo's infinite plane), metres."""

_BOX_FACES = (
    (0, 1.0),
    (0, -1.0),
    (1, 1.0),
    (1, -1.0),
    (2, 1.0),
    (2, -1.0),
)
"""Box faces as (normal axis, normal sign)."""


@dataclass(frozen=True)
class TriangleMesh:
    """An indexed triangle mesh, counter-clockwise faces seen from outside.

    Attributes:
        vertices: (N, 3) positions, metres.
        normals: (N, 3) unit normals.
        colors: (N, 4) RGBA per vertex.
        faces: (M, 3) vertex indices.
    """

    vertices: np.ndarray
    normals: np.ndarray
    colors: np.ndarray
    faces: np.ndarray

    def translated(self, offset: Sequence[float]) -> TriangleMesh:
        """The mesh moved by `offset`."""
        return TriangleMesh(self.vertices + np.asarray(offset, dtype=float), self.normals, self.colors, self.faces)

    def transformed(self, pos: Sequence[float], quat: Sequence[float]) -> TriangleMesh:
        """The mesh rotated by `quat` (w, x, y, z), then moved by `pos`."""
        q = np.asarray(quat, dtype=float)
        return TriangleMesh(
            rotate(q, self.vertices) + np.asarray(pos, dtype=float), rotate(q, self.normals), self.colors, self.faces
        )


def shape_mesh(shape: Shape) -> TriangleMesh:
    """A shape as a mesh in its owner's frame (its `pos` and `quat` applied)."""
    vertices, normals, faces = _geometry(shape.kind, tuple(float(x) for x in shape.size))
    colors = np.tile(np.asarray(shape.rgba, dtype=float), (len(vertices), 1))
    return TriangleMesh(vertices, normals, colors, faces).transformed(shape.pos, shape.quat)


@functools.lru_cache(maxsize=1024)
def _geometry(kind: str, size: tuple[float, ...]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The vertices, normals and faces of a shape at the origin, built once per size (a bake
    writing a .glb and a .usdc meshes the same bones twice). The arrays are read-only."""
    arrays = _BUILDERS[kind](size)
    for array in arrays:
        array.flags.writeable = False
    return arrays


def merge(meshes: Sequence[TriangleMesh]) -> TriangleMesh:
    """One mesh holding all of `meshes` (face indices shifted)."""
    starts = np.cumsum([0] + [len(m.vertices) for m in meshes[:-1]])
    return TriangleMesh(
        np.concatenate([m.vertices for m in meshes]),
        np.concatenate([m.normals for m in meshes]),
        np.concatenate([m.colors for m in meshes]),
        np.concatenate([m.faces + start for m, start in zip(meshes, starts)]),
    )


def shapes_mesh(shapes: Sequence[Shape]) -> TriangleMesh:
    """All of `shapes` merged into one mesh."""
    return merge([shape_mesh(shape) for shape in shapes])


def _capsule(size: Sequence[float]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Capsule along Z: size (radius, half length of the cylinder)."""
    from trimesh.creation import capsule

    radius, half_length = size
    mesh = capsule(height=2.0 * half_length, radius=radius, count=list(CAPSULE_SEGMENTS))
    vertices = np.array(mesh.vertices, dtype=float)
    axis_point = np.zeros_like(vertices)
    axis_point[:, 2] = np.clip(vertices[:, 2], -half_length, half_length)
    normals = vertices - axis_point
    return vertices, normals / np.linalg.norm(normals, axis=1, keepdims=True), np.array(mesh.faces, dtype=np.int64)


def _sphere(size: Sequence[float]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    from trimesh.creation import icosphere

    mesh = icosphere(subdivisions=SPHERE_SUBDIVISIONS, radius=1.0)
    normals = np.array(mesh.vertices, dtype=float)
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    return normals * size[0], normals, np.array(mesh.faces, dtype=np.int64)


def _box(size: Sequence[float]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Box of half sizes `size`, four vertices per face so that each face shades flat."""
    half = np.asarray(size, dtype=float)
    vertices, normals, faces = [], [], []
    for axis, sign in _BOX_FACES:
        u, v = (axis + 1) % 3, (axis + 2) % 3
        normal = np.zeros(3)
        normal[axis] = sign
        for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
            corner = np.zeros(3)
            corner[axis], corner[u], corner[v] = sign, a * sign, b
            vertices.append(corner * half)
            normals.append(normal)
        first = len(vertices) - 4
        faces += [(first, first + 1, first + 2), (first, first + 2, first + 3)]
    return np.array(vertices), np.array(normals), np.array(faces, dtype=np.int64)


def _plane(size: Sequence[float]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Plane in local XY facing +Z: size (half x, half y); 0 means unbounded."""
    half_x, half_y = (s if s > 0 else UNBOUNDED_PLANE_HALF_SIZE_M for s in size[:2])
    vertices = np.array(
        [[-half_x, -half_y, 0.0], [half_x, -half_y, 0.0], [half_x, half_y, 0.0], [-half_x, half_y, 0.0]]
    )
    normals = np.tile([0.0, 0.0, 1.0], (4, 1))
    return vertices, normals, np.array([(0, 1, 2), (0, 2, 3)], dtype=np.int64)


_BUILDERS = {"capsule": _capsule, "sphere": _sphere, "box": _box, "plane": _plane}
