"""Curves an animator draws in a set, read as a direction's path: an OBJ polyline, a glTF
line primitive or a USD `BasisCurves` (`path: {file: ...}` in a direction, docs/direction.md).

`read_curve` returns the curve's points in metres, in world coordinates (x forward, y left,
z up, as quadpipe's scenes), turned from the file's up axis exactly as a set file of the same
format is (`quadpipe.world.sets`: the same default per format, the same `up:`), so a path and
the terrain drawn in one scene line up: an OBJ file's vertices in the order its first `l`
line joins them; a glTF/GLB file's first LINE_STRIP or LINES primitive, with its node's
world transform; a USD stage's first `BasisCurves` prim's first curve, transformed to the
world and scaled by the stage's `metersPerUnit`, up axis from the stage's `upAxis`.
"""

from __future__ import annotations

import base64
import json
import struct
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from quadpipe.clip.kinematics import Y_UP_AXES
from quadpipe.core.limits import Limit
from quadpipe.core.textfiles import read_text
from quadpipe.world.sets import DEFAULT_UP, SET_FORMATS

CURVE_SUFFIXES = (".obj", ".gltf", ".glb", ".usd", ".usda", ".usdc")
"""The curve files a direction's path may name."""

MAX_CURVE_FILE_BYTES = Limit(
    "the curve file's size", 16 * 2**20, "bytes", "export only the path's curve to a file of its own"
)
"""Size of a curve file, in bytes (an animator's path has a few dozen points)."""

GLTF_LINES, GLTF_LINE_STRIP = 1, 3
"""glTF primitive modes that draw lines."""

GLTF_FLOAT = 5126
"""glTF's componentType of 32-bit floats (a POSITION accessor's, by the specification)."""

GLB_MAGIC, GLB_JSON, GLB_BIN = 0x46546C67, 0x4E4F534A, 0x004E4942
"""A GLB file's magic number and the types of its JSON and binary chunks."""

Curve = tuple[np.ndarray, str | None, float]
"""A curve as its file holds it: points (n, 3) in the file's units and axes, the file's own
up axis (None: the format's default), metres per unit."""


class CurveError(ValueError):
    """A curve file that holds no usable curve (the message says why)."""


def read_curve(path: Path, up: str | None = None) -> np.ndarray:
    """The points of the first curve in an OBJ, glTF or USD file, (n, 3) metres, quadpipe's axes.

    `up` ("y" or "z") overrides the file's up axis (as a set's `up:`).

    Raises:
        CurveError: an unknown suffix, no curve in the file, a line that cannot be read.
        QuadpipeError: the file cannot be read (from `read_text`, for OBJ).
    """
    suffix = path.suffix.lower()
    if suffix not in CURVE_SUFFIXES:
        raise CurveError(
            f"a curve is read from {', '.join(CURVE_SUFFIXES)} files, not {suffix or 'a file without suffix'}"
        )
    kind = SET_FORMATS[suffix]
    readers: dict[str, Callable[[Path], Curve]] = {"obj": _obj_curve, "gltf": _gltf_curve, "usd": _usd_curve}
    points, file_up, metres = readers[kind](path)
    metres_points = np.asarray(points, dtype=float) * metres
    return metres_points @ Y_UP_AXES if (up or file_up or DEFAULT_UP[kind]) == "y" else metres_points


def _obj_curve(path: Path) -> Curve:
    """The vertices an OBJ file's first `l` line joins, in its order (OBJ says no up axis or unit)."""
    vertices: list[list[float]] = []
    for number, line in enumerate(read_text(path, MAX_CURVE_FILE_BYTES, "curve").splitlines(), start=1):
        words = line.split()
        try:
            if words and words[0] == "v":
                vertices.append([float(value) for value in words[1:4]])
            elif words and words[0] == "l":
                indices = [int(word.split("/")[0]) for word in words[1:]]
                return (
                    np.array([vertices[i - 1 if i > 0 else len(vertices) + i] for i in indices], dtype=float),
                    None,
                    1.0,
                )
        except (ValueError, IndexError) as exc:
            raise CurveError(f"line {number} of the curve file cannot be read: {line.strip()!r}") from exc
    raise CurveError("the OBJ file has no polyline (an `l` line joining its vertices)")


def _usd_curve(path: Path) -> Curve:
    """The first curve of a USD stage's first `BasisCurves` prim, in world units and axes."""
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
    up = "y" if UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.y else "z"
    return world[:, :3], up, UsdGeom.GetStageMetersPerUnit(stage)


def _gltf_curve(path: Path) -> Curve:
    """The first line primitive (LINE_STRIP, or LINES joined end to end) of a glTF or GLB
    file's scene, its node's world transform applied (glTF is y up and in metres)."""
    if path.stat().st_size > MAX_CURVE_FILE_BYTES.value:
        raise CurveError(f"the file is over {MAX_CURVE_FILE_BYTES.value:g} bytes: {MAX_CURVE_FILE_BYTES.advice}")
    try:
        document, binary = _gltf_parts(path)
        for node, matrix in _gltf_nodes(document):
            for primitive in document["meshes"][node["mesh"]]["primitives"] if "mesh" in node else []:
                mode = primitive.get("mode", 4)
                if mode in (GLTF_LINES, GLTF_LINE_STRIP) and "POSITION" in primitive.get("attributes", {}):
                    return _gltf_line(document, binary, path, primitive, matrix), "y", 1.0
    except (KeyError, IndexError, TypeError, AttributeError, ValueError, struct.error, OSError) as exc:
        raise CurveError(f"the glTF file cannot be read ({type(exc).__name__}: {exc})") from exc
    raise CurveError("the glTF file has no line (a LINE_STRIP or LINES primitive)")


def _gltf_line(
    document: dict[str, Any], binary: bytes, path: Path, primitive: dict[str, Any], matrix: np.ndarray
) -> np.ndarray:
    """A line primitive's points in the world, in order (LINES segments joined end to end)."""
    points = _gltf_positions(document, binary, path, primitive["attributes"]["POSITION"])
    if "indices" in primitive:
        points = points[_gltf_indices(document, binary, path, primitive["indices"])]
    if primitive.get("mode") == GLTF_LINES:
        points = np.concatenate([points[0::2], points[-1:]])
    return (np.column_stack([points, np.ones(len(points))]) @ matrix.T)[:, :3]


def _gltf_parts(path: Path) -> tuple[dict[str, Any], bytes]:
    """A glTF file's JSON document and, for GLB, its binary chunk."""
    data = path.read_bytes()
    if data[:4] == struct.pack("<I", GLB_MAGIC):
        json_length, json_type = struct.unpack_from("<II", data, 12)
        document = json.loads(data[20 : 20 + json_length]) if json_type == GLB_JSON else {}
        binary = b""
        offset = 20 + json_length
        if offset + 8 <= len(data):
            bin_length, bin_type = struct.unpack_from("<II", data, offset)
            binary = data[offset + 8 : offset + 8 + bin_length] if bin_type == GLB_BIN else b""
        return document, binary
    return json.loads(data), b""


def _gltf_nodes(document: dict[str, Any]) -> list[tuple[dict[str, Any], np.ndarray]]:
    """Every node of the file's scene with its world matrix (4 x 4), parents before children."""
    nodes = document.get("nodes", [])
    scenes = document.get("scenes", [{"nodes": list(range(len(nodes)))}])
    roots = scenes[document.get("scene", 0)].get("nodes", [])
    found: list[tuple[dict[str, Any], np.ndarray]] = []
    stack = [(index, np.eye(4)) for index in reversed(roots)]
    while stack and len(found) <= len(nodes):
        index, parent = stack.pop()
        node = nodes[index]
        world = parent @ _gltf_local(node)
        found.append((node, world))
        stack.extend((child, world) for child in reversed(node.get("children", [])))
    return found


def _gltf_local(node: dict[str, Any]) -> np.ndarray:
    """A glTF node's local matrix, from `matrix` (column-major) or translation, rotation, scale."""
    if "matrix" in node:
        return np.array(node["matrix"], dtype=float).reshape(4, 4).T
    x, y, z, w = node.get("rotation", [0.0, 0.0, 0.0, 1.0])
    rotation = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )
    local = np.eye(4)
    local[:3, :3] = rotation * np.array(node.get("scale", [1.0, 1.0, 1.0]), dtype=float)
    local[:3, 3] = node.get("translation", [0.0, 0.0, 0.0])
    return local


def _gltf_accessor(
    document: dict[str, Any], binary: bytes, path: Path, index: int
) -> tuple[bytes, dict[str, Any], int]:
    """An accessor's bytes from its buffer view (its buffer: the GLB chunk, a data URI or a
    file beside the glTF), the accessor and the view's byte stride (0: packed)."""
    accessor = document["accessors"][index]
    view = document["bufferViews"][accessor["bufferView"]]
    buffer = document["buffers"][view["buffer"]]
    uri = buffer.get("uri")
    if uri is None:
        data = binary
    elif uri.startswith("data:"):
        data = base64.b64decode(uri.split(",", 1)[1])
    else:
        data = (path.parent / uri).read_bytes()
    start = view.get("byteOffset", 0) + accessor.get("byteOffset", 0)
    return data[start : view.get("byteOffset", 0) + view["byteLength"]], accessor, view.get("byteStride", 0)


def _gltf_positions(document: dict[str, Any], binary: bytes, path: Path, index: int) -> np.ndarray:
    """A POSITION accessor's points, (n, 3) floats."""
    data, accessor, stride = _gltf_accessor(document, binary, path, index)
    if accessor.get("componentType") != GLTF_FLOAT or accessor.get("type") != "VEC3":
        raise CurveError("the glTF line's positions are not 3 floats each")
    count = accessor["count"]
    step = stride or 12
    if len(data) < step * (count - 1) + 12:
        raise CurveError("the glTF line's positions run past their buffer")
    return np.array([struct.unpack_from("<3f", data, k * step) for k in range(count)], dtype=float)


def _gltf_indices(document: dict[str, Any], binary: bytes, path: Path, index: int) -> np.ndarray:
    """An indices accessor's vertex numbers."""
    data, accessor, _ = _gltf_accessor(document, binary, path, index)
    dtype = {5121: np.uint8, 5123: np.uint16, 5125: np.uint32}.get(accessor.get("componentType", 0))
    if dtype is None:
        raise CurveError("the glTF line's indices are not unsigned integers")
    return np.frombuffer(data, dtype=dtype, count=accessor["count"]).astype(int)
