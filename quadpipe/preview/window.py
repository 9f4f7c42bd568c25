"""The preview window: open3d's GUI drawing a preview app model, keys bound to its actions.

A `gui.SceneWidget` shows the scenery of a `LivePreview` or `ReplayPreview`
(`quadpipe.preview.live`, `.replay`): every body as one mesh (capsules, boxes and spheres tessellated by
`quadpipe.clip.meshes`) moved each frame by its pose, the floor as a checkerboard, the
terrain, a sun casting shadows, a sky-blue background, and the overlays as coloured lines.
The camera follows the first animal (C switches to a free camera; the mouse orbits either
way), a text line shows time, clock and states, and errors show in red under it and on the
console. Everything the window does goes through the app model's named actions, so this
module stays thin: the geometry helpers here are plain numpy and tested headless, and
`SceneView` fills any `rendering.Open3DScene` (a window's, or an offscreen renderer's).

open3d is imported inside the functions that need it: importing this module is cheap.
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from quadpipe.clip.kinematics import to_matrix
from quadpipe.clip.meshes import TriangleMesh, merge, shape_mesh
from quadpipe.clip.model import Shape
from quadpipe.preview.display import check_display
from quadpipe.preview.scenery import OverlayLayer, Pose, Scenery

if TYPE_CHECKING:
    import open3d

    from quadpipe.preview.live import LivePreview
    from quadpipe.preview.replay import ReplayPreview

    Preview = LivePreview | ReplayPreview

KEY_BINDINGS: dict[str, str] = {
    "SPACE": "pause",
    "PERIOD": "step",
    "R": "reset",
    "M": "slow_motion",
    "B": "throw_ball",
    "X": "throw_box",
    "UP": "goal_forward",
    "DOWN": "goal_back",
    "LEFT": "goal_left",
    "RIGHT": "goal_right",
    **{
        name: f"state_{k}"
        for k, name in enumerate(("ONE", "TWO", "THREE", "FOUR", "FIVE", "SIX", "SEVEN", "EIGHT", "NINE"), start=1)
    },
    "F1": "toggle_segments",
    "F2": "toggle_balance",
    "F3": "toggle_forces",
    "F4": "toggle_contacts",
    "F5": "toggle_goal",
    "F6": "toggle_trail",
    "C": "follow_camera",
    "H": "help",
}
"""open3d `gui.KeyName` member -> action. Actions a mode lacks (throws in a replay) do nothing."""

WINDOW_ACTIONS: dict[str, str] = {
    "follow_camera": "camera follows the animal / free camera",
    "help": "print the keys on the console",
}
"""Actions the window handles itself (the others are the app model's)."""

WINDOW_SIZE = (1280, 800)
"""Default window size, pixels."""

FLOOR_TILE_HP = 1.0
"""Side of a floor checker tile, pelvis heights."""

FLOOR_DRAWN_HP = 40.0
"""Largest half side of the floor drawn, pelvis heights (MuJoCo's floor may be larger)."""

CHECKER_RGBA = ((0.32, 0.36, 0.40, 1.0), (0.24, 0.27, 0.30, 1.0))
"""The two floor tile colours (as `quadpipe.render`'s floor)."""

SKY_RGBA = (0.55, 0.7, 0.85, 1.0)
"""Background colour."""

SUN_DIRECTION = (0.3, 0.2, -1.0)
"""Direction the sunlight travels in (as `quadpipe.world.placement`'s sun)."""

SUN_INTENSITY = 75000.0
"""Sun illuminance, lux (open3d's default sun is 100000)."""

ARROW_HEAD_FRACTION = 0.25
ARROW_HEAD_MAX_HP = 0.15
"""An arrow's head is this fraction of its length, at most this many pelvis heights."""

ARROW_HEAD_ANGLE_DEG = 25.0
"""Angle between an arrow's shaft and each of the four lines of its head."""

POINT_SIZE_HP = 0.12
"""Size of the three-line cross drawn for a point overlay, pelvis heights."""

LINE_WIDTH_PX = 3.0
"""Overlay line width, pixels."""

FOLLOW_SMOOTHING_S = 0.3
"""Time constant with which the following camera catches up with the animal, seconds."""

CAMERA_START = {"azimuth_deg": -120.0, "elevation_deg": -20.0, "distance_hp": 4.5}
"""The first view: from the animal's front left, slightly above (as `quadpipe render`)."""

FIELD_OF_VIEW_DEG = 45.0
"""Vertical field of view, degrees."""

TICK_SLEEP_S = 0.004
"""Pause in each tick (open3d ticks as fast as it can; this leaves the CPU some rest)."""

BODY_PREFIX, OVERLAY_PREFIX, STATIC_NAME = "body:", "overlay:", "static"
"""Geometry names in the open3d scene."""


# --------------------------------------------------------------------------- geometry (numpy)


def checker_plane(shape: Shape, hp: float) -> TriangleMesh:
    """A plane shape as checker tiles of `FLOOR_TILE_HP`, at most `FLOOR_DRAWN_HP` each way, in the world.

    Each tile has its own four vertices, so that its colour does not blend into its neighbours'.
    """
    tile = FLOOR_TILE_HP * hp
    half = [min(s if s > 0 else math.inf, FLOOR_DRAWN_HP * hp) for s in shape.size[:2]]
    counts = [max(1, math.ceil(2 * h / tile)) for h in half]
    xs = np.linspace(-half[0], half[0], counts[0] + 1)
    ys = np.linspace(-half[1], half[1], counts[1] + 1)
    grid_i, grid_j = np.meshgrid(np.arange(counts[0]), np.arange(counts[1]), indexing="ij")
    i, j = grid_i.ravel(), grid_j.ravel()
    corners = np.stack(
        [
            np.stack([xs[i], ys[j]], axis=1),
            np.stack([xs[i + 1], ys[j]], axis=1),
            np.stack([xs[i + 1], ys[j + 1]], axis=1),
            np.stack([xs[i], ys[j + 1]], axis=1),
        ],
        axis=1,
    ).reshape(-1, 2)
    vertices = np.concatenate([corners, np.zeros((len(corners), 1))], axis=1)
    first = 4 * np.arange(len(i))[:, None]
    faces = np.concatenate([first + [0, 1, 2], first + [0, 2, 3]])
    colors = np.repeat(np.asarray(CHECKER_RGBA)[(i + j) % 2], 4, axis=0)
    normals = np.tile([0.0, 0.0, 1.0], (len(vertices), 1))
    return TriangleMesh(vertices, normals, colors, faces).transformed(shape.pos, shape.quat)


def static_mesh(shapes: Sequence[Shape], hp: float) -> TriangleMesh | None:
    """The world's fixed shapes as one mesh (planes as checkerboards), None if there are none."""
    meshes = [checker_plane(s, hp) if s.kind == "plane" else shape_mesh(s) for s in shapes]
    return merge(meshes) if meshes else None


def pose_matrices(pose: Pose) -> np.ndarray:
    """(B, 4, 4) world transforms of the bodies of a pose."""
    matrices = np.tile(np.eye(4), (len(pose.positions), 1, 1))
    if len(pose.positions):
        matrices[:, :3, :3] = to_matrix(pose.quaternions)
        matrices[:, :3, 3] = pose.positions
    return matrices


def overlay_lines(overlay: OverlayLayer, hp: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """An overlay layer as line segments: points (P, 3), index pairs (L, 2), colours (L, 3).

    A line is one segment; an arrow its shaft plus four head lines; a point a cross of three
    segments along the axes.
    """
    if overlay.kind == "point":
        return _crosses(overlay.starts, overlay.colors, POINT_SIZE_HP * hp / 2)
    starts, ends = overlay.starts, overlay.ends
    points, colors = [starts, ends], [overlay.colors]
    if overlay.kind == "arrow":
        heads, count = _arrow_heads(starts, ends, hp), len(starts)
        points.append(heads.reshape(-1, 3))
        colors.append(np.repeat(overlay.colors, 4, axis=0))
        shaft = np.stack([np.arange(count), np.arange(count) + count], axis=1)
        tips = np.repeat(np.arange(count) + count, 4)
        head = np.stack([tips, 2 * count + np.arange(4 * count)], axis=1)
        segments = np.concatenate([shaft, head])
    else:
        segments = np.stack([np.arange(len(starts)), np.arange(len(starts)) + len(starts)], axis=1)
    return np.concatenate(points), segments.reshape(-1, 2), np.concatenate(colors)[:, :3]


def _arrow_heads(starts: np.ndarray, ends: np.ndarray, hp: float) -> np.ndarray:
    """(K, 4, 3) back ends of each arrow's four head lines (their front ends are the tips)."""
    shaft = ends - starts
    length = np.linalg.norm(shaft, axis=1, keepdims=True)
    along = np.divide(shaft, length, out=np.zeros_like(shaft), where=length > 1e-12)
    helper = np.where(np.abs(along[:, 2:3]) < 0.9, [[0.0, 0.0, 1.0]], [[1.0, 0.0, 0.0]])
    side = np.cross(along, helper)
    side /= np.maximum(np.linalg.norm(side, axis=1, keepdims=True), 1e-12)
    other = np.cross(along, side)
    size = np.minimum(ARROW_HEAD_FRACTION * length, ARROW_HEAD_MAX_HP * hp)
    angle = math.radians(ARROW_HEAD_ANGLE_DEG)
    back = ends - along * size * math.cos(angle)
    spread = size * math.sin(angle)
    return np.stack([back + side * spread, back - side * spread, back + other * spread, back - other * spread], axis=1)


def _crosses(centres: np.ndarray, colors: np.ndarray, half: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    axes = np.eye(3) * half
    ends = np.concatenate([centres[:, None] - axes, centres[:, None] + axes], axis=1).reshape(-1, 3)
    count = len(centres)
    first = 6 * np.repeat(np.arange(count), 3) + np.tile(np.arange(3), count)
    return ends, np.stack([first, first + 3], axis=1), np.repeat(colors[:, :3], 3, axis=0)


# --------------------------------------------------------------------------- open3d scene


def o3d_mesh(mesh: TriangleMesh) -> open3d.geometry.TriangleMesh:
    """A quadpipe mesh as an open3d mesh with normals and vertex colours."""
    import open3d as o3d

    result = o3d.geometry.TriangleMesh(
        o3d.utility.Vector3dVector(mesh.vertices), o3d.utility.Vector3iVector(mesh.faces.astype(np.int32))
    )
    result.vertex_normals = o3d.utility.Vector3dVector(mesh.normals)
    result.vertex_colors = o3d.utility.Vector3dVector(mesh.colors[:, :3])
    return result


def o3d_lines(overlay: OverlayLayer, hp: float) -> open3d.geometry.LineSet:
    """An overlay layer as an open3d line set."""
    import open3d as o3d

    points, segments, colors = overlay_lines(overlay, hp)
    lines = o3d.geometry.LineSet(
        o3d.utility.Vector3dVector(points), o3d.utility.Vector2iVector(segments.astype(np.int32))
    )
    lines.colors = o3d.utility.Vector3dVector(colors)
    return lines


class SceneView:
    """Keeps an open3d scene showing a preview: bodies where the pose says, overlays redrawn.

    Args:
        scene: a `rendering.Open3DScene` (a `SceneWidget`'s or an `OffscreenRenderer`'s).
        preview: a `LivePreview` or `ReplayPreview`.
    """

    def __init__(self, scene: open3d.visualization.rendering.Open3DScene, preview: Preview):
        from open3d.visualization import rendering

        self.scene, self.preview = scene, preview
        self.lit = rendering.MaterialRecord()
        self.lit.shader = "defaultLit"
        self.line = rendering.MaterialRecord()
        self.line.shader = "unlitLine"
        self.line.line_width = LINE_WIDTH_PX
        self._version: int | None = None
        self._overlays: set[str] = set()
        sun = np.asarray(SUN_DIRECTION, dtype=np.float32)
        scene.set_background(np.asarray(SKY_RGBA, dtype=np.float32))
        scene.set_lighting(rendering.Open3DScene.LightingProfile.MED_SHADOWS, sun / np.linalg.norm(sun))
        scene.scene.set_sun_light(sun / np.linalg.norm(sun), np.ones(3, dtype=np.float32), SUN_INTENSITY)
        scene.scene.enable_sun_light(True)

    def build(self) -> None:
        """(Re)create every geometry from the preview's scenery."""
        scenery: Scenery = self.preview.scenery
        self.scene.clear_geometry()
        self._overlays.clear()
        floor = static_mesh(scenery.static, scenery.hp)
        if floor is not None:
            self.scene.add_geometry(STATIC_NAME, o3d_mesh(floor), self.lit)
            self.scene.scene.geometry_shadows(STATIC_NAME, False, True)  # a floor casting shadows darkens itself
        for body in scenery.bodies:
            self.scene.add_geometry(
                BODY_PREFIX + body.name, o3d_mesh(merge([shape_mesh(s) for s in body.shapes])), self.lit
            )
        self._version = self.preview.scenery_version

    def update(self) -> None:
        """Move the bodies to the current pose and redraw the overlays."""
        if self._version != self.preview.scenery_version:
            self.build()
        pose = self.preview.pose()
        for body, matrix, visible in zip(self.preview.scenery.bodies, pose_matrices(pose), pose.visible):
            name = BODY_PREFIX + body.name
            self.scene.show_geometry(name, bool(visible))
            if visible:
                self.scene.set_geometry_transform(name, matrix)
        self._draw_overlays()

    def _draw_overlays(self) -> None:
        for name in self._overlays:
            self.scene.remove_geometry(OVERLAY_PREFIX + name)
        self._overlays.clear()
        for overlay in self.preview.overlays():
            if len(overlay.starts):
                name = OVERLAY_PREFIX + overlay.name
                self.scene.add_geometry(name, o3d_lines(overlay, self.preview.scenery.hp), self.line)
                self.scene.scene.geometry_shadows(name, False, False)
                self._overlays.add(overlay.name)


class FollowCamera:
    """A camera target that trails the animal smoothly; the eye moves with it (keeping the user's orbit).

    Args:
        focus: where the animal is at the start.
        hp: the length unit, metres.
    """

    def __init__(self, focus: np.ndarray, hp: float):
        from quadpipe.render import CameraView

        self.following = True
        self.center = np.asarray(focus, dtype=float).copy()
        view = CameraView(
            self.center, CAMERA_START["distance_hp"] * hp, CAMERA_START["azimuth_deg"], CAMERA_START["elevation_deg"]
        )
        self.start_eye = view.position()

    def follow(self, focus: np.ndarray, eye: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """The new (center, eye) after `dt` seconds: the target moves toward `focus`, the eye by as much."""
        weight = 1.0 - math.exp(-max(dt, 0.0) / FOLLOW_SMOOTHING_S)
        shift = weight * (np.asarray(focus, dtype=float) - self.center)
        self.center = self.center + shift
        return self.center, np.asarray(eye, dtype=float) + shift


# --------------------------------------------------------------------------- window


def bound_actions(preview: Preview) -> dict[str, str]:
    """The key bindings that do something in this preview: key name -> action."""
    actions = preview.actions()
    return {key: action for key, action in KEY_BINDINGS.items() if action in actions or action in WINDOW_ACTIONS}


def help_text(preview: Preview) -> str:
    """One line per bound key: the key and what it does."""
    actions = preview.actions()
    lines = []
    for key, action in bound_actions(preview).items():
        what = WINDOW_ACTIONS.get(action) or actions[action][0]
        lines.append(f"  {key.lower():>8}  {what}")
    return "keys:\n" + "\n".join(lines) + "\n  mouse     orbit (left), pan (middle or ctrl), zoom (wheel)"


class PreviewWindow:
    """An open3d window over a preview app model.

    Args:
        preview: a `LivePreview` or `ReplayPreview`.
        title: the window's title.
        size: width and height, pixels.
    """

    def __init__(self, preview: Preview, title: str, size: tuple[int, int] = WINDOW_SIZE):
        from open3d.visualization import gui, rendering

        self.gui, self.preview = gui, preview
        self.window = gui.Application.instance.create_window(title, *size)
        self.widget = gui.SceneWidget()
        self.widget.scene = rendering.Open3DScene(self.window.renderer)
        self.status = gui.Label("")
        self.errors = gui.Label("")
        self.errors.text_color = gui.Color(1.0, 0.35, 0.3)
        for child in (self.widget, self.status, self.errors):
            self.window.add_child(child)
        self.view = SceneView(self.widget.scene, preview)
        self.view.update()
        self.camera = FollowCamera(preview.focus(), preview.scenery.hp)
        self._look(self.camera.center, self.camera.start_eye)
        self._keys = {int(getattr(gui.KeyName, key)): action for key, action in bound_actions(preview).items()}
        self._last = time.perf_counter()
        self.window.set_on_layout(self._layout)
        self.window.set_on_key(self._on_key)
        self.window.set_on_tick_event(self._on_tick)

    def _look(self, center: np.ndarray, eye: np.ndarray) -> None:
        self.widget.look_at(center.astype(np.float32), eye.astype(np.float32), np.array([0, 0, 1], dtype=np.float32))

    def _eye(self) -> np.ndarray:
        return np.asarray(self.widget.scene.camera.get_model_matrix(), dtype=float)[:3, 3]

    def _layout(self, context: open3d.visualization.gui.LayoutContext) -> None:
        frame = self.window.content_rect
        self.widget.frame = frame
        em = context.theme.font_size
        self.status.frame = self.gui.Rect(frame.x + em // 2, frame.y + em // 4, frame.width - em, 2 * em)
        self.errors.frame = self.gui.Rect(frame.x + em // 2, frame.y + 2 * em, frame.width - em, 12 * em)

    def _on_key(self, event: open3d.visualization.gui.KeyEvent) -> bool:
        action = self._keys.get(int(event.key))
        if action is None or event.type != self.gui.KeyEvent.Type.DOWN:
            return action is not None
        if action == "follow_camera":
            self.camera.following = not self.camera.following
        elif action == "help":
            print(help_text(self.preview), file=sys.stderr)
        else:
            self.preview.perform(action, self._eye())
        return True

    def _on_tick(self) -> bool:
        now = time.perf_counter()
        dt, self._last = now - self._last, now
        self.preview.advance(dt)
        for line in self.preview.pop_notices():
            print(line, file=sys.stderr)
        self.view.update()
        if self.camera.following:
            self._look(*self.camera.follow(self.preview.focus(), self._eye(), dt))
        self.status.text = self.preview.status_line() + ("" if self.camera.following else "  |  free camera")
        self.errors.text = self.preview.error or ""
        self.errors.visible = bool(self.preview.error)
        time.sleep(TICK_SLEEP_S)
        return True


def open_window(preview: Preview, title: str = "quadpipe preview", size: tuple[int, int] = WINDOW_SIZE) -> None:
    """Open a preview window and run it until it is closed.

    Raises:
        QuadpipeError: `no-display` when no window can be opened.
    """
    check_display()
    from open3d.visualization import gui

    application = gui.Application.instance
    application.initialize()
    PreviewWindow(preview, title, size)
    print(help_text(preview), file=sys.stderr)
    application.run()
