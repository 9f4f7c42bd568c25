"""Headless rendering of clips: MP4 and GIF videos, PNG contact sheets, through MuJoCo's renderer.

A clip is drawn without any physics: a *display model* is built from the clip alone (one mocap
body per animal bone and per prop, carrying that bone's shapes, plus the static terrain, a
checker floor, a sky and a sun casting shadows). Each frame sets the mocap poses from the clip,
updates the kinematics and renders; overlays (foot contacts, the pelvis trail, caller-supplied
lines, arrows and points) are added to the scene as decoration geoms. One display model and one
OpenGL context serve every frame, so the same clip always gives the same pixels.

OpenGL without a display: MuJoCo picks its OpenGL backend from the `MUJOCO_GL` environment
variable when `mujoco` is first imported. Importing this package sets `MUJOCO_GL` (to `egl`
unless the user chose one; `gl` is imported first, and no module here imports `mujoco` before
a function runs), and, so that it does not matter whether `mujoco` was imported first, opens
its own context of that backend instead of relying on `mujoco.Renderer`'s choice. `egl`
renders on the GPU where there is one and falls back to Mesa's llvmpipe on CPU; `osmesa`
(Debian `libosmesa6`) is CPU only.

The modules, in the order a file is made:

- `gl`: the OpenGL backend (`MUJOCO_GL`) and a context of it;
- `poses`: what a picture takes from the clip (its length unit, poses held through NaN);
- `camera`: `Camera` (how the clip is framed) and each frame's `CameraView`;
- `overlays`: `Overlay` layers and the built-in ones (foot contacts, pelvis trail, a directed clip's path);
- `display`: the display model (`display_spec`);
- `renderer`: `ClipRenderer`, which draws frames, and `render_fps`;
- `sheet`: contact sheets;
- `writers`: `render_clip` and its MP4, GIF and PNG writers, by suffix (`RENDER_FORMATS`).
"""

from __future__ import annotations

from quadpipe.render.camera import DEFAULT_VIEW, VIEWS, Camera, CameraView, camera_views, view_camera
from quadpipe.render.display import SHEET_MULTISAMPLES, SUN_DIRECTION, VIDEO_MULTISAMPLES, display_spec
from quadpipe.render.gl import GL_VARIABLE, gl_backend  # first: sets MUJOCO_GL
from quadpipe.render.overlays import (
    BUILTIN_OVERLAYS,
    DEFAULT_OVERLAYS,
    TRAIL_SECONDS,
    Overlay,
    builtin_overlays,
    contact_overlay,
    trail_overlay,
)
from quadpipe.render.renderer import (
    DEFAULT_HEIGHT,
    DEFAULT_WIDTH,
    ClipRenderer,
    output_frames,
    render_fps,
    render_frames,
)
from quadpipe.render.sheet import SHEET_GRID, contact_sheet, sheet_frames, stamp_time
from quadpipe.render.writers import RENDER_FORMATS, render_clip

__all__ = [
    "BUILTIN_OVERLAYS",
    "DEFAULT_HEIGHT",
    "DEFAULT_OVERLAYS",
    "DEFAULT_VIEW",
    "DEFAULT_WIDTH",
    "GL_VARIABLE",
    "RENDER_FORMATS",
    "SHEET_GRID",
    "SHEET_MULTISAMPLES",
    "SUN_DIRECTION",
    "TRAIL_SECONDS",
    "VIDEO_MULTISAMPLES",
    "VIEWS",
    "Camera",
    "CameraView",
    "ClipRenderer",
    "Overlay",
    "builtin_overlays",
    "camera_views",
    "contact_overlay",
    "contact_sheet",
    "display_spec",
    "gl_backend",
    "output_frames",
    "render_clip",
    "render_fps",
    "render_frames",
    "sheet_frames",
    "stamp_time",
    "trail_overlay",
    "view_camera",
]
