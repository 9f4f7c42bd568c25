"""Skinned body meshes: each animal's skin, built from its skeleton and its species' girths.

`body_mesh(track)` sweeps elliptical tubes along the rest skeleton (trunk, neck, head, ears,
legs, tail; `sweeps`) with the species' girths (`profile`, from `configs/bodies/`), unites them
smoothly into one implicit surface (`field`), meshes it watertight (`surface`: marching
tetrahedra, Taubin smoothing, then quadric decimation to about `TARGET_TRIANGLES`) and weights
every vertex to at most four bones. The mesh is in the rest (bind) pose, in the clip's world
frame; it is visual only (the physics keeps its capsules).

`dress(clip, look)` gives each animal its body (`look="body"`) or none (`"bones"`: the
exporters and the renderer then draw the bone capsules). An animal that already has a body
(one that came with its rig) keeps it.
"""

from __future__ import annotations

import dataclasses
import functools
from typing import Literal, get_args

import numpy as np

from quadpipe.bodies.field import body_field, skin_weights, sweep_bounds
from quadpipe.bodies.profile import body_profile
from quadpipe.bodies.surface import contour
from quadpipe.bodies.sweeps import Sweep, body_sweeps
from quadpipe.clip.model import AnimalTrack, BodyMesh, Clip

Look = Literal["body", "bones"]
LOOKS: tuple[str, ...] = get_args(Look)
"""How animals are drawn: a skinned body mesh, or their bone capsules."""

GRID_CELLS = 130
"""Grid cells along the body's longest side (the surface is sampled at this resolution)."""

MIN_RADIUS_CELLS = 1.3
"""No sweep is thinner than this many grid cells (ears, tail tips), so the grid sees it."""

BLEND_HP, FALLOFF_HP = 0.015, 0.02
"""Smooth-union width and skin-weight falloff, in pelvis heights."""

INFLUENCES = 4
"""Bones per vertex at most (glTF's JOINTS_0, what game engines take)."""

TARGET_TRIANGLES = 20000
"""Triangles of a body after decimation."""

POSE_DECIMALS = 9
"""Rest poses (relative to the root joint, in metres) equal to this many decimals (a nanometre)
share one body: the same skeleton placed elsewhere differs by rounding only."""


__all__ = ["LOOKS", "BodyMesh", "Look", "body_mesh", "dress"]


def dress(clip: Clip, look: Look = "body") -> Clip:
    """The clip with a body on every animal (`body`), or on none (`bones`); bodies that came
    with a rig are kept."""
    if look == "bones":
        animals = [dataclasses.replace(track, body=None) for track in clip.animals]
    else:
        animals = [
            track if track.body is not None else dataclasses.replace(track, body=body_mesh(track))
            for track in clip.animals
        ]
    return dataclasses.replace(clip, animals=animals)


def body_mesh(track: AnimalTrack) -> BodyMesh:
    """The skinned body of an animal, in its rest pose (cached per species, size and pose
    relative to the root joint, to `POSE_DECIMALS`, so that the animals of a crowd share one
    body moved to each)."""
    origin = track.rest_start[0]
    body = _body_mesh(
        track.species,
        float(track.pelvis_height),
        float(track.mass_kg),
        np.round(track.rest_start - origin, POSE_DECIMALS).tobytes(),
        np.round(track.rest_end - origin, POSE_DECIMALS).tobytes(),
        track.roles,
    )
    return dataclasses.replace(body, vertices=body.vertices + origin)


@functools.lru_cache(maxsize=32)
def _body_mesh(
    species: str, pelvis_height: float, mass_kg: float, start: bytes, end: bytes, roles: tuple[str, ...]
) -> BodyMesh:
    profile = body_profile(species, pelvis_height, mass_kg)
    sweeps = body_sweeps(roles, np.frombuffer(start).reshape(-1, 3), np.frombuffer(end).reshape(-1, 3), profile)
    low, high = _bounds(sweeps)
    spacing = float((high - low).max()) / GRID_CELLS
    sweeps = [_thickened(sweep, MIN_RADIUS_CELLS * spacing) for sweep in sweeps]
    low, high = _bounds(sweeps)
    blend = BLEND_HP * pelvis_height
    margin = 3.0 * spacing + blend
    axes = [np.arange(lo - margin, hi + margin + spacing, spacing) for lo, hi in zip(low, high)]
    values = body_field(sweeps, axes, blend)
    vertices, faces = contour(values, np.array([axis[0] for axis in axes]), spacing)
    vertices, faces, normals = _decimated(vertices, faces)
    joints, weights = skin_weights(sweeps, vertices, len(roles), FALLOFF_HP * pelvis_height, INFLUENCES)
    colors = np.tile([*profile.coat_rgb, 1.0], (len(vertices), 1))
    return BodyMesh(vertices, normals, colors, faces, joints, weights)


def _bounds(sweeps: list[Sweep]) -> tuple[np.ndarray, np.ndarray]:
    corners = [sweep_bounds(sweep) for sweep in sweeps]
    return np.min([c[0] for c in corners], axis=0), np.max([c[1] for c in corners], axis=0)


def _thickened(sweep: Sweep, minimum: float) -> Sweep:
    return dataclasses.replace(
        sweep, depths=np.maximum(sweep.depths, minimum), widths=np.maximum(sweep.widths, minimum)
    )


def _decimated(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The mesh reduced to about `TARGET_TRIANGLES` by quadric edge collapse, with smooth normals."""
    import open3d as o3d

    mesh = o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(vertices), o3d.utility.Vector3iVector(faces))
    if len(faces) > TARGET_TRIANGLES:
        mesh = mesh.simplify_quadric_decimation(TARGET_TRIANGLES)
    mesh.compute_vertex_normals()
    return (
        np.asarray(mesh.vertices).copy(),
        np.asarray(mesh.triangles).astype(np.int64),
        np.asarray(mesh.vertex_normals).copy(),
    )
