"""What a picture takes from the clip: whether it can be drawn, its length unit, and its poses
held through non-finite frames."""

from __future__ import annotations

import numpy as np

from quadpipe.clip.model import Clip
from quadpipe.core.errors import QuadpipeError


def check_clip(clip: Clip) -> None:
    """Raise unless the clip can be drawn: frames, an animal, and a finite pose of that animal.

    Raises:
        QuadpipeError: `empty-clip`, `no-animal` or `no-finite-frame`.
    """
    if clip.frame_count == 0:
        raise QuadpipeError.single("empty-clip", "the clip has no frames, there is nothing to render")
    if not clip.animals:
        raise QuadpipeError.single(
            "no-animal", "the clip has no animal: the camera follows and is scaled by the first animal"
        )
    if not np.isfinite(clip.animals[0].positions).all(axis=(1, 2)).any():
        raise QuadpipeError.single(
            "no-finite-frame",
            f"animal {clip.animals[0].name!r} has no frame with a finite pose: nothing to show",
            hint="the simulation diverged at once; check the clip's metadata status",
        )


def clip_scale(clip: Clip) -> float:
    """The length unit of the picture: the first animal's pelvis height, metres."""
    return float(clip.animals[0].pelvis_height)


def finite_hold(values: np.ndarray) -> np.ndarray:
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


def mocap_poses(clip: Clip) -> tuple[np.ndarray, np.ndarray]:
    """(F, M, 3) positions and (F, M, 4) orientations of the display model's bone and prop bodies.

    Each track holds its last finite pose through frames where it has none.
    """
    positions = [track.positions for track in clip.animals] + [prop.positions[:, None] for prop in clip.props]
    rotations = [track.rotations for track in clip.animals] + [prop.rotations[:, None] for prop in clip.props]
    return (
        np.concatenate([finite_hold(p) for p in positions], axis=1),
        np.concatenate([finite_hold(q) for q in rotations], axis=1),
    )
