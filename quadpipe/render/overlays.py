"""Overlays: per-frame lines, arrows and points drawn over a clip, and the built-in ones (foot
contacts, the pelvis trail, a directed clip's path), added to each frame's scene as decoration geoms."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

import numpy as np

from quadpipe.anatomy import roles
from quadpipe.anatomy.roles import TOE_BONES
from quadpipe.clip.kinematics import rotate
from quadpipe.clip.model import Clip
from quadpipe.core.errors import QuadpipeError, did_you_mean
from quadpipe.render.poses import clip_scale, finite_hold
from quadpipe.world.timeline import DIRECTION_KEY, timelines_from_json

if TYPE_CHECKING:
    import mujoco

SEGMENT_EPSILON_M = 1e-9
"""Overlay lines and arrows shorter than this are skipped (they have no direction)."""

ARROW_STRETCH = 2.0
"""MuJoCo draws an arrow geom of length L with its tip at L/2 (a shaft over [0, L/3] and a
cone over [L/3, L/2], see `renderGeom` in render_gl3.c), so overlay arrows are given twice
their length to end where the caller asked."""

OverlayKind = Literal["line", "arrow", "point"]
OVERLAY_KINDS: tuple[str, ...] = ("line", "arrow", "point")

CONTACT_RGBA = (0.2, 0.9, 0.3, 1.0)
CONTACT_SIZE_HP = 0.1
"""Foot contact markers: green spheres of this diameter (pelvis heights) at the toe tips."""

TRAIL_RGBA = (1.0, 0.55, 0.1, 0.9)
TRAIL_WIDTH_HP = 0.02
TRAIL_SECONDS = 3.0
"""Pelvis trail: the last seconds of each animal's pelvis path, as an orange line."""

PATH_RGBA = (0.2, 0.5, 1.0, 0.8)
PATH_WIDTH_HP = 0.03
PATH_LIFT_HP = 0.01
"""A directed clip's path: a blue line on the floor plane (this high above it, in HP)."""

DEFAULT_OVERLAYS = ("contacts", "trail", "path")
"""The built-in overlays drawn unless the caller says otherwise."""


@dataclass(frozen=True, eq=False)
class Overlay:
    """A layer of per-frame decorations drawn over a clip.

    Attributes:
        name: what it shows (`contacts`, `balance`); for messages and legends.
        kind: `line` (a thin cylinder from start to end), `arrow` (the same with a head at the
            end) or `point` (a sphere at start; `ends` is ignored).
        starts: (F, K, 3) per clip frame, K start points, metres. Rows with NaN are not drawn,
            so a layer can show a varying number of items per frame.
        ends: (F, K, 3) end points (None for points).
        rgba: colour (alpha < 1 is see-through).
        width: line thickness or sphere diameter, metres.
    """

    name: str
    kind: OverlayKind
    starts: np.ndarray
    ends: np.ndarray | None
    rgba: tuple[float, float, float, float]
    width: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "starts", np.asarray(self.starts, dtype=float))
        if self.ends is not None:
            object.__setattr__(self, "ends", np.asarray(self.ends, dtype=float))

    def check(self, frame_count: int) -> None:
        """Raise if the arrays do not fit a clip of `frame_count` frames.

        Raises:
            QuadpipeError: code `bad-overlay`.
        """
        problem = None
        if self.kind not in OVERLAY_KINDS:
            problem = f"kind {self.kind!r} is not one of {', '.join(OVERLAY_KINDS)}"
        elif self.starts.ndim != 3 or self.starts.shape[0] != frame_count or self.starts.shape[2] != 3:
            problem = f"starts has shape {self.starts.shape}, expected ({frame_count}, K, 3)"
        elif self.kind != "point" and (self.ends is None or self.ends.shape != self.starts.shape):
            problem = f"ends must have the shape of starts {self.starts.shape} for {self.kind}s"
        elif not self.width > 0:
            problem = f"width {self.width} is not positive"
        if problem:
            raise QuadpipeError.single("bad-overlay", f"overlay {self.name!r}: {problem}")


def contact_overlay(clip: Clip) -> Overlay:
    """Green spheres at the toe tips of every foot touching the ground, per frame."""
    frames, legs = clip.frame_count, len(roles.LEGS)
    starts = np.full((frames, legs * len(clip.animals), 3), np.nan)
    for index, track in enumerate(clip.animals):
        for leg_index, leg in enumerate(roles.LEGS):
            bone = track.roles.index(TOE_BONES[leg])
            tips = finite_hold(track.positions[:, bone]) + rotate(
                finite_hold(track.rotations[:, bone]), track.rest_end[bone] - track.rest_start[bone]
            )
            column = index * legs + leg_index
            down = track.foot_contacts[:, leg_index].astype(bool)
            starts[down, column] = tips[down]
    return Overlay("contacts", "point", starts, None, CONTACT_RGBA, CONTACT_SIZE_HP * clip_scale(clip))


def trail_overlay(clip: Clip) -> Overlay:
    """An orange line along the last `TRAIL_SECONDS` of each animal's pelvis path, per frame."""
    history = max(1, round(TRAIL_SECONDS * clip.fps))
    frames = clip.frame_count
    starts = np.full((frames, history * len(clip.animals), 3), np.nan)
    ends = np.full_like(starts, np.nan)
    for index, track in enumerate(clip.animals):
        path = track.positions[:, track.roles.index("pelvis")]
        for frame in range(1, frames):
            first = max(0, frame - history)
            count = frame - first
            columns = slice(index * history, index * history + count)
            starts[frame, columns] = path[first:frame]
            ends[frame, columns] = path[first + 1 : frame + 1]
    return Overlay("trail", "line", starts, ends, TRAIL_RGBA, TRAIL_WIDTH_HP * clip_scale(clip))


def path_overlay(clip: Clip) -> Overlay:
    """A directed clip's paths (docs/direction.md) as blue lines on the floor plane, every
    frame; nothing for a clip without a direction."""
    timelines = timelines_from_json(clip.metadata[DIRECTION_KEY]) if DIRECTION_KEY in clip.metadata else {}
    lift = PATH_LIFT_HP * clip_scale(clip)
    lines = [np.column_stack([t.points, np.full(len(t.points), lift)]) for t in timelines.values()]
    starts = np.concatenate([line[:-1] for line in lines]) if lines else np.zeros((0, 3))
    ends = np.concatenate([line[1:] for line in lines]) if lines else np.zeros((0, 3))
    frames = (clip.frame_count, len(starts), 3)
    return Overlay(
        "path",
        "line",
        np.broadcast_to(starts, frames),
        np.broadcast_to(ends, frames),
        PATH_RGBA,
        PATH_WIDTH_HP * clip_scale(clip),
    )


BUILTIN_OVERLAYS: dict[str, Callable[[Clip], Overlay]] = {
    "contacts": contact_overlay,
    "trail": trail_overlay,
    "path": path_overlay,
}
"""Overlays quadpipe computes from the clip itself, by name."""


def builtin_overlays(clip: Clip, names: Sequence[str] = DEFAULT_OVERLAYS) -> list[Overlay]:
    """The named built-in overlays of a clip.

    Raises:
        QuadpipeError: code `unknown-overlay` for a name that is not built in.
    """
    for name in names:
        if name not in BUILTIN_OVERLAYS:
            raise QuadpipeError.single(
                "unknown-overlay", f"there is no built-in overlay {name!r}", hint=did_you_mean(name, BUILTIN_OVERLAYS)
            )
    return [BUILTIN_OVERLAYS[name](clip) for name in names]


def draw_overlay(scene: mujoco.MjvScene, overlay: Overlay, frame: int) -> None:
    """Append one frame of an overlay to the scene as decoration geoms."""
    import mujoco

    starts = overlay.starts[frame]
    ends = overlay.ends[frame] if overlay.ends is not None else starts
    rgba = np.array(overlay.rgba, dtype=np.float32)
    radius = overlay.width / 2
    geom_type = {
        "line": mujoco.mjtGeom.mjGEOM_CAPSULE,
        "arrow": mujoco.mjtGeom.mjGEOM_ARROW,
        "point": mujoco.mjtGeom.mjGEOM_SPHERE,
    }[overlay.kind]
    identity = np.eye(3).ravel()
    for start, end in zip(starts, ends):
        if not (np.isfinite(start).all() and np.isfinite(end).all()):
            continue
        if overlay.kind != "point" and np.linalg.norm(end - start) < SEGMENT_EPSILON_M:
            continue
        if scene.ngeom >= scene.maxgeom:
            return
        geom = scene.geoms[scene.ngeom]
        mujoco.mjv_initGeom(geom, geom_type, np.full(3, radius), start, identity, rgba)
        if overlay.kind == "arrow":
            mujoco.mjv_connector(geom, geom_type, radius, start, start + ARROW_STRETCH * (end - start))
        elif overlay.kind == "line":
            mujoco.mjv_connector(geom, geom_type, radius, start, end)
        _describe_decoration(geom, scene.ngeom)
        scene.ngeom += 1


def _describe_decoration(geom: mujoco.MjvGeom, index: int) -> None:
    """Set the fields `mjv_initGeom` leaves as the scene's memory held them, as `mjv_updateScene`
    sets them for a decoration: no object (`objtype`, `objid`), its own segmentation id, no
    camera distance yet (`mjr_render` measures the translucent ones). Left alone they held
    whatever an earlier scene of the process had left there, and renders of one clip in one
    process differed by a few pixels, now and then."""
    import mujoco

    geom.category = mujoco.mjtCatBit.mjCAT_DECOR
    geom.objtype = mujoco.mjtObj.mjOBJ_UNKNOWN
    geom.objid = -1
    geom.segid = index
    geom.camdist = 0.0
