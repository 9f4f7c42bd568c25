"""Named camera views (`quadpipe render --view`): each looks at the animal from where it says.

The pushed dog of `tests.clips` faces +x. Its views are checked against geometry: where the
camera stands relative to the animal, and where the pelvis and the head project on screen.
"""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from quadpipe import render
from quadpipe.anatomy.roles import ROLES
from quadpipe.cli.media import View
from quadpipe.core.errors import QuadpipeError
from quadpipe.exporters.npz import export_npz
from tests.clips import dog_clip
from tests.conftest import invoke_cli

WIDTH, HEIGHT = 160, 120
FRAME = 0
"""The first frame: the dog stands facing +x (it is pushed about later)."""

SIDE_SHARE = 0.8
"""In a view from one side, at least this share of the camera's offset from the animal lies
along that side's direction."""


def _camera_and_points(view: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The camera's offset from the animal's centre, its unit direction, and where the
    pelvis and the head project (pixels), at `FRAME`."""
    clip = dog_clip()
    frame_view = render.camera_views(clip, render.view_camera(view))[FRAME]
    joints = clip.animals[0].positions[FRAME]
    offset = frame_view.position() - joints.mean(axis=0)
    pelvis, head = frame_view.project(joints[[ROLES.index("pelvis"), ROLES.index("head")]], WIDTH, HEIGHT)
    return offset, offset / np.linalg.norm(offset), pelvis, head


@pytest.mark.parametrize(
    ("view", "direction"),
    [("side", [0, 1, 0]), ("rear", [-1, 0, 0]), ("front", [1, 0, 0]), ("top", [0, 0, 1])],
)
def test_each_view_puts_the_camera_on_its_side_of_the_animal(view, direction):
    _, unit, _, _ = _camera_and_points(view)
    assert unit @ np.array(direction, dtype=float) >= SIDE_SHARE


def test_the_side_view_shows_the_body_along_the_picture_and_the_rear_view_end_on():
    _, _, pelvis, head = _camera_and_points("side")
    side_length = abs(head[0] - pelvis[0])
    assert side_length > 0.1 * WIDTH
    assert head[0] < pelvis[0]  # the left side: the head is to the left of the picture
    _, _, pelvis, head = _camera_and_points("rear")
    assert abs(head[0] - pelvis[0]) < 0.25 * side_length


def test_the_top_view_has_the_head_up_the_picture():
    _, _, pelvis, head = _camera_and_points("top")
    assert pelvis[1] - head[1] > 0.2 * HEIGHT
    assert abs(head[0] - pelvis[0]) < 0.1 * WIDTH


def test_the_default_view_is_the_default_camera():
    assert render.view_camera(render.DEFAULT_VIEW) == render.Camera()


def test_a_view_keeps_the_cameras_mode_and_distance():
    camera = render.view_camera("rear", render.Camera(mode="fixed", distance_hp=7.0))
    assert (camera.mode, camera.distance_hp, camera.azimuth_deg) == ("fixed", 7.0, render.VIEWS["rear"][0])


def test_an_unknown_view_is_a_bad_camera_naming_the_views():
    with pytest.raises(QuadpipeError) as raised:
        render.view_camera("below")
    assert raised.value.issues[0].code == "bad-camera" and "side" in str(raised.value)


def test_the_command_line_offers_every_view():
    assert sorted(view.value for view in View) == sorted(render.VIEWS)


def test_render_view_option_changes_the_picture(tmp_path):
    """In process: the option and the pictures are what is checked, not the process around them."""
    clip = tmp_path / "dog.npz"
    export_npz(dog_clip(), clip)
    pictures = {}
    for view in ("side", "rear"):
        path = tmp_path / f"{view}.png"
        result = invoke_cli("render", str(clip), "-o", str(path), "--view", view, "--width", "160", "--height", "120")
        assert result.returncode == 0, result.stderr
        pictures[view] = np.asarray(Image.open(path))
    assert np.abs(pictures["side"].astype(int) - pictures["rear"].astype(int)).max(axis=2).mean() > 10
    result = invoke_cli("render", str(clip), "-o", str(tmp_path / "x.png"), "--view", "below")
    assert result.returncode != 0 and "below" in result.stderr


def test_the_camera_stands_back_from_a_body_long_and_high_for_its_pelvis_height():
    from quadpipe.bodies import dress
    from quadpipe.sim.simulation import simulate

    distances = {}
    for animal in ("dog", "rat"):
        clip = dress(simulate(animal, "rigid", seconds=0.0).clip)
        track = clip.animals[0]
        distances[animal] = render.camera_views(clip)[0].distance / track.pelvis_height
        assert distances[animal] * track.pelvis_height >= render.camera.MIN_BODY_SIZES * render.camera.body_size(track)
    assert distances["dog"] == pytest.approx(render.Camera().distance_hp)
    assert distances["rat"] > 2 * render.Camera().distance_hp
