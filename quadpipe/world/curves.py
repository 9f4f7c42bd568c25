"""Curves an animator draws in a set, read as a direction's path: an OBJ polyline or a USD
`BasisCurves` (`path: {file: ...}` in a direction, docs/direction.md).

`read_curve` returns the curve's points in metres, in world coordinates (x forward, y left,
z up, as quadpipe's scenes): an OBJ file's vertices in the order its first `l` line joins
them (in metres, z up); a USD stage's first `BasisCurves` prim's first curve, transformed to
the world and scaled by the stage's `metersPerUnit`, turned from Y-up when the stage is.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from quadpipe.core.limits import Limit
from quadpipe.core.textfiles import read_text

CURVE_SUFFIXES = (".obj", ".usd", ".usda", ".usdc")
"""The curve files a direction's path may name."""

MAX_CURVE_FILE_BYTES = Limit(
    "the curve file's size", 16 * 2**20, "bytes", "export only the path's curve to a file of its own"
)
"""Size of an OBJ curve file, in bytes (an animator's path has a few dozen points)."""


class CurveError(ValueError):
    """A curve file that holds no usable curve (the message says why)."""


def read_curve(path: Path) -> np.ndarray:
    """The points of the first curve in an OBJ or USD file, (n, 3) metres.

    Raises:
        CurveError: an unknown suffix, no curve in the file, a line that cannot be read.
        QuadpipeError: the file cannot be read (from `read_text`, for OBJ).
    """
    suffix = path.suffix.lower()
    if suffix == ".obj":
        return _obj_curve(path)
    if suffix in CURVE_SUFFIXES:
        return _usd_curve(path)
    raise CurveError(f"a curve is read from {', '.join(CURVE_SUFFIXES)} files, not {suffix or 'a file without suffix'}")


def _obj_curve(path: Path) -> np.ndarray:
    """The vertices an OBJ file's first `l` line joins, in its order."""
    vertices: list[list[float]] = []
    for number, line in enumerate(read_text(path, MAX_CURVE_FILE_BYTES, "curve").splitlines(), start=1):
        words = line.split()
        try:
            if words and words[0] == "v":
                vertices.append([float(value) for value in words[1:4]])
            elif words and words[0] == "l":
                indices = [int(word.split("/")[0]) for word in words[1:]]
                return np.array([vertices[i - 1 if i > 0 else len(vertices) + i] for i in indices], dtype=float)
        except (ValueError, IndexError) as exc:
            raise CurveError(f"line {number} of the curve file cannot be read: {line.strip()!r}") from exc
    raise CurveError("the OBJ file has no polyline (an `l` line joining its vertices)")


def _usd_curve(path: Path) -> np.ndarray:
    """The first curve of a USD stage's first `BasisCurves` prim, in world metres, z up."""
    from pxr import Usd, UsdGeom

    stage = Usd.Stage.Open(str(path))
    if stage is None:
        raise CurveError("the USD file cannot be opened")
    prim = next((p for p in stage.Traverse() if p.IsA(UsdGeom.BasisCurves)), None)
    if prim is None:
        raise CurveError("the USD file has no BasisCurves prim")
    curves = UsdGeom.BasisCurves(prim)
    points = np.array(curves.GetPointsAttr().Get() or [], dtype=float).reshape(-1, 3)
    counts = curves.GetCurveVertexCountsAttr().Get() or [len(points)]
    points = points[: int(counts[0])]
    matrix = np.array(UsdGeom.XformCache().GetLocalToWorldTransform(prim), dtype=float)
    world = np.column_stack([points, np.ones(len(points))]) @ matrix
    metres = world[:, :3] * UsdGeom.GetStageMetersPerUnit(stage)
    if UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.y:
        metres = np.column_stack([metres[:, 0], -metres[:, 2], metres[:, 1]])
    return metres
