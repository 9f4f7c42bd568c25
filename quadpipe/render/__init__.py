"""Headless rendering of clips: MP4 and GIF videos, PNG contact sheets, through MuJoCo's renderer.

A clip is drawn without any physics: a *display model* is built from the clip alone (one mocap
body per animal bone and per prop, carrying that bone's shapes, plus the static terrain, a
checker floor, a sky and a sun casting shadows). Each frame sets the mocap poses from the clip,
updates the kinematics and renders; overlays (foot contacts, the pelvis trail, caller-supplied
lines, arrows and points) are added to the scene as decoration geoms. One display model and one
OpenGL context serve every frame, so the same clip always gives the same pixels.

OpenGL without a display: MuJoCo picks its OpenGL backend from the `MUJOCO_GL` environment
variable when `mujoco` is first imported. This module sets `MUJOCO_GL` (to `egl` unless the
user chose one) when it is imported, and, so that it does not matter whether `mujoco` was
imported first, opens its own context of that backend instead of relying on `mujoco.Renderer`'s
choice. `egl` renders on the GPU where there is one and falls back to Mesa's llvmpipe on CPU;
`osmesa` (Debian `libosmesa6`) is CPU only.
"""

from __future__ import annotations

import importlib
import math
import os
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Callable, Iterator, Literal, Sequence

import numpy as np

from quadpipe.anatomy import roles
from quadpipe.anatomy.roles import TOE_BONES
from quadpipe.core.atomic import atomic_path
from quadpipe.clip.model import Clip, Shape
from quadpipe.core.errors import QuadpipeError, did_you_mean
from quadpipe.clip.kinematics import rotate

if TYPE_CHECKING:
    import mujoco

GL_VARIABLE = "MUJOCO_GL"
"""The environment variable MuJoCo reads its OpenGL backend from."""

DEFAULT_GL_BACKEND = "egl"
"""Headless backend used when the user has not chosen one: GPU when present, else Mesa on CPU."""

GL_BACKENDS = ("egl", "osmesa", "glfw")
"""Backends quadpipe can open a context with (`glfw` needs a display)."""

DEFAULT_WIDTH, DEFAULT_HEIGHT = 640, 480
"""Frame size in pixels (each tile's size in a contact sheet)."""

MAX_SIZE_PX = 8192
"""Largest frame side accepted, pixels."""

SMOOTHING_PAD_TIME_CONSTANTS = 4.0
"""Length of the reflected padding at each end of a tracked path, in filter time constants."""

FOVY_DEG = 45.0
"""Vertical field of view of the camera, degrees."""

SHADOW_MAP_PX = 2048
"""Side of the sun's shadow map, pixels (MuJoCo's default 4096 costs 40 % more CPU a frame)."""

VIDEO_MULTISAMPLES, SHEET_MULTISAMPLES = 0, 4
"""Anti-aliasing samples per pixel: none for video (4 samples double the CPU time of a frame),
4 for contact sheets, which are few frames and meant for documents."""

SCENE_EXTENT_HP = 3.0
"""MuJoCo's scene extent (its unit for clipping planes and shadows), in pelvis heights."""

SHADOW_RADIUS_EXTENTS = 2.0
"""Radius around the camera target that the sun's shadows cover, in scene extents."""

SUN_DIRECTION = (0.3, 0.2, -1.0)
"""Direction the sunlight travels in (high, from behind the animal's right), as in `quadpipe.world.placement`."""

SUN_DISTANCE_HP = 10.0
"""How far up-sun from the camera target the sun sits, pelvis heights (for the shadow map)."""

SKY_TOP_RGB, SKY_HORIZON_RGB = (0.55, 0.7, 0.85), (0.1, 0.12, 0.15)
CHECKER_RGB = ((0.32, 0.36, 0.40), (0.24, 0.27, 0.30))
"""Sky gradient and floor checker colours, as in `quadpipe.world.placement`."""

CHECKER_SQUARE_HP = 0.5
"""Side of one floor checker square, in pelvis heights (so a rat and an elephant read alike)."""

HEADLIGHT_AMBIENT, HEADLIGHT_DIFFUSE, HEADLIGHT_SPECULAR = 0.25, 0.35, 0.1
"""The camera's headlight: enough fill to see the shadowed side of the animal."""

PLANE_GRID_M = 1.0
"""Spacing of a plane's rendering grid (MuJoCo subdivides planes for lighting), metres."""

FONT_SCALE = 100
"""MuJoCo font scale of the render context (quadpipe draws no MuJoCo text)."""

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

DEFAULT_OVERLAYS = ("contacts", "trail")
"""The built-in overlays drawn unless the caller says otherwise."""

SHEET_GRID = (4, 3)
"""Contact sheet tiles: columns, rows."""

STAMP_HEIGHT_FRACTION = 1 / 16
STAMP_MIN_PX = 10
STAMP_MARGIN_FRACTION = 0.3
STAMP_BACKGROUND = (0, 0, 0, 150)
STAMP_TEXT = (255, 255, 255, 255)
"""Time stamps on contact sheet tiles: font size (a fraction of the tile height, at least
`STAMP_MIN_PX`), margin around the text (a fraction of the font size), box and text colours."""

VIDEO_CRF = 18
VIDEO_PRESET = "medium"
VIDEO_TIMEOUT_S = 600.0
"""H.264 settings: constant rate factor (lower is better; 18 looks lossless), x264 speed
preset, and how long ffmpeg may take to finish the file, seconds."""

GIF_COLOURS = 256
"""Palette size of each GIF frame (octree, no dithering: 5x faster than Pillow's default and
half the file size, with only slight banding in the sky)."""


def gl_backend() -> str:
    """The OpenGL backend to render with: `MUJOCO_GL` if set, else `egl` (and set it).

    Raises:
        QuadpipeError: `MUJOCO_GL` names a backend quadpipe cannot render with.
    """
    backend = (os.environ.get(GL_VARIABLE) or DEFAULT_GL_BACKEND).strip().lower()
    if backend not in GL_BACKENDS:
        raise QuadpipeError.single(
            "unsupported-gl-backend",
            f"cannot render with {GL_VARIABLE}={backend!r}",
            hint=f"set {GL_VARIABLE} to one of {', '.join(GL_BACKENDS)}, or unset it ({DEFAULT_GL_BACKEND} is used)",
        )
    os.environ[GL_VARIABLE] = backend
    return backend


# Before anything imports mujoco where possible, so that `mujoco.Renderer` is headless too.
if GL_VARIABLE not in os.environ or not os.environ[GL_VARIABLE].strip():
    os.environ[GL_VARIABLE] = DEFAULT_GL_BACKEND


CAMERA_MODES = ("track", "fixed")


@dataclass(frozen=True)
class Camera:
    """How the camera frames the clip.

    Attributes:
        mode: `track` follows the first animal (the centroid of its joints, smoothed);
            `fixed` stays put.
        azimuth_deg: horizontal direction the camera looks in, degrees from +X towards +Y
            (MuJoCo's convention); -120 looks back from the animal's front-left: a side-on
            three-quarter view of an animal facing +X.
        elevation_deg: angle above the horizon of the viewing direction (negative: looks down).
        distance_hp: distance from the target, in the first animal's pelvis heights.
        smoothing_s: time constant of the tracking filter, seconds (0: no smoothing).
        lookat: fixed mode's target point (metres); None: the centre of the animal's path,
            with the distance raised if needed so that the whole path fits.
    """

    mode: Literal["track", "fixed"] = "track"
    azimuth_deg: float = -120.0
    elevation_deg: float = -20.0
    distance_hp: float = 4.5
    smoothing_s: float = 0.4
    lookat: tuple[float, float, float] | None = None


@dataclass(frozen=True, eq=False)
class CameraView:
    """The camera of one frame (a MuJoCo free camera), and where it puts world points on screen."""

    lookat: np.ndarray
    distance: float
    azimuth_deg: float
    elevation_deg: float

    def axes(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The camera's forward, up and right unit vectors in the world."""
        azimuth, elevation = math.radians(self.azimuth_deg), math.radians(self.elevation_deg)
        horizontal = np.array([math.cos(azimuth), math.sin(azimuth), 0.0])
        forward = math.cos(elevation) * horizontal + [0.0, 0.0, math.sin(elevation)]
        up = -math.sin(elevation) * horizontal + [0.0, 0.0, math.cos(elevation)]
        return forward, up, np.cross(forward, up)

    def position(self) -> np.ndarray:
        """Where the camera is, metres."""
        return self.lookat - self.distance * self.axes()[0]

    def project(self, points: np.ndarray, width: int, height: int) -> np.ndarray:
        """Pixel coordinates (x right, y down, origin top-left) of world points (..., 3).

        Points behind the camera come out as NaN.
        """
        forward, up, right = self.axes()
        offsets = np.asarray(points, dtype=float) - self.position()
        depth = offsets @ forward
        focal = (height / 2) / math.tan(math.radians(FOVY_DEG) / 2)
        with np.errstate(divide="ignore", invalid="ignore"):
            x = width / 2 + focal * (offsets @ right) / depth
            y = height / 2 - focal * (offsets @ up) / depth
        pixels = np.stack([x, y], axis=-1)
        pixels[depth <= 0] = np.nan
        return pixels


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
            tips = _finite_hold(track.positions[:, bone]) + rotate(
                _finite_hold(track.rotations[:, bone]), track.rest_end[bone] - track.rest_start[bone]
            )
            column = index * legs + leg_index
            down = track.foot_contacts[:, leg_index].astype(bool)
            starts[down, column] = tips[down]
    return Overlay("contacts", "point", starts, None, CONTACT_RGBA, CONTACT_SIZE_HP * _scale(clip))


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
            ends[frame, columns] = path[first + 1:frame + 1]
    return Overlay("trail", "line", starts, ends, TRAIL_RGBA, TRAIL_WIDTH_HP * _scale(clip))


BUILTIN_OVERLAYS: dict[str, Callable[[Clip], Overlay]] = {"contacts": contact_overlay, "trail": trail_overlay}
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


def _scale(clip: Clip) -> float:
    """The length unit of the picture: the first animal's pelvis height, metres."""
    return float(clip.animals[0].pelvis_height)


def _finite_hold(values: np.ndarray) -> np.ndarray:
    """Rows (frames) holding NaN or inf replaced by the last finite row before them.

    A diverged simulation leaves NaN poses from some frame on; the picture then freezes on the
    last good pose instead of failing. Leading bad rows take the first finite row.
    """
    values = np.array(values, dtype=float)
    good = np.isfinite(values.reshape(values.shape[0], -1)).all(axis=1)
    if good.all() or not good.any():
        return values
    source = np.where(good, np.arange(len(good)), 0)
    source = np.maximum.accumulate(source)
    source[: np.argmax(good)] = np.argmax(good)
    return values[source]


def camera_views(clip: Clip, camera: Camera = Camera()) -> list[CameraView]:
    """The camera of every clip frame.

    Raises:
        QuadpipeError: code `bad-camera` for an unknown mode or a distance that is not positive.

    The camera aims at the centroid of the first animal's joints (the pelvis alone would put
    the animal half a body off-centre). Tracking smooths that path with an exponential filter
    run forwards then backwards over the whole clip: it does not jitter with the gait, and,
    unlike a one-way filter, does not lag behind a running animal. Distances scale with the
    animal's pelvis height, so a rat and an elephant fill the frame alike.
    """
    _check_camera(camera)
    scale = _scale(clip)
    path = _finite_hold(clip.animals[0].positions).mean(axis=1)
    distance = camera.distance_hp * scale
    if camera.mode == "track":
        targets = _smooth_both_ways(path, camera.smoothing_s * clip.fps)
    else:
        target, distance = _fixed_target(path, camera, distance)
        targets = np.repeat(target[None], clip.frame_count, axis=0)
    return [CameraView(target, distance, camera.azimuth_deg, camera.elevation_deg) for target in targets]


def _check_camera(camera: Camera) -> None:
    problem = None
    if camera.mode not in CAMERA_MODES:
        problem = f"camera mode {camera.mode!r} is not one of {', '.join(CAMERA_MODES)}"
    elif not camera.distance_hp > 0:
        problem = f"camera distance {camera.distance_hp} pelvis heights is not positive"
    elif not camera.smoothing_s >= 0:
        problem = f"camera smoothing {camera.smoothing_s} s is negative"
    if problem:
        raise QuadpipeError.single("bad-camera", problem)


def _smooth_both_ways(path: np.ndarray, time_constant_frames: float) -> np.ndarray:
    """Zero-lag exponential smoothing of a (F, 3) path: forwards, then backwards.

    The path is first extended at both ends by its point reflection (as scipy's `filtfilt`
    pads), so that an animal moving steadily stays centred in the first and last frames too.
    """
    if time_constant_frames <= 0 or len(path) < 2:
        return path.copy()
    pad = min(len(path) - 1, math.ceil(SMOOTHING_PAD_TIME_CONSTANTS * time_constant_frames))
    smooth = np.concatenate([2 * path[0] - path[pad:0:-1], path, 2 * path[-1] - path[-2:-pad - 2:-1]])
    inertia = math.exp(-1.0 / time_constant_frames)  # weight of the previous smoothed value
    for frame in range(1, len(smooth)):
        smooth[frame] += inertia * (smooth[frame - 1] - smooth[frame])
    for frame in range(len(smooth) - 2, -1, -1):
        smooth[frame] += inertia * (smooth[frame + 1] - smooth[frame])
    return smooth[pad:pad + len(path)]


def _fixed_target(path: np.ndarray, camera: Camera, distance: float) -> tuple[np.ndarray, float]:
    """A fixed camera's target, and its distance: the animal's own, plus what the path's
    bounding sphere needs to fit the view."""
    if camera.lookat is not None:
        return np.array(camera.lookat, dtype=float), distance
    low, high = path.min(axis=0), path.max(axis=0)
    radius = float(np.linalg.norm(high - low)) / 2
    return (low + high) / 2, distance + radius / math.sin(math.radians(FOVY_DEG) / 2)


def output_frames(clip: Clip, fps: float | None = None) -> np.ndarray:
    """The clip frame shown at each output frame: all of them, or the nearest at `fps`.

    Raises:
        QuadpipeError: code `bad-fps` for a frame rate that is not positive.
    """
    if fps is None or fps == clip.fps:
        return np.arange(clip.frame_count)
    if not fps > 0:
        raise QuadpipeError.single(
            "bad-fps", f"frame rate {fps} is not positive", hint="give frames per second, e.g. 30"
        )
    count = math.floor(clip.duration * fps + 1e-9) + 1
    return np.minimum(np.round(np.arange(count) / fps * clip.fps).astype(int), clip.frame_count - 1)


def display_spec(clip: Clip, width: int, height: int, multisamples: int = VIDEO_MULTISAMPLES) -> "mujoco.MjSpec":
    """A physics-free MuJoCo model that shows the clip: mocap bodies, terrain, floor, sky, sun.

    Bodies, in mocap order: every bone of every animal (`<animal>/<role>`), every prop
    (`prop/<name>`), then the sun (`sun`), whose directional light follows the camera target
    so that its shadow map covers what the camera sees.
    """
    import mujoco

    scale = _scale(clip)
    spec = mujoco.MjSpec()
    spec.modelname = "display"
    spec.compiler.degree = False
    _set_visual(spec, clip, width, height, multisamples)
    spec.add_texture(
        name="sky", type=mujoco.mjtTexture.mjTEXTURE_SKYBOX, builtin=mujoco.mjtBuiltin.mjBUILTIN_GRADIENT,
        rgb1=list(SKY_TOP_RGB), rgb2=list(SKY_HORIZON_RGB), width=256, height=256,
    )
    spec.add_texture(
        name="checker", type=mujoco.mjtTexture.mjTEXTURE_2D, builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER,
        rgb1=list(CHECKER_RGB[0]), rgb2=list(CHECKER_RGB[1]), width=256, height=256,
    )
    repeat = 1.0 / (2 * CHECKER_SQUARE_HP * scale)
    spec.add_material(name="checker", textures=["", "checker"], texrepeat=[repeat, repeat], texuniform=True)
    for track in clip.animals:
        for role, shapes in zip(track.roles, track.shapes):
            _add_mocap_body(spec, f"{track.name}/{role}", shapes)
    for prop in clip.props:
        _add_mocap_body(spec, f"prop/{prop.name}", [prop.shape])
    for shape in clip.terrain:
        _add_geom(spec.worldbody, shape, material="checker" if shape.kind == "plane" else None)
    sun = spec.worldbody.add_body(name="sun", mocap=True)
    sun.add_light(
        name="sun", type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL, dir=list(SUN_DIRECTION),
        diffuse=[0.8, 0.8, 0.8], castshadow=True,
    )
    return spec


def _set_visual(spec: "mujoco.MjSpec", clip: Clip, width: int, height: int, multisamples: int) -> None:
    """Buffer size, shadows, anti-aliasing, clipping planes and headlight of the display model."""
    scale = _scale(clip)
    visual = spec.visual
    visual.global_.offwidth, visual.global_.offheight = width, height
    visual.global_.fovy = FOVY_DEG
    visual.quality.shadowsize = SHADOW_MAP_PX
    visual.quality.offsamples = multisamples
    visual.map.shadowclip = SHADOW_RADIUS_EXTENTS
    visual.headlight.ambient = [HEADLIGHT_AMBIENT] * 3
    visual.headlight.diffuse = [HEADLIGHT_DIFFUSE] * 3
    visual.headlight.specular = [HEADLIGHT_SPECULAR] * 3
    spec.stat.extent = SCENE_EXTENT_HP * scale
    spec.stat.center = list(clip.animals[0].rest_start[0])


def _add_mocap_body(spec: "mujoco.MjSpec", name: str, shapes: Sequence[Shape]) -> None:
    body = spec.worldbody.add_body(name=name, mocap=True)
    for shape in shapes:
        _add_geom(body, shape)


def _add_geom(body: "mujoco.MjsBody", shape: Shape, material: str | None = None) -> None:
    """A shape as a display-only geom (it collides with nothing)."""
    import mujoco

    kinds = {
        "capsule": mujoco.mjtGeom.mjGEOM_CAPSULE, "box": mujoco.mjtGeom.mjGEOM_BOX,
        "sphere": mujoco.mjtGeom.mjGEOM_SPHERE, "plane": mujoco.mjtGeom.mjGEOM_PLANE,
    }
    size = list(shape.size) + [0.0] * (3 - len(shape.size))
    if shape.kind == "plane":
        size[2] = PLANE_GRID_M
    geom = body.add_geom(
        type=kinds[shape.kind], size=size, pos=list(shape.pos), quat=list(shape.quat),
        rgba=list(shape.rgba), contype=0, conaffinity=0,
    )
    if material is not None:
        geom.material = material
        geom.rgba = [1.0, 1.0, 1.0, 1.0]


class ClipRenderer:
    """Draws the frames of one clip, reusing one display model and one OpenGL context.

    Use as a context manager (or call `close`): the OpenGL context is freed on exit.

    Args:
        clip: what to draw; it needs at least one frame and one animal.
        width, height: frame size in pixels.
        camera: how to frame the clip.
        overlays: decorations to draw; None: the built-in `DEFAULT_OVERLAYS`.
        multisamples: anti-aliasing samples per pixel.

    Raises:
        QuadpipeError: `empty-clip`, `no-animal`, `no-finite-frame`, `bad-size`,
            `bad-overlay`, `bad-camera`, or `no-headless-gl` when no OpenGL context can be
            opened.
    """

    def __init__(
        self,
        clip: Clip,
        *,
        width: int = DEFAULT_WIDTH,
        height: int = DEFAULT_HEIGHT,
        camera: Camera = Camera(),
        overlays: Sequence[Overlay] | None = None,
        multisamples: int = VIDEO_MULTISAMPLES,
    ):
        import mujoco

        _check_clip(clip)
        _check_size(width, height)
        self.clip, self.width, self.height = clip, width, height
        self.overlays = builtin_overlays(clip) if overlays is None else list(overlays)
        for overlay in self.overlays:
            overlay.check(clip.frame_count)
        self.views = camera_views(clip, camera)
        self._positions, self._rotations = _mocap_poses(clip)
        self._sun_offset = -_unit(SUN_DIRECTION) * SUN_DISTANCE_HP * _scale(clip)
        self.model = display_spec(clip, width, height, multisamples).compile()
        self.data = mujoco.MjData(self.model)
        self._gl = _open_gl_context(width, height)
        self._mjr = mujoco.MjrContext(self.model, FONT_SCALE)
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, self._mjr)
        capacity = self.model.ngeom + sum(overlay.starts.shape[1] for overlay in self.overlays)
        self.scene = mujoco.MjvScene(self.model, maxgeom=capacity)
        self._option = mujoco.MjvOption()
        self._camera = mujoco.MjvCamera()
        self._camera.type = mujoco.mjtCamera.mjCAMERA_FREE
        self._viewport = mujoco.MjrRect(0, 0, width, height)
        self._pixels = np.zeros((height, width, 3), dtype=np.uint8)

    def __enter__(self) -> "ClipRenderer":
        return self

    def __exit__(self, *_exc) -> None:
        self.close()

    def close(self) -> None:
        """Free the OpenGL resources (safe to call twice)."""
        if self._gl is not None:
            self._gl.make_current()
            self._mjr.free()
            self._gl.free()
            self._gl = None

    def render(self, frame: int) -> np.ndarray:
        """The picture of clip frame `frame`: (height, width, 3) uint8 RGB, top row first."""
        import mujoco

        view = self.views[frame]
        self.data.mocap_pos[:-1] = self._positions[frame]
        self.data.mocap_quat[:-1] = self._rotations[frame]
        self.data.mocap_pos[-1] = view.lookat + self._sun_offset
        mujoco.mj_kinematics(self.model, self.data)
        mujoco.mj_camlight(self.model, self.data)
        self._camera.lookat[:] = view.lookat
        self._camera.distance = view.distance
        self._camera.azimuth = view.azimuth_deg
        self._camera.elevation = view.elevation_deg
        mujoco.mjv_updateScene(
            self.model, self.data, self._option, None, self._camera, mujoco.mjtCatBit.mjCAT_ALL, self.scene
        )
        _keep_planes_out_of_shadow_map(self.scene)
        for overlay in self.overlays:
            _draw_overlay(self.scene, overlay, frame)
        self._gl.make_current()
        mujoco.mjr_render(self._viewport, self.scene, self._mjr)
        mujoco.mjr_readPixels(self._pixels, None, self._viewport, self._mjr)
        return np.flipud(self._pixels).copy()


def _check_clip(clip: Clip) -> None:
    if clip.frame_count == 0:
        raise QuadpipeError.single("empty-clip", "the clip has no frames, there is nothing to render")
    if not clip.animals:
        raise QuadpipeError.single(
            "no-animal", "the clip has no animal: the camera follows and is scaled by the first animal"
        )
    if not np.isfinite(clip.animals[0].positions).all(axis=(1, 2)).any():
        raise QuadpipeError.single(
            "no-finite-frame", f"animal {clip.animals[0].name!r} has no frame with a finite pose: nothing to show",
            hint="the simulation diverged at once; check the clip's metadata status",
        )


def _check_size(width: int, height: int) -> None:
    for name, value in (("width", width), ("height", height)):
        if not 1 <= value <= MAX_SIZE_PX:
            raise QuadpipeError.single(
                "bad-size", f"{name} {value} px is out of range", hint=f"give 1 to {MAX_SIZE_PX} pixels"
            )


def _unit(vector: Sequence[float]) -> np.ndarray:
    vector = np.asarray(vector, dtype=float)
    return vector / np.linalg.norm(vector)


def _mocap_poses(clip: Clip) -> tuple[np.ndarray, np.ndarray]:
    """(F, M, 3) positions and (F, M, 4) orientations of the display model's bone and prop bodies.

    Each track holds its last finite pose through frames where it has none.
    """
    positions = [track.positions for track in clip.animals] + [prop.positions[:, None] for prop in clip.props]
    rotations = [track.rotations for track in clip.animals] + [prop.rotations[:, None] for prop in clip.props]
    return (
        np.concatenate([_finite_hold(p) for p in positions], axis=1),
        np.concatenate([_finite_hold(q) for q in rotations], axis=1),
    )


def _open_gl_context(width: int, height: int):
    """An OpenGL context of the chosen backend, made current.

    Raises:
        QuadpipeError: code `no-headless-gl` when the backend's libraries are missing or
            refuse to start (MuJoCo's modules raise assorted exception types for this).
    """
    backend = gl_backend()
    try:
        context = importlib.import_module(f"mujoco.{backend}").GLContext(width, height)
        context.make_current()
    except Exception as exc:  # noqa: BLE001 - the system's OpenGL, not quadpipe, failed
        raise QuadpipeError.single(
            "no-headless-gl",
            f"cannot open an OpenGL context with {GL_VARIABLE}={backend}: {type(exc).__name__}: {exc}",
            hint="on Debian install libegl1 (for egl) or libosmesa6 and set MUJOCO_GL=osmesa; see docs/render.md",
        ) from exc
    return context


def _keep_planes_out_of_shadow_map(scene: "mujoco.MjvScene") -> None:
    """Mark the scene's planes as decoration, which MuJoCo leaves out of the shadow map.

    A plane shadows nothing above it, and MuJoCo's shadow lookup is off by up to a shadow-map
    texel near the edges of the sun's shadow box (its viewport leaves a one-texel border that
    the texture matrix ignores), so under a slanting sun the floor speckles itself with shadow
    in one corner of the box. Planes still receive the animals' shadows.
    """
    import mujoco

    for index in range(scene.ngeom):
        geom = scene.geoms[index]
        if geom.type == mujoco.mjtGeom.mjGEOM_PLANE:
            geom.category = mujoco.mjtCatBit.mjCAT_DECOR


def _draw_overlay(scene: "mujoco.MjvScene", overlay: Overlay, frame: int) -> None:
    """Append one frame of an overlay to the scene as decoration geoms."""
    import mujoco

    starts = overlay.starts[frame]
    ends = overlay.ends[frame] if overlay.ends is not None else starts
    rgba = np.array(overlay.rgba, dtype=np.float32)
    radius = overlay.width / 2
    geom_type = {
        "line": mujoco.mjtGeom.mjGEOM_CAPSULE, "arrow": mujoco.mjtGeom.mjGEOM_ARROW,
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
        geom.category = mujoco.mjtCatBit.mjCAT_DECOR
        scene.ngeom += 1


def render_frames(
    clip: Clip,
    *,
    width: int = DEFAULT_WIDTH,
    height: int = DEFAULT_HEIGHT,
    fps: float | None = None,
    camera: Camera = Camera(),
    overlays: Sequence[Overlay] | None = None,
) -> Iterator[np.ndarray]:
    """The rendered frames of a clip, one (height, width, 3) uint8 array at a time.

    Args:
        clip: what to draw.
        width, height: frame size in pixels.
        fps: output frame rate; None: the clip's (every frame). Otherwise the nearest clip
            frame is shown at each output time.
        camera: how to frame the clip.
        overlays: decorations; None: the built-in `DEFAULT_OVERLAYS`.
    """
    frames = output_frames(clip, fps)
    with ClipRenderer(clip, width=width, height=height, camera=camera, overlays=overlays) as renderer:
        for frame in frames:
            yield renderer.render(int(frame))


def render_clip(
    clip: Clip,
    output_path: str | Path,
    *,
    width: int = DEFAULT_WIDTH,
    height: int = DEFAULT_HEIGHT,
    fps: float | None = None,
    camera: Camera = Camera(),
    overlays: Sequence[Overlay] | None = None,
    grid: tuple[int, int] = SHEET_GRID,
) -> None:
    """Render a clip to a video (`.mp4`, `.gif`) or a contact sheet (`.png`), atomically.

    Args:
        clip: what to draw.
        output_path: the file; its suffix picks the format (see `FORMATS`).
        width, height: frame size in pixels (a contact sheet's tile size; H.264 needs both even).
        fps: video frame rate; None: the clip's.
        camera: how to frame the clip.
        overlays: decorations; None: the built-in `DEFAULT_OVERLAYS` (pass [] for none).
        grid: contact sheet columns and rows.

    Raises:
        QuadpipeError: `unknown-format`, `unwritable-output`, `bad-size`, `bad-fps`,
            `bad-grid`, `bad-overlay`, `bad-camera`, `empty-clip`, `no-animal`,
            `no-finite-frame`, `no-headless-gl`.
    """
    path = Path(output_path)
    suffix = path.suffix.lower()
    if suffix not in FORMATS:
        raise QuadpipeError.single(
            "unknown-format",
            f"cannot render to {path.name!r}: unknown suffix {path.suffix or '(none)'!r}",
            file=str(path),
            hint=f"supported: {', '.join(f'{s} ({d})' for s, (d, _) in FORMATS.items())}",
        )
    writer = FORMATS[suffix][1]
    options = _RenderOptions(width, height, fps, camera, overlays, grid)
    options.check(clip, suffix)
    with atomic_path(path, suffix=suffix) as temporary:
        writer(clip, temporary, options)
        os.replace(temporary, path)


@dataclass(frozen=True)
class _RenderOptions:
    """render_clip's settings, handed to the format writers."""

    width: int
    height: int
    fps: float | None
    camera: Camera
    overlays: Sequence[Overlay] | None
    grid: tuple[int, int]

    def check(self, clip: Clip, suffix: str) -> None:
        """Reject settings the format cannot take, before any file is made."""
        _check_clip(clip)
        _check_size(self.width, self.height)
        output_frames(clip, self.fps)
        _check_camera(self.camera)
        for overlay in self.overlays or ():
            overlay.check(clip.frame_count)
        if suffix == ".mp4" and (self.width % 2 or self.height % 2):
            raise QuadpipeError.single(
                "bad-size", f"H.264 video needs an even width and height, not {self.width}x{self.height}",
                hint="give even sizes, e.g. 640x480",
            )
        if suffix == ".png":
            _check_grid(self.grid)

    def frames(self, clip: Clip) -> Iterator[np.ndarray]:
        """The rendered output frames."""
        return render_frames(
            clip, width=self.width, height=self.height, fps=self.fps, camera=self.camera, overlays=self.overlays
        )

    def frame_rate(self, clip: Clip) -> float:
        """Frames per second of the output."""
        return float(self.fps or clip.fps)


def _write_mp4(clip: Clip, path: Path, options: _RenderOptions) -> None:
    """H.264 video (yuv420p, so every player opens it)."""
    import imageio_ffmpeg

    writer = imageio_ffmpeg.write_frames(
        str(path), (options.width, options.height), fps=options.frame_rate(clip), codec="libx264",
        pix_fmt_out="yuv420p", quality=None, macro_block_size=2, ffmpeg_log_level="error",
        ffmpeg_timeout=VIDEO_TIMEOUT_S,
        output_params=["-crf", str(VIDEO_CRF), "-preset", VIDEO_PRESET, "-movflags", "+faststart"],
    )
    writer.send(None)
    try:
        for frame in options.frames(clip):
            writer.send(np.ascontiguousarray(frame))
    finally:
        writer.close()


def _write_gif(clip: Clip, path: Path, options: _RenderOptions) -> None:
    """Animated GIF, looping."""
    from PIL import Image

    frames = (
        Image.fromarray(frame).quantize(GIF_COLOURS, method=Image.Quantize.FASTOCTREE, dither=Image.Dither.NONE)
        for frame in options.frames(clip)
    )
    first = next(frames)
    delay_ms = 1000.0 / options.frame_rate(clip)
    first.save(path, format="GIF", save_all=True, append_images=frames, duration=delay_ms, loop=0)


def _write_sheet(clip: Clip, path: Path, options: _RenderOptions) -> None:
    """Contact sheet: a grid of evenly spaced frames, each stamped with its time."""
    from PIL import Image

    sheet = contact_sheet(
        clip, width=options.width, height=options.height, camera=options.camera, overlays=options.overlays,
        grid=options.grid,
    )
    Image.fromarray(sheet).save(path, format="PNG")


def _check_grid(grid: tuple[int, int]) -> None:
    if len(grid) != 2 or min(grid) < 1:
        raise QuadpipeError.single(
            "bad-grid", f"contact sheet grid {tuple(grid)} needs at least 1 column and 1 row", hint="e.g. 4x3"
        )


def sheet_frames(clip: Clip, grid: tuple[int, int] = SHEET_GRID) -> np.ndarray:
    """The clip frames a contact sheet shows: evenly spaced from the first to the last."""
    count = min(grid[0] * grid[1], clip.frame_count)
    return np.round(np.linspace(0, clip.frame_count - 1, count)).astype(int)


def contact_sheet(
    clip: Clip,
    *,
    width: int = DEFAULT_WIDTH,
    height: int = DEFAULT_HEIGHT,
    camera: Camera = Camera(),
    overlays: Sequence[Overlay] | None = None,
    grid: tuple[int, int] = SHEET_GRID,
) -> np.ndarray:
    """A grid of evenly spaced frames, row by row, each stamped `t = 1.23 s`, as an RGB array.

    The sheet has `min(columns, tiles)` columns of `width` pixels and as many rows of `height`
    pixels as the tiles need (fewer tiles than the grid holds when the clip is that short).

    Raises:
        QuadpipeError: `bad-grid`, and those of `ClipRenderer`.
    """
    _check_grid(grid)
    frames = sheet_frames(clip, grid)
    columns = min(grid[0], len(frames))
    rows = math.ceil(len(frames) / columns)
    sheet = np.zeros((rows * height, columns * width, 3), dtype=np.uint8)
    with ClipRenderer(
        clip, width=width, height=height, camera=camera, overlays=overlays, multisamples=SHEET_MULTISAMPLES
    ) as renderer:
        for tile, frame in enumerate(frames):
            row, column = divmod(tile, columns)
            picture = stamp_time(renderer.render(int(frame)), frame / clip.fps)
            sheet[row * height:(row + 1) * height, column * width:(column + 1) * width] = picture
    return sheet


def stamp_time(picture: np.ndarray, seconds: float) -> np.ndarray:
    """A copy of an RGB picture with `t = 1.23 s` written in its top-left corner."""
    from PIL import Image, ImageDraw, ImageFont

    height = picture.shape[0]
    size = max(STAMP_MIN_PX, round(height * STAMP_HEIGHT_FRACTION))
    font = ImageFont.load_default(size=size)
    image = Image.fromarray(picture).convert("RGBA")
    layer = Image.new("RGBA", image.size, (0, 0, 0, 0))
    draw = ImageDraw.Draw(layer)
    margin = round(size * STAMP_MARGIN_FRACTION)
    text = f"t = {seconds:.2f} s"
    left, top, right, bottom = draw.textbbox((2 * margin, 2 * margin), text, font=font)
    draw.rectangle((left - margin, top - margin, right + margin, bottom + margin), fill=STAMP_BACKGROUND)
    draw.text((2 * margin, 2 * margin), text, font=font, fill=STAMP_TEXT)
    return np.asarray(Image.alpha_composite(image, layer).convert("RGB"))


def render_fps(
    clip: Clip, frames: int = 60, *, width: int = DEFAULT_WIDTH, height: int = DEFAULT_HEIGHT,
    overlays: Sequence[Overlay] | None = None,
) -> float:
    """Frames per second of rendering (scene update, draw, read back), model building excluded.

    Renders `frames` frames, cycling through the clip, after one warm-up frame.
    """
    with ClipRenderer(clip, width=width, height=height, overlays=overlays) as renderer:
        renderer.render(0)
        start = time.perf_counter()
        for index in range(frames):
            renderer.render(index % clip.frame_count)
        return frames / (time.perf_counter() - start)


FORMATS: dict[str, tuple[str, Callable[[Clip, Path, _RenderOptions], None]]] = {
    ".mp4": ("H.264 video", _write_mp4),
    ".gif": ("animated GIF", _write_gif),
    ".png": ("contact sheet", _write_sheet),
}
"""What `render_clip` writes, by file suffix: description and writer."""
