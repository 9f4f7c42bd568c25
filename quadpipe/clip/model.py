"""The format-free clip: what a simulation produces and every exporter consumes.

A `Clip` holds, for each frame at `fps`, the world pose of every bone of every animal and of
every moving prop, plus the static world (terrain) and per-frame extras (foot contacts, sensor
values). Poses are in quadpipe's frame (metres, +X forward, +Y left, +Z up); exporters convert
to their format's conventions (glTF: +Y up; USD: the stage's up axis).

Each bone has a *body frame*: origin at the bone's joint, axes aligned with the world in the
rest pose. So a bone's rest (bind) transform is a pure translation to `rest_start`, and its
shapes are given in that frame. The rest pose faces +x at the animal's start position whatever
heading the animal starts with (the heading is part of the motion, not of the bind pose).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from quadpipe.anatomy.binding import RigBinding

ShapeKind = Literal["capsule", "box", "sphere", "plane"]


@dataclass(frozen=True)
class Shape:
    """A collision/visual primitive in its owner's frame.

    Attributes:
        kind: capsule, box, sphere or plane.
        size: capsule (radius, half length); box (half x, half y, half z); sphere (radius,);
            plane (half x, half y).
        pos: centre in the owner's frame, metres.
        quat: orientation in the owner's frame, (w, x, y, z); a capsule's axis is its local Z.
        rgba: display colour.
    """

    kind: ShapeKind
    size: tuple[float, ...]
    pos: tuple[float, float, float] = (0.0, 0.0, 0.0)
    quat: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)
    rgba: tuple[float, float, float, float] = (0.8, 0.8, 0.8, 1.0)


@dataclass(frozen=True)
class BodyMesh:
    """An animal's skin: a closed triangle mesh in the rest (bind) pose, skinned to its bones.

    Attributes:
        vertices: (N, 3) rest positions, world frame, metres.
        normals: (N, 3) unit normals.
        colors: (N, 4) RGBA per vertex.
        faces: (M, 3) vertex indices, counter-clockwise seen from outside.
        joints: (N, K) bone indices (into the track's roles) influencing each vertex.
        weights: (N, K) their weights, each row summing to 1.
    """

    vertices: np.ndarray
    normals: np.ndarray
    colors: np.ndarray
    faces: np.ndarray
    joints: np.ndarray
    weights: np.ndarray


@dataclass
class AnimalTrack:
    """One animal's motion.

    Attributes:
        name: instance name in the scene (`dog`, `dog2`).
        species: the animal config's name.
        roles: the bones, parents first (the 39 roles).
        parents: index of each bone's parent in `roles`, -1 for the root.
        rest_start: (B, 3) joint positions in the rest pose (world, with the animal at its start
            placement).
        rest_end: (B, 3) bone end points in the rest pose.
        shapes: per bone, its shapes in the bone's body frame.
        positions: (F, B, 3) world position of each bone's body frame origin (its joint).
        rotations: (F, B, 4) world orientation of each bone's body frame, (w, x, y, z).
        pelvis_height: HP in metres, the animal's length unit for thresholds.
        mass_kg: body mass.
        foot_contacts: (F, 4) booleans, legs in `quadpipe.anatomy.roles.LEGS` order.
        body: its skinned body mesh, None to draw the bones' shapes (see `quadpipe.bodies`).
        rig: the source rig's own joints, when the animal came from a rig that is not simply
            the 39 roles; exporters write the motion onto them (`quadpipe.clip.retarget`). A
            track already on them has the rig's joint names as its `roles`.
    """

    name: str
    species: str
    roles: tuple[str, ...]
    parents: np.ndarray
    rest_start: np.ndarray
    rest_end: np.ndarray
    shapes: list[list[Shape]]
    positions: np.ndarray
    rotations: np.ndarray
    pelvis_height: float
    mass_kg: float
    foot_contacts: np.ndarray
    body: BodyMesh | None = None
    rig: RigBinding | None = None


@dataclass
class PropTrack:
    """A moving rigid object (thrown box, ball, capsule): its shape and per-frame pose.

    Attributes:
        present: (F,) booleans, whether the prop is in the scene at each frame (a thrown box
            waits out of the scene until its throw, at a pose that means nothing); None when
            it always is.
    """

    name: str
    shape: Shape
    positions: np.ndarray
    rotations: np.ndarray
    mass_kg: float
    present: np.ndarray | None = None

    def presence(self) -> np.ndarray:
        """(F,) booleans: whether the prop is in the scene at each frame."""
        if self.present is None:
            return np.ones(len(self.positions), dtype=bool)
        return np.asarray(self.present, dtype=bool)


@dataclass
class Clip:
    """A baked simulation: frames at `fps` of every animal and prop, and the static world.

    Attributes:
        fps: frames per second (30 in the thesis).
        animals: the animals' tracks.
        props: moving objects.
        terrain: static world shapes (floor, hills, stairs), in world coordinates.
        sensors: per-frame sensor values by name, each (F, ...).
        metadata: controller, scene, seed, quadpipe version, and `status` ("ok", or why it stopped).
    """

    fps: float
    animals: list[AnimalTrack]
    props: list[PropTrack] = field(default_factory=list)
    terrain: list[Shape] = field(default_factory=list)
    sensors: dict[str, np.ndarray] = field(default_factory=dict)
    metadata: dict[str, str] = field(default_factory=dict)

    @property
    def frame_count(self) -> int:
        """Number of frames."""
        if self.animals:
            return int(self.animals[0].positions.shape[0])
        return int(self.props[0].positions.shape[0]) if self.props else 0

    @property
    def duration(self) -> float:
        """Length in seconds (from the first to the last frame)."""
        return max(0, self.frame_count - 1) / self.fps

    def times(self) -> np.ndarray:
        """Time of each frame, seconds."""
        return np.arange(self.frame_count) / self.fps
