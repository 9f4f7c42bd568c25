"""glTF 2.0 (`.glb`, or `.gltf` + `.bin`): skinned animals, animated props, static terrain.

glTF is +Y up, +Z forward, metres; quadpipe's frame (+X forward, +Y left, +Z up) maps to it by
a cyclic permutation of the axes (glTF x = left, y = up, z = forward), which keeps handedness.

The scene's root nodes are one per animal, one per prop and the terrain, so that importers
(Blender) make one armature per animal, named after it, and leave props and terrain apart.
An animal's root node (its name, no transform) holds its joint nodes in the 39-bone hierarchy
with local TRS (named by role; `<animal>_<role>` when a clip holds several animals); its
skinned mesh, `<animal>_body`, is a root node too (a skinned mesh ignores its node's
transform, and glTF wants it at the root): the body (`quadpipe.bodies`), each vertex weighted
to up to four bones through JOINTS_0/WEIGHTS_0, or for `--look bones` all its bone shapes
merged, each vertex weighted 1.0 to its bone; colours in COLOR_0. Its skin's inverse bind
matrices are the bones' rest translations. One animation, `clip`, has a LINEAR translation and
rotation channel per joint and per prop, keyed at every frame; a prop absent from some frames
(a thrown box before its throw) also has a STEP scale channel, 0 while absent, and holds still
then (`quadpipe.exporters.layout`). Rotations stay in one hemisphere frame to frame, so no
interpolation swings the long way round. The file is written with numpy, json and struct only,
byte-identical for the same clip.
"""

from __future__ import annotations

import json
import struct
from pathlib import Path
from typing import Any

import numpy as np

from quadpipe.clip.bind import GLTF_BONE_AXIS, bound_poses
from quadpipe.clip.kinematics import continuous, normalize, quat_to_y_up, to_matrix, to_y_up
from quadpipe.clip.meshes import TriangleMesh, merge, shape_mesh, shapes_mesh
from quadpipe.clip.model import AnimalTrack, Clip, PropTrack
from quadpipe.core.atomic import transaction, write_bytes
from quadpipe.core.version import __version__
from quadpipe.exporters.layout import BODY_SUFFIX, held_poses, switches

GLB_MAGIC = 0x46546C67
GLB_VERSION = 2
CHUNK_JSON = 0x4E4F534A
CHUNK_BIN = 0x004E4942

FLOAT, UNSIGNED_BYTE, UNSIGNED_SHORT, UNSIGNED_INT = 5126, 5121, 5123, 5125
ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER = 34962, 34963
COMPONENT_DTYPES = {FLOAT: np.float32, UNSIGNED_BYTE: np.uint8, UNSIGNED_SHORT: np.uint16, UNSIGNED_INT: np.uint32}
ELEMENT_TYPES = {1: "SCALAR", 2: "VEC2", 3: "VEC3", 4: "VEC4", 16: "MAT4"}

ALIGNMENT = 4
"""Every buffer view starts on a 4-byte boundary (the largest component here is 4 bytes)."""

MATERIAL = {
    "name": "quadpipe",
    "pbrMetallicRoughness": {"baseColorFactor": [1.0, 1.0, 1.0, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.8},
}
"""The one material: white, matte; shapes' colours come from the COLOR_0 vertex colours."""

ANIMATION_NAME = "clip"


class _Document:
    """A glTF document being built: JSON objects and one binary buffer.

    Args:
        key_times: the animation's key times in seconds (one per frame), shared by all samplers.
    """

    def __init__(self, key_times: np.ndarray) -> None:
        self.key_times = key_times
        self.input: int | None = None
        self.binary = bytearray()
        self.json: dict[str, Any] = {
            "asset": {"version": "2.0", "generator": f"quadpipe {__version__}"},
            "scene": 0,
            "scenes": [{"name": "quadpipe", "nodes": []}],
            "nodes": [],
            "meshes": [],
            "materials": [MATERIAL],
            "accessors": [],
            "bufferViews": [],
            "buffers": [],
        }
        self.skins: list[dict] = []
        self.channels: list[dict] = []
        self.samplers: list[dict] = []

    def add(self, kind: str, item: dict) -> int:
        """Append a JSON object to a top-level array, returning its index."""
        self.json[kind].append(item)
        return len(self.json[kind]) - 1

    def accessor(self, values: np.ndarray, component: int, *, target: int | None = None, bounds: bool = False) -> int:
        """Store `values` (N, k) or (N,) in a buffer view of its own and describe them.

        Args:
            values: the data; cast to the component type's dtype.
            component: glTF component type (FLOAT, UNSIGNED_SHORT, ...).
            target: ARRAY_BUFFER for vertex attributes, ELEMENT_ARRAY_BUFFER for indices.
            bounds: record exact per-component min and max (POSITION, animation input).
        """
        data = np.ascontiguousarray(values, dtype=COMPONENT_DTYPES[component])
        width = 1 if data.ndim == 1 else data.shape[1]
        self.binary.extend(b"\0" * (-len(self.binary) % ALIGNMENT))
        view = {"buffer": 0, "byteOffset": len(self.binary), "byteLength": data.nbytes}
        if target is not None:
            view["target"] = target
        self.binary.extend(data.tobytes())
        accessor: dict[str, Any] = {
            "bufferView": self.add("bufferViews", view),
            "componentType": component,
            "count": int(data.shape[0]),
            "type": ELEMENT_TYPES[width],
        }
        if bounds:
            columns = data.reshape(len(data), width)
            # .item() gives a float32 its exact value as a Python float: min/max match the data bit for bit
            accessor["min"] = [v.item() for v in columns.min(axis=0)]
            accessor["max"] = [v.item() for v in columns.max(axis=0)]
        return self.add("accessors", accessor)

    def node(self, item: dict, *, root: bool = False) -> int:
        """Add a node; `root` also lists it in the scene."""
        index = self.add("nodes", item)
        if root:
            self.json["scenes"][0]["nodes"].append(index)
        return index

    def animate(self, node: int, path: str, values: np.ndarray) -> None:
        """A LINEAR channel moving `node`'s `path` (translation, rotation) through `values`, one per key."""
        if self.input is None:
            self.input = self.accessor(self.key_times, FLOAT, bounds=True)
        self._channel(node, path, self.input, values, "LINEAR")

    def step(self, node: int, path: str, frames: np.ndarray, values: np.ndarray) -> None:
        """A STEP channel setting `node`'s `path` to `values` at `frames` (each held until the next)."""
        self._channel(node, path, self.accessor(self.key_times[frames], FLOAT, bounds=True), values, "STEP")

    def _channel(self, node: int, path: str, input: int, values: np.ndarray, interpolation: str) -> None:
        output = self.accessor(values, FLOAT)
        self.samplers.append({"input": input, "output": output, "interpolation": interpolation})
        self.channels.append({"sampler": len(self.samplers) - 1, "target": {"node": node, "path": path}})

    def finish(self, uri: str | None) -> dict[str, Any]:
        """The complete JSON (the buffer referenced by `uri`, or the GLB's own chunk when None)."""
        self.binary.extend(b"\0" * (-len(self.binary) % ALIGNMENT))
        buffer: dict[str, Any] = {"byteLength": len(self.binary)}
        if uri is not None:
            buffer["uri"] = uri
        self.json["buffers"] = [buffer]
        if self.skins:
            self.json["skins"] = self.skins
        if self.channels:
            self.json["animations"] = [{"name": ANIMATION_NAME, "channels": self.channels, "samplers": self.samplers}]
        return {key: value for key, value in self.json.items() if value != []}


def build(clip: Clip, uri: str | None = None) -> tuple[dict[str, Any], bytes]:
    """The glTF JSON and binary buffer of a clip.

    Args:
        clip: the clip.
        uri: the external buffer's file name (`.gltf`), None for a GLB's embedded buffer.
    """
    doc = _Document(clip.times())
    doc.json["asset"]["extras"] = {"fps": float(clip.fps), **clip.metadata}
    for track in clip.animals:
        _add_animal(doc, track, prefix=f"{track.name}_" if len(clip.animals) > 1 else "")
    for prop in clip.props:
        _add_prop(doc, prop)
    if clip.terrain:
        mesh = doc.add("meshes", {"name": "terrain", "primitives": [_primitive(doc, shapes_mesh(clip.terrain))]})
        doc.node({"name": "terrain", "mesh": mesh}, root=True)
    return doc.finish(uri), bytes(doc.binary)


def _primitive(
    doc: _Document, mesh: TriangleMesh, joints: np.ndarray | None = None, weights: np.ndarray | None = None
) -> dict:
    """A triangle primitive (y-up) with normals and colours, skinned when joints are given.

    Args:
        joints: (N,) the one bone of each vertex (rigid, weight 1), or (N, 4) bones with `weights`.
    """
    attributes = {
        "POSITION": doc.accessor(to_y_up(mesh.vertices), FLOAT, target=ARRAY_BUFFER, bounds=True),
        "NORMAL": doc.accessor(normalize(to_y_up(mesh.normals)), FLOAT, target=ARRAY_BUFFER),
        "COLOR_0": doc.accessor(mesh.colors[:, :3], FLOAT, target=ARRAY_BUFFER),
    }
    if joints is not None:
        if weights is None:
            joints, weights = joints[:, None], np.ones((len(joints), 1))
        influences = np.zeros((len(joints), 4), dtype=np.int64)
        influences[:, : joints.shape[1]] = joints
        padded = np.zeros((len(joints), 4))
        padded[:, : weights.shape[1]] = weights
        joint_type = UNSIGNED_BYTE if joints.max(initial=0) < 256 else UNSIGNED_SHORT
        attributes["JOINTS_0"] = doc.accessor(influences, joint_type, target=ARRAY_BUFFER)
        attributes["WEIGHTS_0"] = doc.accessor(padded, FLOAT, target=ARRAY_BUFFER)
    index_type = UNSIGNED_SHORT if len(mesh.vertices) <= np.iinfo(np.uint16).max else UNSIGNED_INT
    indices = doc.accessor(mesh.faces.reshape(-1), index_type, target=ELEMENT_ARRAY_BUFFER)
    return {"attributes": attributes, "indices": indices, "material": 0, "mode": 4}


def _add_animal(doc: _Document, track: AnimalTrack, prefix: str) -> None:
    """An animal's joint nodes, skinned mesh, skin and animation channels (bone 0 is the root).
    Each joint's local +Y points along its bone at rest (`quadpipe.clip.bind`)."""
    poses = bound_poses(track, GLTF_BONE_AXIS)
    offsets = to_y_up(poses.rest_translations)
    turns = _xyzw(quat_to_y_up(poses.rest_rotations))
    first = len(doc.json["nodes"]) + 1
    joints = [first + index for index in range(len(track.roles))]
    doc.node({"name": track.name, "children": [joints[r] for r in np.flatnonzero(track.parents < 0)]}, root=True)
    for index, role in enumerate(track.roles):
        children = [joints[c] for c in np.flatnonzero(track.parents == index)]
        node = {
            "name": prefix + role,
            "translation": [float(v) for v in offsets[index]],
            "rotation": [float(v) for v in turns[index]],
        }
        if children:
            node["children"] = children
        doc.node(node)

    for index, joint in enumerate(joints):
        doc.animate(joint, "translation", to_y_up(poses.translations[:, index]))
        doc.animate(joint, "rotation", _xyzw(quat_to_y_up(poses.rotations[:, index])))

    primitive = _body_primitive(doc, track) if track.body is not None else _bones_primitive(doc, track)
    if primitive is None:
        return
    mesh = doc.add("meshes", {"name": track.name, "primitives": [primitive]})
    inverse_bind = np.tile(np.eye(4), (len(joints), 1, 1))
    unturn = to_matrix(quat_to_y_up(poses.bind)).transpose(0, 2, 1)
    inverse_bind[:, :3, :3] = unturn
    inverse_bind[:, :3, 3] = -np.einsum("bij,bj->bi", unturn, to_y_up(track.rest_start))
    skin = {
        "name": track.name,
        "inverseBindMatrices": doc.accessor(inverse_bind.transpose(0, 2, 1).reshape(-1, 16), FLOAT),
        "skeleton": joints[0],
        "joints": joints,
    }
    doc.skins.append(skin)
    extras = {"species": track.species, "pelvis_height_m": track.pelvis_height, "mass_kg": track.mass_kg}
    doc.node({"name": track.name + BODY_SUFFIX, "mesh": mesh, "skin": len(doc.skins) - 1, "extras": extras}, root=True)


def _bones_primitive(doc: _Document, track: AnimalTrack) -> dict | None:
    """The bones' shapes merged into one primitive, each vertex rigidly on its bone (None: no shapes)."""
    bones = [index for index, shapes in enumerate(track.shapes) if shapes]
    if not bones:
        return None
    pieces = [shapes_mesh(track.shapes[b]).translated(track.rest_start[b]) for b in bones]
    bone_of_vertex = np.concatenate([np.full(len(piece.vertices), b) for piece, b in zip(pieces, bones)])
    return _primitive(doc, merge(pieces), bone_of_vertex)


def _body_primitive(doc: _Document, track: AnimalTrack) -> dict:
    """The animal's body mesh, smoothly skinned (up to four weighted bones per vertex)."""
    body = track.body
    assert body is not None
    mesh = TriangleMesh(body.vertices, body.normals, body.colors, body.faces)
    weights = np.asarray(body.weights, dtype=np.float32)
    weights /= weights.sum(axis=1, keepdims=True)  # each sums to 1 in float32, as the validator checks
    return _primitive(doc, mesh, body.joints, weights)


def _add_prop(doc: _Document, prop: PropTrack) -> None:
    """A prop: a node with its shape's mesh, moved by translation and rotation channels, and
    scaled to 0 by a STEP channel while it is out of the scene."""
    mesh = doc.add("meshes", {"name": prop.name, "primitives": [_primitive(doc, shape_mesh(prop.shape))]})
    held_positions, held_rotations = held_poses(prop)
    positions = to_y_up(held_positions)
    rotations = _xyzw(quat_to_y_up(continuous(normalize(held_rotations))))
    frames, present = switches(prop)
    node = {
        "name": prop.name,
        "mesh": mesh,
        "translation": [float(v) for v in positions[0]],
        "rotation": [float(v) for v in rotations[0]],
        "extras": {"mass_kg": prop.mass_kg},
    }
    if not present[0]:
        node["scale"] = [0.0, 0.0, 0.0]
    index = doc.node(node, root=True)
    doc.animate(index, "translation", positions)
    doc.animate(index, "rotation", rotations)
    if len(frames) > 1 or not present[0]:
        doc.step(index, "scale", frames, np.repeat(present.astype(np.float32)[:, None], 3, axis=1))


def _xyzw(quats: np.ndarray) -> np.ndarray:
    """(w, x, y, z) -> glTF's (x, y, z, w), renormalized in float32 so each stays unit length."""
    ordered = np.roll(normalize(quats), -1, axis=-1).astype(np.float32)
    return ordered / np.linalg.norm(ordered, axis=-1, keepdims=True)


def _json_bytes(document: dict, pad: bytes = b"") -> bytes:
    text = json.dumps(document, separators=(",", ":"), ensure_ascii=False).encode("utf-8")
    return text + pad * (-len(text) % ALIGNMENT)


def glb_bytes(clip: Clip) -> bytes:
    """A clip as a GLB file's bytes: header, JSON chunk, BIN chunk."""
    document, binary = build(clip)
    json_chunk = _json_bytes(document, b" ")
    chunks = [(CHUNK_JSON, json_chunk), (CHUNK_BIN, binary)]
    body = b"".join(struct.pack("<II", len(data), kind) + data for kind, data in chunks)
    return struct.pack("<III", GLB_MAGIC, GLB_VERSION, 12 + len(body)) + body


def export_glb(clip: Clip, path: Path) -> None:
    """glTF 2.0 binary: skinned meshes, joint hierarchy, animation, props, terrain."""
    write_bytes(path, glb_bytes(clip))


def export_gltf(clip: Clip, path: Path) -> None:
    """glTF 2.0 JSON with its .bin buffer beside it (same content as .glb)."""
    bin_path = path.with_suffix(".bin")
    document, binary = build(clip, uri=bin_path.name)
    with transaction():
        write_bytes(bin_path, binary)
        write_bytes(path, _json_bytes(document, b" "))
