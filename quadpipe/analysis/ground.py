"""Where the ground is, and how low a bone's shapes reach: the geometry of posture's contacts.

The ground under a point is the highest terrain surface a vertical ray from far above meets:
planes (any tilt) and boxes (any orientation) of the clip's terrain; terrain spheres and
capsules are not ground. A clip without terrain stands on z = 0.
"""

from __future__ import annotations

import numpy as np

from quadpipe.analysis.footfalls import rotate
from quadpipe.clip.model import AnimalTrack, Shape

RAY_START_Z_M = 1.0e4
"""Height the vertical rays start from, metres: above any terrain."""

FLAT_TOLERANCE = 1.0e-9
"""A plane whose normal has less vertical component than this is a wall, not ground."""


def ground_height(terrain: list[Shape], xy: np.ndarray) -> np.ndarray:
    """The ground's height under each of (N, 2) horizontal points: (N,) metres (0 without terrain)."""
    points = np.asarray(xy, dtype=float).reshape(-1, 2)
    heights = [_surface(shape, points) for shape in terrain if shape.kind in ("plane", "box")]
    if not heights:
        return np.zeros(len(points))
    top = np.nanmax(np.stack(heights), axis=0) if len(heights) > 1 else heights[0]
    return np.where(np.isfinite(top), top, 0.0)


def _surface(shape: Shape, points: np.ndarray) -> np.ndarray:
    """Height of one terrain shape's top under each point (NaN where it is not under the point)."""
    quat = np.asarray(shape.quat, dtype=float)[None, :]
    centre = np.asarray(shape.pos, dtype=float)
    if shape.kind == "plane":
        normal = rotate(quat, np.array([0.0, 0.0, 1.0]))[0]
        if abs(normal[2]) < FLAT_TOLERANCE:
            return np.full(len(points), np.nan)
        return centre[2] - (normal[0] * (points[:, 0] - centre[0]) + normal[1] * (points[:, 1] - centre[1])) / normal[2]
    return _box_top(centre, quat, np.asarray(shape.size, dtype=float), points)


def _box_top(centre: np.ndarray, quat: np.ndarray, half: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Where downward vertical rays over `points` first enter an oriented box (NaN: they miss it)."""
    inverse = quat * np.array([1.0, -1.0, -1.0, -1.0])
    starts = np.column_stack([points, np.full(len(points), RAY_START_Z_M)]) - centre
    origin = _rotate_pairs(inverse, starts)
    direction = rotate(inverse, np.array([0.0, 0.0, -1.0]))[0]
    with np.errstate(divide="ignore", invalid="ignore"):
        low = (-half - origin) / direction
        high = (half - origin) / direction
    near = np.where(np.isnan(low), -np.inf, np.minimum(low, high))
    far = np.where(np.isnan(high), np.inf, np.maximum(low, high))
    inside_slab = (direction != 0.0) | (np.abs(origin) <= half)
    enter = near.max(axis=1)
    leave = far.min(axis=1)
    hit = inside_slab.all(axis=1) & (enter <= leave) & (leave >= 0.0)
    return np.where(hit, RAY_START_Z_M - np.maximum(enter, 0.0), np.nan)


def lowest_points(track: AnimalTrack, bones: list[int], frames: slice) -> np.ndarray | None:
    """Per frame, the lowest point of the given bones' shapes, world: (F, 3) (None: no shapes).

    A capsule's lowest point lies a radius below its lower end (exact unless it lies flat); a
    sphere's a radius below its centre; a box's at its lowest corner.
    """
    candidates = []
    for bone in bones:
        position = track.positions[frames, bone]
        rotation = track.rotations[frames, bone]
        for shape in track.shapes[bone]:
            candidates.extend(_shape_low_points(shape, position, rotation))
    if not candidates:
        return None
    stacked = np.stack(candidates)
    lowest = np.argmin(stacked[:, :, 2], axis=0)
    return stacked[lowest, np.arange(stacked.shape[1])]


def lowest_point_slides(track: AnimalTrack, bones: list[int], frames: slice) -> np.ndarray | None:
    """Per pair of consecutive frames, how far the bones' lowest point slides: (F - 1, 3) metres.

    The lowest point of a frame is followed as a point of its bone to the next frame (a
    capsule's or a sphere's on its cap under the centre, a box's corner), so a foot that
    rolls or pivots over the ground without sliding does not move it; a foot that skates
    does (None: no shapes).
    """
    points, moved = [], []
    for bone in bones:
        position = track.positions[frames, bone]
        rotation = track.rotations[frames, bone]
        for shape in track.shapes[bone]:
            for point, successor in _shape_low_motions(shape, position, rotation):
                points.append(point)
                moved.append(successor)
    if not points:
        return None
    stacked = np.stack(points)
    lowest = np.argmin(stacked[:, :-1, 2], axis=0)
    steps = np.arange(stacked.shape[1] - 1)
    return np.stack(moved)[lowest, steps] - stacked[lowest, steps]


def _shape_low_motions(shape: Shape, position: np.ndarray, rotation: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """Per candidate lowest point of one shape: the point each frame (F, 3) and where that
    point of the bone is one frame later (F - 1, 3)."""
    if shape.kind == "box":
        corners = _shape_low_points(shape, position, rotation)
        return [(corner, corner[1:]) for corner in corners]
    centre = position + rotate(rotation, np.asarray(shape.pos, dtype=float))
    centres = [centre]
    if shape.kind == "capsule":
        local = np.asarray(shape.quat, dtype=float)[None, :]
        axis = rotate(rotation, rotate(local, np.array([0.0, 0.0, shape.size[1]]))[0])
        centres = [centre + axis, centre - axis]
    elif shape.kind != "sphere":
        return []
    radius = shape.size[0]
    below = radius * np.array([0.0, 0.0, 1.0])
    inverse = rotation * np.array([1.0, -1.0, -1.0, -1.0])
    carried = _rotate_pairs(rotation[1:], rotate(inverse[:-1], below))
    return [(end - below, end[1:] - carried) for end in centres]


def _rotate_pairs(quat: np.ndarray, vectors: np.ndarray) -> np.ndarray:
    """Rotate each of (N, 3) vectors by its own of (N, 4) quaternions (or all by one (1, 4))."""
    w = quat[:, :1]
    axis = quat[:, 1:]
    twice_cross = 2.0 * np.cross(axis, vectors)
    return vectors + w * twice_cross + np.cross(axis, twice_cross)


def _shape_low_points(shape: Shape, position: np.ndarray, rotation: np.ndarray) -> list[np.ndarray]:
    """Candidate lowest points of one bone shape per frame, world (each (F, 3))."""
    centre = position + rotate(rotation, np.asarray(shape.pos, dtype=float))
    local = np.asarray(shape.quat, dtype=float)[None, :]
    down = np.array([0.0, 0.0, shape.size[0]])
    if shape.kind == "capsule":
        axis = rotate(rotation, rotate(local, np.array([0.0, 0.0, shape.size[1]]))[0])
        return [centre + axis - down, centre - axis - down]
    if shape.kind == "sphere":
        return [centre - down]
    if shape.kind == "box":
        corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * np.asarray(
            shape.size
        )
        return [centre + rotate(rotation, rotate(local, corner)[0]) for corner in corners]
    return []
