"""The animator's set as ground: a mesh file read into triangles, then sampled into a height field.

A set is a triangle mesh in OBJ, PLY, glTF/GLB (read with trimesh) or USD (`.usd`, `.usda`,
`.usdc`, `.usdz`, read with `pxr`: every `UsdGeom.Mesh` with its world transform, polygons
fanned into triangles). MuJoCo collides a mesh geom as its convex hull, so a concave set
cannot be one mesh geom; it becomes a height field instead: vertical rays on a regular grid
over the set's footprint, each taking the highest surface it meets (`HeightGrid`). Its limits:
one height per (x, y) (an overhang, a cave or a bridge becomes solid under its top), and detail
finer than the grid's cell is smoothed.

Axes and units: quadpipe's frame is +X forward, +Y left, +Z up, metres. A `y`-up file is read
as quadpipe's .glb and .bvh exporters write (the file's x is quadpipe's left, its y up, its z
forward: `quadpipe.clip.kinematics.Y_UP_AXES`); a `z`-up file as the .usd exporter writes
(the file's axes are quadpipe's). So the set's own transform is the identity in the frame of the
clip exported in that convention, and an animal baked on the set lines up with it when both are
imported into one DCC scene.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from quadpipe.clip.kinematics import Y_UP_AXES
from quadpipe.core.errors import Issue, Location, QuadpipeError
from quadpipe.core.limits import MAX_SET_TRIANGLES
from quadpipe.core.textfiles import missing_file
from quadpipe.world.set_format import MAX_SET_RESOLUTION

SET_FORMATS: dict[str, str] = {
    ".obj": "obj",
    ".ply": "ply",
    ".glb": "gltf",
    ".gltf": "gltf",
    ".usd": "usd",
    ".usda": "usd",
    ".usdc": "usd",
    ".usdz": "usd",
}
"""File suffix -> the format a set is read as."""

DEFAULT_UP: dict[str, str] = {"obj": "y", "ply": "z", "gltf": "y"}
"""The up axis of a format when `up:` is not given: glTF's is y by its specification; OBJ and
PLY carry none, so Blender's export defaults (OBJ y-up, PLY z-up). USD files say theirs
(`upAxis`)."""

EDGE_TOLERANCE = 1e-9
"""Barycentric slack so that a ray through a shared edge or vertex hits one of its triangles."""

POINTS_PER_CHUNK = 256
"""Query points tested against every triangle at once in `surface_heights` (bounds memory)."""


@dataclass(frozen=True)
class SetMesh:
    """A set's triangles in quadpipe's frame: (T, 3, 3) corners, metres."""

    triangles: np.ndarray


@dataclass(frozen=True)
class HeightGrid:
    """A set sampled on a regular grid: the height field MuJoCo collides with.

    Attributes:
        origin: (x, y) of the sample at row 0, column 0 (the footprint's lowest corner), metres.
        cell: spacing of the samples along x and y, metres.
        heights: (rows, columns) surface heights, row i at y = origin y + i cell, column j at
            x = origin x + j cell, metres.
    """

    origin: tuple[float, float]
    cell: float
    heights: np.ndarray

    @property
    def half_sizes(self) -> tuple[float, float]:
        """Half its extent along x and y, metres (MuJoCo's hfield `size[0:2]`)."""
        rows, columns = self.heights.shape
        return (columns - 1) * self.cell / 2, (rows - 1) * self.cell / 2

    @property
    def centre(self) -> tuple[float, float]:
        """The (x, y) centre of its footprint, metres."""
        half_x, half_y = self.half_sizes
        return self.origin[0] + half_x, self.origin[1] + half_y


def set_issue(path: Path, shown: str, where: Location) -> Issue | None:
    """The issue of a set file that is not there or not in a readable format; None when it may be read."""
    if not path.is_file():
        hint = f"the path is relative to the scene file's folder, {path.parent.resolve()}"
        issue = missing_file(path, "set", name=shown, where=where, suffixes=SET_FORMATS, hint=hint)
        return Issue(issue.code, f"{issue.message} (relative to this scene)", issue.where, issue.hint)
    if path.suffix.lower() not in SET_FORMATS:
        return Issue(
            "set-format",
            f"set file {shown!r}: {path.suffix or 'no suffix'} is not a mesh format quadpipe reads",
            where,
            f"export the set as one of {', '.join(SET_FORMATS)}",
        )
    return None


def height_grid(
    path: Path, shown: str, where: Location, scale: float, up: str | None, resolution: int | None
) -> HeightGrid:
    """A set file sampled into a height field (cached by file, date and settings).

    Args:
        path: the file.
        shown: its name as the scene writes it, for messages.
        where: where the scene names it.
        scale: metres per unit of the file (times a USD stage's `metersPerUnit`).
        up: the file's up axis, `y` or `z`; None for its format's (`DEFAULT_UP`, or USD's `upAxis`).
        resolution: samples along the footprint's longer side; None: the set's own detail.

    Raises:
        QuadpipeError: a missing, unreadable, empty or too big set, at `where`.
    """
    issue = set_issue(path, shown, where)
    if issue is not None:
        raise QuadpipeError([issue])
    stat = path.stat()
    return _cached_grid(str(path.resolve()), stat.st_mtime_ns, stat.st_size, shown, where, scale, up, resolution)


@functools.lru_cache(maxsize=8)
def _cached_grid(
    path: str,
    _mtime: int,
    _size: int,
    shown: str,
    where: Location,
    scale: float,
    up: str | None,
    resolution: int | None,
) -> HeightGrid:
    return sample_grid(read_set(Path(path), shown, where, scale, up), resolution, shown, where)


def read_set(path: Path, shown: str, where: Location, scale: float = 1.0, up: str | None = None) -> SetMesh:
    """A set file's triangles in quadpipe's frame, metres.

    Raises:
        QuadpipeError: `set-unreadable` (not a mesh of its format), `set-empty` (no triangles),
            `limit-exceeded` (more than `MAX_SET_TRIANGLES`), at `where`.
    """
    kind = SET_FORMATS[path.suffix.lower()]
    reader: Callable[[Path], tuple[np.ndarray, np.ndarray, str | None, float]] = (
        _usd_triangles if kind == "usd" else _trimesh_triangles
    )
    try:
        vertices, faces, file_up, metres = reader(path)
    except QuadpipeError:
        raise
    except Exception as exc:  # noqa: BLE001  # any reader failure is the file's fault, reported at it
        raise QuadpipeError.single(
            "set-unreadable",
            f"set file {shown!r} cannot be read as {kind.upper()}: {_reason(exc)}",
            where=where,
            hint="open it in the tool that made it and export it again",
        ) from exc
    MAX_SET_TRIANGLES.check(len(faces), where=where)
    axis = up or file_up or DEFAULT_UP[kind]
    triangles = np.asarray(vertices, dtype=float)[np.asarray(faces, dtype=int)] * (scale * metres)
    if axis == "y":
        triangles = triangles @ Y_UP_AXES
    if not len(triangles) or not np.isfinite(triangles).all():
        raise QuadpipeError.single(
            "set-empty" if not len(triangles) else "set-unreadable",
            f"set file {shown!r} holds {'no triangles' if not len(triangles) else 'coordinates that are not finite'}",
            where=where,
            hint="export the ground's mesh (faces, not only points or lines)",
        )
    return SetMesh(triangles)


REASON_CHARACTERS = 200
"""Longest reader message quoted in a `set-unreadable` error."""


def _reason(exc: Exception) -> str:
    """A reader's complaint in one line: its first line, without USD's `Error in '<function>' at
    line N in file <source> : '...'` wrapping."""
    line = next((text.strip() for text in str(exc).splitlines() if text.strip()), type(exc).__name__)
    if " : '" in line:
        line = line.split(" : '", 1)[1].rstrip("'")
    return line[:REASON_CHARACTERS]


def _trimesh_triangles(path: Path) -> tuple[np.ndarray, np.ndarray, str | None, float]:
    """Vertices and triangles of an OBJ, PLY or glTF file, its scene's node transforms applied."""
    import trimesh

    loaded = trimesh.load(str(path), force="mesh", process=False)
    if not isinstance(loaded, trimesh.Trimesh):
        return np.zeros((0, 3)), np.zeros((0, 3), dtype=int), None, 1.0
    return np.asarray(loaded.vertices), np.asarray(loaded.faces), None, 1.0


def _usd_triangles(path: Path) -> tuple[np.ndarray, np.ndarray, str | None, float]:
    """Vertices and triangles of every `UsdGeom.Mesh` of a USD stage, in the stage's world frame,
    polygons fanned into triangles; with the stage's up axis and metres per unit."""
    from pxr import Usd, UsdGeom

    stage = Usd.Stage.Open(str(path))
    if stage is None:
        raise ValueError("not a USD stage")
    vertices: list[np.ndarray] = []
    faces: list[np.ndarray] = []
    count = 0
    for prim in stage.Traverse():
        if not prim.IsA(UsdGeom.Mesh):
            continue
        mesh = UsdGeom.Mesh(prim)
        points = np.asarray(mesh.GetPointsAttr().Get() or [], dtype=float).reshape(-1, 3)
        matrix = np.asarray(UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(Usd.TimeCode.Default()))
        vertices.append(points @ matrix[:3, :3] + matrix[3, :3])
        faces.append(
            _fan(mesh.GetFaceVertexCountsAttr().Get() or [], mesh.GetFaceVertexIndicesAttr().Get() or []) + count
        )
        count += len(points)
    up = "y" if UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.y else "z"
    all_faces = np.concatenate(faces) if faces else np.zeros((0, 3), dtype=int)
    all_vertices = np.concatenate(vertices) if vertices else np.zeros((0, 3))
    if len(all_faces) and (all_faces.min() < 0 or all_faces.max() >= len(all_vertices)):
        raise ValueError("a face indexes a point that does not exist")
    return all_vertices, all_faces, up, float(UsdGeom.GetStageMetersPerUnit(stage))


def _fan(counts: Any, indices: Any) -> np.ndarray:
    """USD polygons (`faceVertexCounts`, `faceVertexIndices`) as triangles fanned from each first corner."""
    counts, indices = np.asarray(counts, dtype=int), np.asarray(indices, dtype=int)
    if counts.sum() != len(indices) or (counts < 3).any():
        raise ValueError("faceVertexCounts do not match faceVertexIndices")
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    return np.array(
        [(indices[s], indices[s + k], indices[s + k + 1]) for s, n in zip(starts, counts) for k in range(1, n - 1)],
        dtype=int,
    ).reshape(-1, 3)


def sample_grid(mesh: SetMesh, resolution: int | None, shown: str, where: Location) -> HeightGrid:
    """The set's top surface sampled on a grid of `resolution` samples along its longer side
    (None: `default_resolution`).

    Samples no triangle covers (outside an irregular footprint) take the set's lowest height.

    Raises:
        QuadpipeError: `set-empty` when the set has no extent seen from above (a wall, a line).
    """
    lows, highs = mesh.triangles[..., :2].min(axis=(0, 1)), mesh.triangles[..., :2].max(axis=(0, 1))
    extent = highs - lows
    if not extent.max() > 0:
        raise _flat_footprint(shown, where)
    cell = float(extent.max()) / ((resolution or default_resolution(mesh, float(extent.max()))) - 1)
    columns, rows = (np.ceil(extent / cell - 1e-9).astype(int) + 1).tolist()
    xs, ys = lows[0] + cell * np.arange(columns), lows[1] + cell * np.arange(rows)
    heights = np.full((rows, columns), -np.inf)
    for triangle in mesh.triangles:
        _raise_under(triangle, xs, ys, heights)
    covered = np.isfinite(heights)
    if not covered.any():
        raise _flat_footprint(shown, where)
    heights[~covered] = heights[covered].min()
    return HeightGrid((float(lows[0]), float(lows[1])), cell, heights)


def default_resolution(mesh: SetMesh, side: float) -> int:
    """Samples along a set's longer side (`side`, metres) for a cell as long as the median edge of
    its triangles seen from above: the detail the set carries, and no finer (each cell edge of a
    height field is a seam where MuJoCo's contacts can tilt), within 2 to `MAX_SET_RESOLUTION`."""
    edges = np.linalg.norm(mesh.triangles[:, :, :2] - np.roll(mesh.triangles[:, :, :2], 1, axis=1), axis=-1)
    edge = float(np.median(edges[edges > 0])) if (edges > 0).any() else side
    return int(np.clip(np.ceil(side / edge - 1e-9) + 1, 2, MAX_SET_RESOLUTION))


def _flat_footprint(shown: str, where: Location) -> QuadpipeError:
    return QuadpipeError.single(
        "set-empty",
        f"set file {shown!r} covers no ground seen from above",
        where=where,
        hint="check its up axis (`up: y` or `up: z`) and that it holds the ground's faces",
    )


def _raise_under(triangle: np.ndarray, xs: np.ndarray, ys: np.ndarray, heights: np.ndarray) -> None:
    """Lift the grid samples a triangle covers to its height there (keeping the highest)."""
    (x0, y0, z0), (x1, y1, z1), (x2, y2, z2) = triangle
    det = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0)
    if abs(det) < 1e-18:
        return
    c0, c1 = np.searchsorted(xs, [min(x0, x1, x2) - 1e-9, max(x0, x1, x2) + 1e-9], side="left")
    r0, r1 = np.searchsorted(ys, [min(y0, y1, y2) - 1e-9, max(y0, y1, y2) + 1e-9], side="left")
    if c1 <= c0 or r1 <= r0:
        return
    dx, dy = xs[None, c0:c1] - x0, ys[r0:r1, None] - y0
    u = ((y2 - y0) * dx - (x2 - x0) * dy) / det
    v = ((x1 - x0) * dy - (y1 - y0) * dx) / det
    inside = (u >= -EDGE_TOLERANCE) & (v >= -EDGE_TOLERANCE) & (u + v <= 1 + EDGE_TOLERANCE)
    z = np.where(inside, z0 + u * (z1 - z0) + v * (z2 - z0), -np.inf)
    block = heights[r0:r1, c0:c1]
    np.maximum(block, z, out=block)


def surface_heights(mesh: SetMesh, points: np.ndarray) -> np.ndarray:
    """The set's top surface height at each (x, y) of `points` (P, 2+), NaN where it has none."""
    t = mesh.triangles
    a, b, c = t[:, 0], t[:, 1], t[:, 2]
    det = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1])
    keep = np.abs(det) > 1e-18
    a, b, c, det = a[keep], b[keep], c[keep], det[keep]
    out = np.full(len(points), np.nan)
    for start in range(0, len(points), POINTS_PER_CHUNK):
        xy = np.asarray(points[start : start + POINTS_PER_CHUNK, :2], dtype=float)
        dx, dy = xy[:, None, 0] - a[:, 0], xy[:, None, 1] - a[:, 1]
        u = ((c[:, 1] - a[:, 1]) * dx - (c[:, 0] - a[:, 0]) * dy) / det
        v = ((b[:, 0] - a[:, 0]) * dy - (b[:, 1] - a[:, 1]) * dx) / det
        inside = (u >= -EDGE_TOLERANCE) & (v >= -EDGE_TOLERANCE) & (u + v <= 1 + EDGE_TOLERANCE)
        z = np.where(inside, a[:, 2] + u * (b[:, 2] - a[:, 2]) + v * (c[:, 2] - a[:, 2]), -np.inf).max(axis=1)
        out[start : start + len(xy)] = np.where(np.isfinite(z), z, np.nan)
    return out
