"""Drawing a clip's frames: `ClipRenderer`, one display model and one OpenGL context for every frame.

Each frame sets the mocap poses from the clip, updates the kinematics, adds the overlays to the
scene and renders, so the same clip always gives the same pixels.
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterator, Sequence
from typing import TYPE_CHECKING

import numpy as np

from quadpipe.bodies import Look, dress
from quadpipe.clip.model import Clip
from quadpipe.core.errors import QuadpipeError
from quadpipe.render.camera import Camera, camera_views
from quadpipe.render.display import SUN_DIRECTION, SUN_DISTANCE_HP, VIDEO_MULTISAMPLES, display_spec
from quadpipe.render.gl import GLContext, open_gl_context
from quadpipe.render.overlays import Overlay, builtin_overlays, draw_overlay
from quadpipe.render.poses import check_clip, clip_scale, mocap_poses

if TYPE_CHECKING:
    import mujoco

DEFAULT_WIDTH, DEFAULT_HEIGHT = 640, 480
"""Frame size in pixels (each tile's size in a contact sheet)."""

MAX_SIZE_PX = 8192
"""Largest frame side accepted, pixels."""

FONT_SCALE = 100
"""MuJoCo font scale of the render context (quadpipe draws no MuJoCo text)."""


class ClipRenderer:
    """Draws the frames of one clip, reusing one display model and one OpenGL context.

    Use as a context manager (or call `close`): the OpenGL context is freed on exit.

    Args:
        clip: what to draw; it needs at least one frame and one animal.
        width, height: frame size in pixels.
        camera: how to frame the clip.
        overlays: decorations to draw; None: the built-in `DEFAULT_OVERLAYS`.
        multisamples: anti-aliasing samples per pixel.
        look: draw each animal's skinned body (`body`, built unless the clip carries one) or
            its bone shapes (`bones`); see `quadpipe.bodies`.

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
        look: Look = "body",
    ):
        import mujoco

        check_clip(clip)
        clip = dress(clip, look)
        check_size(width, height)
        self.clip, self.width, self.height = clip, width, height
        self.overlays = builtin_overlays(clip) if overlays is None else list(overlays)
        for overlay in self.overlays:
            overlay.check(clip.frame_count)
        self.views = camera_views(clip, camera)
        self._positions, self._rotations = mocap_poses(clip)
        self._sun_offset = -_unit(SUN_DIRECTION) * SUN_DISTANCE_HP * clip_scale(clip)
        self.model = display_spec(clip, width, height, multisamples).compile()
        self.data = mujoco.MjData(self.model)
        self._gl: GLContext | None = open_gl_context(width, height)
        self._mjr = mujoco.MjrContext(self.model, FONT_SCALE)
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, self._mjr)
        # every geom, every skin (each drawn as one scene geom) and every overlay item
        capacity = self.model.ngeom + self.model.nskin + sum(overlay.starts.shape[1] for overlay in self.overlays)
        self.scene = mujoco.MjvScene(self.model, maxgeom=capacity)
        self._option = mujoco.MjvOption()
        self._camera = mujoco.MjvCamera()
        self._camera.type = mujoco.mjtCamera.mjCAMERA_FREE
        self._viewport = mujoco.MjrRect(0, 0, width, height)
        self._pixels = np.zeros((height, width, 3), dtype=np.uint8)

    def __enter__(self) -> ClipRenderer:
        return self

    def __exit__(self, *_exc: object) -> None:
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
            draw_overlay(self.scene, overlay, frame)
        assert self._gl is not None, "render() after close()"
        self._gl.make_current()
        mujoco.mjr_render(self._viewport, self.scene, self._mjr)
        mujoco.mjr_readPixels(self._pixels, None, self._viewport, self._mjr)
        return np.flipud(self._pixels).copy()


def check_size(width: int, height: int) -> None:
    """Raise unless both sides are 1 to `MAX_SIZE_PX` pixels.

    Raises:
        QuadpipeError: code `bad-size`.
    """
    for name, value in (("width", width), ("height", height)):
        if not 1 <= value <= MAX_SIZE_PX:
            raise QuadpipeError.single(
                "bad-size", f"{name} {value} px is out of range", hint=f"give 1 to {MAX_SIZE_PX} pixels"
            )


def _unit(vector: Sequence[float]) -> np.ndarray:
    array = np.asarray(vector, dtype=float)
    return array / np.linalg.norm(array)


def _keep_planes_out_of_shadow_map(scene: mujoco.MjvScene) -> None:
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


def render_frames(
    clip: Clip,
    *,
    width: int = DEFAULT_WIDTH,
    height: int = DEFAULT_HEIGHT,
    fps: float | None = None,
    camera: Camera = Camera(),
    overlays: Sequence[Overlay] | None = None,
    look: Look = "body",
) -> Iterator[np.ndarray]:
    """The rendered frames of a clip, one (height, width, 3) uint8 array at a time.

    Args:
        clip: what to draw.
        width, height: frame size in pixels.
        fps: output frame rate; None: the clip's (every frame). Otherwise the nearest clip
            frame is shown at each output time.
        camera: how to frame the clip.
        overlays: decorations; None: the built-in `DEFAULT_OVERLAYS`.
        look: the animals' skinned bodies (`body`) or their bones (`bones`).
    """
    frames = output_frames(clip, fps)
    with ClipRenderer(clip, width=width, height=height, camera=camera, overlays=overlays, look=look) as renderer:
        for frame in frames:
            yield renderer.render(int(frame))


def render_fps(
    clip: Clip,
    frames: int = 60,
    *,
    width: int = DEFAULT_WIDTH,
    height: int = DEFAULT_HEIGHT,
    overlays: Sequence[Overlay] | None = None,
    look: Look = "body",
) -> float:
    """Frames per second of rendering (scene update, draw, read back), model building excluded.

    Renders `frames` frames, cycling through the clip, after one warm-up frame.
    """
    with ClipRenderer(clip, width=width, height=height, overlays=overlays, look=look) as renderer:
        renderer.render(0)
        start = time.perf_counter()
        for index in range(frames):
            renderer.render(index % clip.frame_count)
        return frames / (time.perf_counter() - start)
