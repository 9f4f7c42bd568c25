"""The camera: how a clip is framed (`Camera`), and where each frame's view looks from (`CameraView`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Literal

import numpy as np

from quadpipe.clip.model import AnimalTrack, Clip
from quadpipe.core.errors import QuadpipeError
from quadpipe.render.poses import clip_scale, finite_hold

FOVY_DEG = 45.0
"""Vertical field of view of the camera, degrees."""

SMOOTHING_PAD_TIME_CONSTANTS = 4.0
"""Length of the reflected padding at each end of a tracked path, in filter time constants."""

CAMERA_MODES = ("track", "fixed")

MIN_BODY_SIZES = 1.6
"""The camera stays at least this many body sizes (`body_size`) from its target. Distances are
in pelvis heights, and most bodies are about 2 HP long (the dog's 2.2: 4.5 HP is two of them),
but the rat's is 7 HP long and 2.5 HP high: 4.5 HP put the camera inside it."""

VIEWS: dict[str, tuple[float, float]] = {
    "three-quarter": (-120.0, -20.0),
    "side": (-90.0, -8.0),
    "rear": (0.0, -8.0),
    "front": (180.0, -8.0),
    "top": (0.0, -89.0),
}
"""Named views of an animal heading +X: (azimuth, elevation) in degrees, as `Camera` takes them.
`side` looks at its left side (the camera on +Y, looking towards -Y), `rear` from behind
(looking along +X), `front` from ahead, `top` from above (its head up the picture: -90 would
make MuJoCo's free camera's up vector undefined), `three-quarter` from its front left, the default."""

DEFAULT_VIEW = "three-quarter"


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


def view_camera(view: str, camera: Camera = Camera()) -> Camera:
    """`camera` turned to one of the named `VIEWS` (its mode, distance and smoothing kept).

    Raises:
        QuadpipeError: code `bad-camera` for a name that is not one of `VIEWS`.
    """
    if view not in VIEWS:
        raise QuadpipeError.single(
            "bad-camera", f"view {view!r} is not one of {', '.join(VIEWS)}", hint=f"e.g. --view {DEFAULT_VIEW}"
        )
    azimuth, elevation = VIEWS[view]
    return replace(camera, azimuth_deg=azimuth, elevation_deg=elevation)


def camera_views(clip: Clip, camera: Camera = Camera()) -> list[CameraView]:
    """The camera of every clip frame.

    Raises:
        QuadpipeError: code `bad-camera` for an unknown mode or a distance that is not positive.

    The camera aims at the centroid of the first animal's joints (the pelvis alone would put
    the animal half a body off-centre), from at least `MIN_BODY_SIZES` of its body sizes. Tracking smooths that path with an exponential filter
    run forwards then backwards over the whole clip: it does not jitter with the gait, and,
    unlike a one-way filter, does not lag behind a running animal. Distances scale with the
    animal's pelvis height, so a rat and an elephant fill the frame alike.
    """
    check_camera(camera)
    scale = clip_scale(clip)
    path = finite_hold(clip.animals[0].positions).mean(axis=1)
    distance = max(camera.distance_hp * scale, MIN_BODY_SIZES * body_size(clip.animals[0]))
    if camera.mode == "track":
        targets = _smooth_both_ways(path, camera.smoothing_s * clip.fps)
    else:
        target, distance = _fixed_target(path, camera, distance)
        targets = np.repeat(target[None], clip.frame_count, axis=0)
    return [CameraView(target, distance, camera.azimuth_deg, camera.elevation_deg) for target in targets]


def body_size(track: AnimalTrack) -> float:
    """An animal's size at rest, metres: the larger of its horizontal length and its height,
    of its skinned body if it has one, else of its bones."""
    points = track.body.vertices if track.body is not None else np.concatenate([track.rest_start, track.rest_end])
    extent = points.max(axis=0) - points.min(axis=0)
    return float(max(math.hypot(extent[0], extent[1]), extent[2]))


def check_camera(camera: Camera) -> None:
    """Raise unless the camera's mode is known, its distance positive and its smoothing not negative.

    Raises:
        QuadpipeError: code `bad-camera`.
    """
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
    smooth = np.concatenate([2 * path[0] - path[pad:0:-1], path, 2 * path[-1] - path[-2 : -pad - 2 : -1]])
    inertia = math.exp(-1.0 / time_constant_frames)  # weight of the previous smoothed value
    for frame in range(1, len(smooth)):
        smooth[frame] += inertia * (smooth[frame - 1] - smooth[frame])
    for frame in range(len(smooth) - 2, -1, -1):
        smooth[frame] += inertia * (smooth[frame + 1] - smooth[frame])
    return smooth[pad : pad + len(path)]


def _fixed_target(path: np.ndarray, camera: Camera, distance: float) -> tuple[np.ndarray, float]:
    """A fixed camera's target, and its distance: the animal's own, plus what the path's
    bounding sphere needs to fit the view."""
    if camera.lookat is not None:
        return np.array(camera.lookat, dtype=float), distance
    low, high = path.min(axis=0), path.max(axis=0)
    radius = float(np.linalg.norm(high - low)) / 2
    return (low + high) / 2, distance + radius / math.sin(math.radians(FOVY_DEG) / 2)
