"""Headless rendering (`quadpipe.render`): videos and contact sheets of a real simulated clip.

Pictures are checked against geometry: world points are projected with the frame's camera
(`CameraView.project`), and pixels that change when the animal or an overlay is taken away must
lie where the projection puts them. Small frames (160x120) and a short clip keep this fast.
"""

from __future__ import annotations

import copy
from pathlib import Path

import imageio_ffmpeg
import numpy as np
import pytest
from PIL import Image

from quadpipe import render
from quadpipe.anatomy.roles import LEGS, TOE_BONES
from quadpipe.clip.kinematics import rotate
from quadpipe.clip.model import Clip
from quadpipe.core.errors import QuadpipeError
from tests.clips import BLOW_UP_FRAME, blown_up_clip, dog_clip

WIDTH, HEIGHT = 160, 120
SHORT_FRAMES = 12
"""The short clip: the first 12 frames (0.37 s) of the pushed dog."""

CHANGED = 40
"""A pixel has changed when a channel differs by more than this (of 255)."""

BOX_MARGIN_PX = 6
"""Slack around a projected bounding box: shape radii and anti-aliasing."""

INSIDE_FRACTION = 0.97
"""Share of changed pixels that must lie where the geometry projects."""


def _head(clip: Clip, frames: int) -> Clip:
    """The first `frames` frames of a clip."""
    short = copy.deepcopy(clip)
    for track in short.animals:
        track.positions, track.rotations = track.positions[:frames], track.rotations[:frames]
        track.foot_contacts = track.foot_contacts[:frames]
    for prop in short.props:
        prop.positions, prop.rotations = prop.positions[:frames], prop.rotations[:frames]
    return short


@pytest.fixture(scope="module")
def short_clip() -> Clip:
    return _head(dog_clip(), SHORT_FRAMES)


def _without_animal(clip: Clip) -> Clip:
    """The same clip (same camera path) with the animal's shapes taken away."""
    bare = copy.deepcopy(clip)
    bare.animals[0].shapes = [[] for _ in bare.animals[0].shapes]
    return bare


def _changed(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(row, column) of the pixels that differ substantially between two pictures."""
    return np.argwhere(np.abs(a.astype(int) - b.astype(int)).max(axis=2) > CHANGED)


def _share_inside(pixels: np.ndarray, corners: np.ndarray, margin: float = BOX_MARGIN_PX) -> float:
    """Share of (row, column) pixels inside the box of projected (x, y) points, plus a margin."""
    low, high = corners.min(axis=0) - margin, corners.max(axis=0) + margin
    x, y = pixels[:, 1], pixels[:, 0]
    inside = (x >= low[0]) & (x <= high[0]) & (y >= low[1]) & (y <= high[1])
    return float(inside.mean())


def _animal_points(clip: Clip, frame: int) -> np.ndarray:
    """Every joint and bone end of the first animal at a frame, and their shadows on z = 0."""
    track = clip.animals[0]
    joints = track.positions[frame]
    ends = joints + rotate(track.rotations[frame], track.rest_end - track.rest_start)
    points = np.concatenate([joints, ends])
    sun = np.array(render.SUN_DIRECTION) / np.linalg.norm(render.SUN_DIRECTION)
    shadows = points - (points[:, 2:3] / sun[2]) * sun
    return np.concatenate([points, shadows])


def _read_mp4(path: Path) -> tuple[dict, list[np.ndarray]]:
    reader = imageio_ffmpeg.read_frames(str(path))
    meta = next(reader)
    width, height = meta["size"]
    return meta, [np.frombuffer(frame, np.uint8).reshape(height, width, 3) for frame in reader]


def _read_gif(path: Path) -> list[np.ndarray]:
    with Image.open(path) as image:
        frames = []
        for index in range(image.n_frames):
            image.seek(index)
            frames.append(np.asarray(image.convert("RGB")))
    return frames


# --- videos ---------------------------------------------------------------------------------


def test_mp4_has_every_frame_at_size_in_h264_yuv420p(short_clip, tmp_path):
    path = tmp_path / "run.mp4"
    render.render_clip(short_clip, path, width=WIDTH, height=HEIGHT, overlays=[])
    meta, frames = _read_mp4(path)
    assert len(frames) == SHORT_FRAMES
    assert meta["size"] == (WIDTH, HEIGHT)
    assert meta["codec"] == "h264" and meta["pix_fmt"].startswith("yuv420p")
    assert meta["fps"] == pytest.approx(short_clip.fps)


def test_mp4_at_a_lower_frame_rate_shows_the_nearest_frames(short_clip, tmp_path):
    path = tmp_path / "half.mp4"
    render.render_clip(short_clip, path, width=WIDTH, height=HEIGHT, fps=15, overlays=[])
    meta, frames = _read_mp4(path)
    assert len(frames) == len(render.output_frames(short_clip, 15)) == 6
    assert meta["fps"] == pytest.approx(15)
    np.testing.assert_array_equal(render.output_frames(short_clip, 15), [0, 2, 4, 6, 8, 10])


def test_gif_has_every_frame_and_is_byte_identical_when_rendered_again(short_clip, tmp_path):
    first, second = tmp_path / "a.gif", tmp_path / "b.gif"
    render.render_clip(short_clip, first, width=WIDTH, height=HEIGHT)
    render.render_clip(short_clip, second, width=WIDTH, height=HEIGHT)
    frames = _read_gif(first)
    assert len(frames) == SHORT_FRAMES
    assert frames[0].shape == (HEIGHT, WIDTH, 3)
    assert first.read_bytes() == second.read_bytes()
    with Image.open(first) as image:
        assert image.info["duration"] == pytest.approx(1000 / short_clip.fps, abs=10)


# --- the picture shows the clip -------------------------------------------------------------


@pytest.mark.parametrize("frame", [0, 5, SHORT_FRAMES - 1])
def test_animal_pixels_lie_where_its_bones_project(short_clip, frame):
    """The bones' shapes are drawn where the bones are (the body: tests/test_bodies.py)."""
    with render.ClipRenderer(short_clip, width=WIDTH, height=HEIGHT, overlays=[], look="bones") as renderer:
        with_animal = renderer.render(frame)
        view = renderer.views[frame]
    with render.ClipRenderer(
        _without_animal(short_clip), width=WIDTH, height=HEIGHT, overlays=[], look="bones"
    ) as renderer:
        without = renderer.render(frame)
    changed = _changed(with_animal, without)
    assert len(changed) > 0.01 * WIDTH * HEIGHT
    corners = view.project(_animal_points(short_clip, frame), WIDTH, HEIGHT)
    assert _share_inside(changed, corners) >= INSIDE_FRACTION


def test_tracking_camera_keeps_the_animal_near_the_centre_of_every_frame():
    clip = dog_clip()
    views = render.camera_views(clip)
    for frame in range(0, clip.frame_count, 10):
        centre = views[frame].project(clip.animals[0].positions[frame].mean(axis=0), WIDTH, HEIGHT)
        assert abs(centre[0] - WIDTH / 2) < 0.2 * WIDTH and abs(centre[1] - HEIGHT / 2) < 0.2 * HEIGHT


def test_tracking_does_not_lag_a_moving_animal_and_filters_its_jitter():
    clip = dog_clip()
    track = clip.animals[0]
    frames = clip.frame_count
    ramp = np.outer(np.arange(frames) / clip.fps, [2.0, 1.0, 0.0])
    jitter = np.outer((-1.0) ** np.arange(frames), [0.0, 0.0, 0.05])
    track.positions = track.rest_start[None] + (ramp + jitter)[:, None]
    targets = np.array([view.lookat for view in render.camera_views(clip)])
    expected = track.rest_start.mean(axis=0) + ramp
    np.testing.assert_allclose(targets[:, :2], expected[:, :2], atol=0.03 * track.pelvis_height)
    middle = slice(frames // 3, 2 * frames // 3)
    assert np.ptp(targets[middle, 2]) < 0.1 * np.ptp(jitter[:, 2])


def test_camera_distance_scales_with_the_animal():
    clip = dog_clip()
    giant = copy.deepcopy(clip)
    giant.animals[0].pelvis_height *= 10
    giant.animals[0].positions *= 10
    small, large = render.camera_views(clip)[0], render.camera_views(giant)[0]
    assert large.distance == pytest.approx(10 * small.distance)
    np.testing.assert_allclose(large.lookat, 10 * small.lookat)


def test_fixed_camera_sees_the_whole_path():
    clip = dog_clip()
    views = render.camera_views(clip, render.Camera(mode="fixed"))
    assert all(np.array_equal(view.lookat, views[0].lookat) for view in views)
    centres = clip.animals[0].positions.mean(axis=1)
    pixels = views[0].project(centres, WIDTH, HEIGHT)
    assert (pixels >= 0).all() and (pixels[:, 0] <= WIDTH).all() and (pixels[:, 1] <= HEIGHT).all()


def test_a_diverged_clip_freezes_on_its_last_good_pose():
    clip = blown_up_clip()
    clip.props = []
    camera = render.Camera(mode="fixed", lookat=(0.0, 0.0, 0.5))
    with render.ClipRenderer(clip, width=WIDTH, height=HEIGHT, camera=camera, overlays=[]) as renderer:
        last_good, later = renderer.render(BLOW_UP_FRAME - 1), renderer.render(BLOW_UP_FRAME + 10)
        earlier = renderer.render(0)
    np.testing.assert_array_equal(later, last_good)
    assert len(_changed(earlier, last_good)) > 0


def test_same_frame_gives_the_same_pixels(short_clip):
    with render.ClipRenderer(short_clip, width=WIDTH, height=HEIGHT) as renderer:
        first = renderer.render(7)
        renderer.render(2)
        again = renderer.render(7)
    with render.ClipRenderer(short_clip, width=WIDTH, height=HEIGHT) as renderer:
        fresh = renderer.render(7)
    np.testing.assert_array_equal(first, again)
    np.testing.assert_array_equal(first, fresh)


# --- overlays -------------------------------------------------------------------------------


def test_overlay_geoms_are_fully_described_so_that_renders_repeat(short_clip):
    """Every field of an overlay's scene geoms is set, none left as the scene's memory held it
    (renders of one clip in one process differed by a few pixels, now and then, while the
    object type and id were whatever an earlier scene had left there)."""
    import mujoco

    with render.ClipRenderer(short_clip, width=WIDTH, height=HEIGHT) as renderer:
        renderer.render(SHORT_FRAMES - 1)
        scene = renderer.scene
        geoms = [scene.geoms[index] for index in range(scene.ngeom)]
        decorations = [index for index, geom in enumerate(geoms) if geom.category == mujoco.mjtCatBit.mjCAT_DECOR]
        overlays = [index for index in decorations if geoms[index].type != mujoco.mjtGeom.mjGEOM_PLANE]
        assert len(overlays) > 2  # the trail's segments and the feet down
        for index in overlays:
            geom = geoms[index]
            assert (geom.objtype, geom.objid, geom.segid) == (mujoco.mjtObj.mjOBJ_UNKNOWN, -1, index)


def _beside_animal(view: render.CameraView, offset_hp: float, scale: float) -> np.ndarray:
    """A world point to the camera's right of the target, on the target's level."""
    return view.lookat + view.axes()[2] * offset_hp * scale


def _render_pair(clip: Clip, overlay: render.Overlay, frame: int) -> tuple[np.ndarray, np.ndarray, render.CameraView]:
    with render.ClipRenderer(clip, width=WIDTH, height=HEIGHT, overlays=[]) as renderer:
        plain = renderer.render(frame)
    with render.ClipRenderer(clip, width=WIDTH, height=HEIGHT, overlays=[overlay]) as renderer:
        drawn = renderer.render(frame)
        view = renderer.views[frame]
    return plain, drawn, view


def test_point_overlay_draws_a_sphere_where_its_point_projects(short_clip):
    frame, scale = 4, short_clip.animals[0].pelvis_height
    view = render.camera_views(short_clip)[frame]
    point = _beside_animal(view, 1.2, scale)
    starts = np.full((SHORT_FRAMES, 2, 3), np.nan)
    starts[frame, 0] = point
    overlay = render.Overlay("goal", "point", starts, None, (1.0, 0.0, 1.0, 1.0), 0.3 * scale)
    plain, drawn, view = _render_pair(short_clip, overlay, frame)
    changed = _changed(plain, drawn)
    centre = view.project(point, WIDTH, HEIGHT)
    assert len(changed) > 20
    np.testing.assert_allclose(changed[:, ::-1].mean(axis=0), centre, atol=2.0)


@pytest.mark.parametrize("kind", ["line", "arrow"])
def test_segment_overlays_draw_along_their_projected_segment(short_clip, kind):
    frame, scale = 6, short_clip.animals[0].pelvis_height
    view = render.camera_views(short_clip)[frame]
    start, end = _beside_animal(view, 0.8, scale), _beside_animal(view, 0.8, scale) + [0.0, 0.0, 1.2 * scale]
    starts = np.full((SHORT_FRAMES, 1, 3), np.nan)
    ends = np.full((SHORT_FRAMES, 1, 3), np.nan)
    starts[frame, 0], ends[frame, 0] = start, end
    overlay = render.Overlay("force", kind, starts, ends, (0.6, 0.2, 0.9, 1.0), 0.05 * scale)
    plain, drawn, view = _render_pair(short_clip, overlay, frame)
    changed = _changed(plain, drawn)[:, ::-1].astype(float)
    a, b = view.project(np.array([start, end]), WIDTH, HEIGHT)
    along = np.clip((changed - a) @ (b - a) / ((b - a) @ (b - a)), 0.0, 1.0)
    distance = np.linalg.norm(changed - (a + along[:, None] * (b - a)), axis=1)
    assert len(changed) > 20
    assert (distance <= 4.0).mean() >= INSIDE_FRACTION
    assert along.min() < 0.1 and along.max() > 0.85


def test_nan_overlay_rows_draw_nothing(short_clip):
    starts, ends = np.full((SHORT_FRAMES, 3, 3), np.nan), np.zeros((SHORT_FRAMES, 3, 3))
    blank = render.Overlay("none", "line", starts, ends, (1, 0, 0, 1), 0.05)
    plain, drawn, _ = _render_pair(short_clip, blank, 3)
    np.testing.assert_array_equal(plain, drawn)


def test_contact_overlay_marks_toe_tips_of_feet_down_only():
    clip = dog_clip()
    overlay = render.contact_overlay(clip)
    track = clip.animals[0]
    assert overlay.starts.shape == (clip.frame_count, 4, 3)
    down = track.foot_contacts.astype(bool)
    assert down.any() and (~down).any()
    assert np.isfinite(overlay.starts[down]).all() and np.isnan(overlay.starts[~down]).all()
    frame, leg = np.argwhere(down)[0]
    toe = track.roles.index(TOE_BONES[LEGS[leg]])
    tip = track.positions[frame, toe] + rotate(track.rotations[frame, toe], track.rest_end[toe] - track.rest_start[toe])
    np.testing.assert_allclose(overlay.starts[frame, leg], tip)
    assert tip[2] < 0.1 * track.pelvis_height


def test_trail_overlay_follows_the_pelvis_over_the_last_seconds():
    clip = dog_clip()
    overlay = render.trail_overlay(clip)
    pelvis = clip.animals[0].positions[:, 0]
    history = round(render.TRAIL_SECONDS * clip.fps)
    assert not np.isfinite(overlay.starts[0]).any()
    for frame in (1, 30, clip.frame_count - 1):
        drawn = np.isfinite(overlay.starts[frame, :, 0])
        assert drawn.sum() == min(frame, history)
        np.testing.assert_array_equal(overlay.starts[frame, drawn][0], pelvis[max(0, frame - history)])
        np.testing.assert_array_equal(overlay.ends[frame, drawn][-1], pelvis[frame])


def test_built_in_overlays_change_the_picture(short_clip):
    frame = SHORT_FRAMES - 1
    with render.ClipRenderer(short_clip, width=WIDTH, height=HEIGHT, overlays=[]) as renderer:
        plain = renderer.render(frame)
    with render.ClipRenderer(short_clip, width=WIDTH, height=HEIGHT) as renderer:
        decorated = renderer.render(frame)
    assert len(_changed(plain, decorated)) > 0


# --- contact sheet --------------------------------------------------------------------------


def test_contact_sheet_has_the_grid_size_and_a_different_stamped_picture_per_tile(short_clip, tmp_path):
    path = tmp_path / "sheet.png"
    render.render_clip(short_clip, path, width=WIDTH, height=HEIGHT, grid=(3, 2), overlays=[])
    sheet = np.asarray(Image.open(path).convert("RGB"))
    assert sheet.shape == (2 * HEIGHT, 3 * WIDTH, 3)
    frames = render.sheet_frames(short_clip, (3, 2))
    assert frames[0] == 0 and frames[-1] == SHORT_FRAMES - 1 and len(set(frames)) == 6
    tiles = [sheet[r * HEIGHT : (r + 1) * HEIGHT, c * WIDTH : (c + 1) * WIDTH] for r in range(2) for c in range(3)]
    for i in range(len(tiles)):
        for j in range(i + 1, len(tiles)):
            assert len(_changed(tiles[i], tiles[j])) > 0, (i, j)
    with render.ClipRenderer(
        short_clip, width=WIDTH, height=HEIGHT, overlays=[], multisamples=render.SHEET_MULTISAMPLES
    ) as renderer:
        unstamped = renderer.render(int(frames[4]))
    stamp = _changed(tiles[4], unstamped)
    assert len(stamp) > 0
    assert stamp[:, 0].max() < HEIGHT / 3 and stamp[:, 1].max() < WIDTH * 0.75


def test_contact_sheet_of_a_short_clip_has_one_tile_per_frame(short_clip, tmp_path):
    clip = _head(short_clip, 5)
    sheet = render.contact_sheet(clip, width=WIDTH, height=HEIGHT, overlays=[])
    assert sheet.shape == (2 * HEIGHT, 4 * WIDTH, 3)
    np.testing.assert_array_equal(render.sheet_frames(clip), [0, 1, 2, 3, 4])
    assert not sheet[HEIGHT:, WIDTH:].any()


def test_contact_sheet_png_is_byte_identical_when_rendered_again(short_clip, tmp_path):
    first, second = tmp_path / "a.png", tmp_path / "b.png"
    for path in (first, second):
        render.render_clip(short_clip, path, width=WIDTH, height=HEIGHT, grid=(2, 1))
    assert first.read_bytes() == second.read_bytes()


# --- errors ---------------------------------------------------------------------------------


def _code(excinfo: pytest.ExceptionInfo) -> str:
    return excinfo.value.issues[0].code


def test_unknown_suffix_lists_the_formats_and_writes_nothing(short_clip, tmp_path):
    with pytest.raises(QuadpipeError) as excinfo:
        render.render_clip(short_clip, tmp_path / "run.avi")
    assert _code(excinfo) == "unknown-format"
    assert all(suffix in excinfo.value.issues[0].hint for suffix in (".mp4", ".gif", ".png"))
    assert list(tmp_path.iterdir()) == []


def test_missing_folder_is_an_unwritable_output(short_clip, tmp_path):
    with pytest.raises(QuadpipeError) as excinfo:
        render.render_clip(short_clip, tmp_path / "nowhere" / "run.mp4")
    assert _code(excinfo) == "unwritable-output"
    assert list(tmp_path.iterdir()) == []


def test_a_failure_while_rendering_leaves_no_file(short_clip, tmp_path):
    wrong = render.Overlay("balance", "arrow", np.zeros((3, 1, 3)), np.zeros((3, 1, 3)), (1, 1, 0, 1), 0.01)
    for suffix in (".gif", ".png", ".mp4"):
        with pytest.raises(QuadpipeError) as excinfo:
            render.render_clip(short_clip, tmp_path / f"run{suffix}", width=WIDTH, height=HEIGHT, overlays=[wrong])
        assert _code(excinfo) == "bad-overlay"
        assert "balance" in str(excinfo.value)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    ("arguments", "code"),
    [
        ({"width": 161}, "bad-size"),
        ({"height": 0}, "bad-size"),
        ({"fps": 0}, "bad-fps"),
        ({"camera": render.Camera(mode="orbit")}, "bad-camera"),  # type: ignore[arg-type]
        ({"camera": render.Camera(distance_hp=0.0)}, "bad-camera"),
    ],
)
def test_bad_settings_are_refused_before_any_file_is_made(short_clip, tmp_path, arguments, code):
    with pytest.raises(QuadpipeError) as excinfo:
        render.render_clip(short_clip, tmp_path / "run.mp4", **{"width": WIDTH, "height": HEIGHT, **arguments})
    assert _code(excinfo) == code
    assert list(tmp_path.iterdir()) == []


def test_an_empty_grid_is_refused(short_clip, tmp_path):
    with pytest.raises(QuadpipeError) as excinfo:
        render.render_clip(short_clip, tmp_path / "sheet.png", grid=(0, 3))
    assert _code(excinfo) == "bad-grid"
    assert list(tmp_path.iterdir()) == []


def test_unknown_built_in_overlay_suggests_the_right_name(short_clip):
    with pytest.raises(QuadpipeError) as excinfo:
        render.builtin_overlays(short_clip, ["contact"])
    assert _code(excinfo) == "unknown-overlay"
    assert "contacts" in excinfo.value.issues[0].hint


def test_gl_backend_defaults_to_egl_and_refuses_unknown_ones(monkeypatch):
    monkeypatch.delenv("MUJOCO_GL", raising=False)
    assert render.gl_backend() == "egl"
    monkeypatch.setenv("MUJOCO_GL", "directx")
    with pytest.raises(QuadpipeError) as excinfo:
        render.gl_backend()
    assert _code(excinfo) == "unsupported-gl-backend"


def test_a_missing_opengl_library_is_reported_with_an_install_hint(short_clip, monkeypatch):
    def no_library(name):
        raise OSError(f"cannot load the library behind {name}")

    monkeypatch.setattr(render.gl.importlib, "import_module", no_library)
    with pytest.raises(QuadpipeError) as excinfo:
        render.ClipRenderer(short_clip, width=WIDTH, height=HEIGHT)
    assert _code(excinfo) == "no-headless-gl"
    assert "libegl1" in excinfo.value.issues[0].hint
