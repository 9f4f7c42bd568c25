"""What a preview window draws: the scenery (shapes per body), poses, and overlay layers.

Plain numpy, built from a compiled MuJoCo world (`model_scenery`) or from a baked clip
(`clip_scenery`, `clip_poses`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import mujoco
import numpy as np

from quadpipe.clip.model import Clip, Shape
from quadpipe.sim.recording import geom_shape
from quadpipe.world.throws import PARK_DEPTH_HP

HIDDEN_BELOW_HP = PARK_DEPTH_HP / 2
"""A body deeper than this many pelvis heights under the floor is parked, and not drawn (pool
bodies wait `PARK_DEPTH_HP` under it, colliding with nothing and held against gravity, as the
scene's thrown objects do)."""

OverlayKind = Literal["line", "arrow", "point"]

_DRAWABLE_GEOMS = {
    int(mujoco.mjtGeom.mjGEOM_CAPSULE),
    int(mujoco.mjtGeom.mjGEOM_BOX),
    int(mujoco.mjtGeom.mjGEOM_SPHERE),
    int(mujoco.mjtGeom.mjGEOM_PLANE),
}
"""Geom types a preview draws (those a `quadpipe.clip.model.Shape` can carry)."""


@dataclass(frozen=True)
class BodyShapes:
    """A moving body to draw: its name and its shapes, in its own frame."""

    name: str
    shapes: tuple[Shape, ...]


@dataclass(frozen=True)
class Scenery:
    """Everything to draw, built once per world.

    Attributes:
        bodies: the moving bodies, in the order of `Pose` rows.
        static: shapes fixed in the world (floor, terrain), world coordinates.
        hp: the first animal's pelvis height, metres (the length unit of the view).
    """

    bodies: tuple[BodyShapes, ...]
    static: tuple[Shape, ...]
    hp: float


@dataclass(frozen=True)
class Pose:
    """Where every body of the scenery is now.

    Attributes:
        positions: (B, 3) world positions of the body frames, metres (finite).
        quaternions: (B, 4) world orientations (w, x, y, z).
        visible: (B,) whether to draw each body (parked and diverged ones are not).
    """

    positions: np.ndarray
    quaternions: np.ndarray
    visible: np.ndarray


@dataclass(frozen=True)
class OverlayLayer:
    """One named layer of decorations at the current time.

    Attributes:
        name: the layer (`segments`, `balance`, ...).
        kind: `line` (start to end), `arrow` (the same, with a head at the end) or `point` (at start).
        starts: (K, 3) start points, metres.
        ends: (K, 3) end points (equal to `starts` for points).
        colors: (K, 4) RGBA per item.
    """

    name: str
    kind: OverlayKind
    starts: np.ndarray
    ends: np.ndarray
    colors: np.ndarray


def layer(
    name: str, kind: OverlayKind, starts: np.ndarray, ends: np.ndarray | None, rgba: Sequence[float] | np.ndarray
) -> OverlayLayer:
    """An overlay layer; `rgba` is one colour for all items, or one per item."""
    starts = np.asarray(starts, dtype=float).reshape(-1, 3)
    ends = starts.copy() if ends is None else np.asarray(ends, dtype=float).reshape(-1, 3)
    colors = np.asarray(rgba, dtype=float)
    colors = np.tile(colors, (len(starts), 1)) if colors.ndim == 1 else colors.reshape(-1, 4)
    return OverlayLayer(name, kind, starts, ends, colors)


def model_scenery(model: mujoco.MjModel, hp: float) -> tuple[Scenery, np.ndarray]:
    """The drawable shapes of a compiled world: per moving body, and the world body's; with the body ids."""
    bodies, ids = [], []
    for body in range(1, model.nbody):
        shapes = _geom_shapes(model, body)
        if shapes:
            bodies.append(BodyShapes(model.body(body).name, shapes))
            ids.append(body)
    return Scenery(tuple(bodies), _geom_shapes(model, 0), hp), np.array(ids, dtype=int)


def _geom_shapes(model: mujoco.MjModel, body: int) -> tuple[Shape, ...]:
    start = int(model.body_geomadr[body])
    geoms = range(start, start + int(model.body_geomnum[body])) if start >= 0 else range(0)
    return tuple(geom_shape(model, g) for g in geoms if int(model.geom_type[g]) in _DRAWABLE_GEOMS)


def pose_of(positions: np.ndarray, quaternions: np.ndarray, lowest: float) -> Pose:
    """A pose whose bodies below `lowest` (parked) or not finite (diverged) are hidden."""
    finite = np.isfinite(positions).all(axis=1) & np.isfinite(quaternions).all(axis=1)
    visible = finite & (np.where(finite, positions[:, 2], 0.0) > lowest)
    safe_quats = np.where(finite[:, None], quaternions, [1.0, 0.0, 0.0, 0.0])
    return Pose(np.where(finite[:, None], positions, 0.0), safe_quats, visible)


def clip_scenery(clip: Clip) -> Scenery:
    """The drawable shapes of a clip: every animal bone (`name/role`), every prop, the terrain."""
    bodies = [
        BodyShapes(f"{track.name}/{role}", tuple(shapes))
        for track in clip.animals
        for role, shapes in zip(track.roles, track.shapes)
    ]
    bodies += [BodyShapes(prop.name, (prop.shape,)) for prop in clip.props]
    hp = clip.animals[0].pelvis_height if clip.animals else 1.0
    return Scenery(tuple(bodies), tuple(clip.terrain), float(hp))


def clip_poses(clip: Clip) -> tuple[np.ndarray, np.ndarray]:
    """(F, B, 3) positions and (F, B, 4) orientations of the scenery's bodies, in its order."""
    positions = [track.positions for track in clip.animals] + [prop.positions[:, None] for prop in clip.props]
    rotations = [track.rotations for track in clip.animals] + [prop.rotations[:, None] for prop in clip.props]
    return np.concatenate(positions, axis=1), np.concatenate(rotations, axis=1)
