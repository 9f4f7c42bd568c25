"""A closed triangle surface from a sampled implicit function: marching tetrahedra, then smoothing.

The field is sampled on a regular grid (negative inside, positive outside, positive on the
grid's border). Each grid cube is cut into the six tetrahedra of Freudenthal's triangulation
(all sharing the cube's main diagonal), which tile space consistently from cube to cube; the
zero set of the field, linear on each tetrahedron, is then a closed 2-manifold: every surface
vertex lies on one grid edge (shared by the tetrahedra around it) and every surface edge
borders exactly two triangles. Unlike marching cubes, no ambiguous case and no lookup table.

Taubin's lambda/mu smoothing then evens out the tetrahedra's slivers without shrinking the
surface or changing its connectivity. Everything is numpy, in a fixed order: the same field
gives the same arrays, bit for bit.
"""

from __future__ import annotations

import itertools

import numpy as np

EDGE_PARAMETER_MARGIN = 1e-3
"""A surface vertex lies at least this fraction of its grid edge away from the edge's ends, so
that no two vertices coincide and no triangle is degenerate."""

TAUBIN_LAMBDA, TAUBIN_MU, TAUBIN_ITERATIONS = 0.5, -0.53, 12
"""Taubin smoothing: a shrinking step (lambda) then an inflating one (mu) per iteration."""

_CORNERS = np.array([(i & 1, (i >> 1) & 1, (i >> 2) & 1) for i in range(8)])
"""Cube corners as (x, y, z) offsets; corner index = x + 2y + 4z."""

_TETRAHEDRA = np.array(
    [(0, 1 << a, (1 << a) | (1 << b), 7) for a, b, _ in itertools.permutations(range(3))],
    dtype=np.int64,
)
"""Freudenthal's six tetrahedra of a cube, as corner indices: each walks from corner 0 to
corner 7 along the three axes in one of the six orders."""


def contour(values: np.ndarray, origin: np.ndarray, spacing: float) -> tuple[np.ndarray, np.ndarray]:
    """The zero surface of a grid-sampled field, outward-facing (counter-clockwise from outside).

    Args:
        values: (nx, ny, nz) field samples, negative inside; the grid's border must be outside.
        origin: world position of sample (0, 0, 0), metres.
        spacing: grid step, metres.

    Returns:
        (N, 3) vertices and (M, 3) triangle indices, smoothed.
    """
    flat = values.reshape(-1)
    strides = np.array([values.shape[1] * values.shape[2], values.shape[2], 1])
    corners = _crossing_cubes(values)[:, None] + (_CORNERS @ strides)[None, :]  # (C, 8) grid indices
    tets = corners[:, _TETRAHEDRA].reshape(-1, 4)  # (6C, 4)
    inside = flat[tets] < 0
    count = inside.sum(axis=1)
    edges = np.concatenate(
        [
            _one_corner_cut(tets[count == 1], inside[count == 1]),
            _one_corner_cut(tets[count == 3], ~inside[count == 3])[..., ::-1],
            _two_corner_cut(tets[count == 2], inside[count == 2]),
        ]
    )  # (T, 3, 2): each triangle corner as the grid edge it lies on, inside end first
    low, high = np.minimum(edges[..., 0], edges[..., 1]), np.maximum(edges[..., 0], edges[..., 1])
    _, first, faces = np.unique((low * flat.size + high).reshape(-1), return_index=True, return_inverse=True)
    vertices = _edge_points(edges.reshape(-1, 2)[first], flat, strides, origin, spacing)
    faces = _facing_outward(faces.reshape(-1, 3), vertices, edges, strides)
    return taubin_smooth(vertices, faces), faces


def _crossing_cubes(values: np.ndarray) -> np.ndarray:
    """Flat grid indices of the lower corners of the cubes whose corners differ in sign."""
    inside = values < 0
    nx, ny, nz = (n - 1 for n in values.shape)
    any_in = np.zeros((nx, ny, nz), dtype=bool)
    all_in = np.ones((nx, ny, nz), dtype=bool)
    for dx, dy, dz in _CORNERS:
        corner = inside[dx : dx + nx, dy : dy + ny, dz : dz + nz]
        any_in |= corner
        all_in &= corner
    return np.ravel_multi_index(np.nonzero(any_in & ~all_in), values.shape).astype(np.int64)


def _one_corner_cut(tets: np.ndarray, alone: np.ndarray) -> np.ndarray:
    """One triangle per tetrahedron with a single corner on its own side of the surface:
    (T, 3, 2) grid edges from the lone corner to each other one."""
    order = np.argsort(~alone, axis=1, kind="stable")  # the lone corner first
    ordered = np.take_along_axis(tets, order, axis=1)
    return np.stack([np.broadcast_to(ordered[:, :1], (len(tets), 3)), ordered[:, 1:]], axis=-1)


def _two_corner_cut(tets: np.ndarray, inside: np.ndarray) -> np.ndarray:
    """Two triangles (a quad) per tetrahedron with two corners inside: (2T, 3, 2) grid edges."""
    order = np.argsort(~inside, axis=1, kind="stable")  # the two inside corners first
    a, b, c, d = np.take_along_axis(tets, order, axis=1).T
    quad = np.stack([np.stack(pair, axis=-1) for pair in ((a, c), (a, d), (b, d), (b, c))], axis=1)
    return np.concatenate([quad[:, [0, 1, 2]], quad[:, [0, 2, 3]]])


def _facing_outward(faces: np.ndarray, vertices: np.ndarray, edges: np.ndarray, strides: np.ndarray) -> np.ndarray:
    """Faces flipped where their winding normal points inward.

    Each triangle corner lies on a grid edge from an inside sample to an outside one; the sum of
    those three edge directions points out of the surface, across the triangle.
    """
    outward = (_grid_coordinates(edges[..., 1], strides) - _grid_coordinates(edges[..., 0], strides)).sum(axis=1)
    corners = vertices[faces]
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    flip = np.einsum("ij,ij->i", normals, outward) < 0
    return np.where(flip[:, None], faces[:, ::-1], faces)


def _edge_points(
    edges: np.ndarray, flat: np.ndarray, strides: np.ndarray, origin: np.ndarray, spacing: float
) -> np.ndarray:
    """Where the field crosses zero along each grid edge (inside end, outside end), metres."""
    inner, outer = flat[edges[:, 0]], flat[edges[:, 1]]
    t = np.clip(inner / (inner - outer), EDGE_PARAMETER_MARGIN, 1.0 - EDGE_PARAMETER_MARGIN)
    a = _grid_coordinates(edges[:, 0], strides)
    b = _grid_coordinates(edges[:, 1], strides)
    return origin + spacing * (a + t[:, None] * (b - a))


def _grid_coordinates(index: np.ndarray, strides: np.ndarray) -> np.ndarray:
    """(..., 3) grid coordinates (i, j, k) of flat grid indices."""
    i, rest = np.divmod(index, strides[0])
    j, k = np.divmod(rest, strides[1])
    return np.stack([i, j, k], axis=-1).astype(float)


def taubin_smooth(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Vertices moved by Taubin's lambda/mu smoothing over the mesh's edges (connectivity kept)."""
    edges = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    edges = np.unique(np.sort(edges, axis=1), axis=0)
    source = np.concatenate([edges[:, 0], edges[:, 1]])
    target = np.concatenate([edges[:, 1], edges[:, 0]])
    degree = np.bincount(source, minlength=len(vertices)).astype(float)[:, None]
    points = vertices.copy()
    for _ in range(TAUBIN_ITERATIONS):
        for factor in (TAUBIN_LAMBDA, TAUBIN_MU):
            mean = np.stack(
                [np.bincount(source, weights=points[target, axis], minlength=len(points)) for axis in range(3)],
                axis=1,
            )
            points = points + factor * (mean / degree - points)
    return points
