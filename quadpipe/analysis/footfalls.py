"""Footfalls from a clip's per-frame foot contacts: flickers, bounces and scuffs cleaned away,
and the toe tips' positions that measure each stance's slip."""

from __future__ import annotations

import math

import numpy as np

from quadpipe.analysis.report import Footfall
from quadpipe.anatomy.roles import TOE_BONES
from quadpipe.animals.sizing import natural_time
from quadpipe.clip.model import AnimalTrack, Clip
from quadpipe.core.errors import QuadpipeError, did_you_mean

MIN_RUN_NATURAL_TIMES = 0.1
"""A contact or a gap shorter than this many natural times sqrt(HP / g) is a flicker (26 ms
for the thesis dog, 5 ms for the rat, 55 ms for the elephant). Longer runs count: a horse's
hind foot at a bound is down for 0.18 natural time."""

MIN_RUN_FRAMES = 2
"""Runs shorter than this many frames are flickers whatever the frame rate."""

MIN_FRAMES_PER_NATURAL_TIME = 6.0
"""Below this many frames per natural time sqrt(HP / g), footfalls are not resolved (a dog at
30 fps has 7.8; a rat at 30 fps, 2): the report says which frame rate to record at."""

SCUFF_FRACTION = 0.4
"""A contact shorter than this fraction of the foot's typical stance is a scuff (a toe dragging
during the swing), not a footfall; the typical stance is the 75th percentile of its contacts."""

BOUNCE_FRACTION = 0.4
"""A lift shorter than this fraction of the foot's typical swing, between two contacts, is a
bounce (the foot hopping inside one stance), not a step; the typical swing is the 75th
percentile of its lifts."""

TYPICAL_STANCE_PERCENTILE = 75.0
"""Percentile of a foot's contact (or lift) lengths taken as its typical stance (or swing)."""


def min_run_frames(fps: float, pelvis_height: float) -> int:
    """Shortest contact or gap that counts at this frame rate for an animal of this HP, in frames."""
    return max(MIN_RUN_FRAMES, round(MIN_RUN_NATURAL_TIMES * natural_time(pelvis_height) * fps))


def frame_rate_note(fps: float, pelvis_height: float) -> str | None:
    """A note when the clip has too few frames per natural time to resolve footfalls."""
    own = natural_time(pelvis_height)
    if fps * own >= MIN_FRAMES_PER_NATURAL_TIME:
        return None
    needed = math.ceil(MIN_FRAMES_PER_NATURAL_TIME / own / 10.0) * 10
    return (
        f"{fps * own:.1f} frames per natural time sqrt(HP/g) = {own * 1000:.0f} ms: too few to resolve footfalls;"
        f" record at {needed:g} fps or more (quadpipe simulate --fps)"
    )


def clean_contacts(contact: np.ndarray, min_frames: int) -> np.ndarray:
    """One foot's per-frame contacts as footfalls: flickers, then bounces, then scuffs removed.

    Bounces go before scuffs: a foot that touches, hops off and lands for good starts its
    stance at the first touch, whose short contact would otherwise be dropped as a scuff.
    """
    return drop_scuffs(fill_bounces(debounce(contact, min_frames)))


def debounce(contact: np.ndarray, min_frames: int) -> np.ndarray:
    """One foot's contacts without flickers: gaps, then contacts, shorter than `min_frames` removed.

    Args:
        contact: (F,) booleans.
        min_frames: shortest run that counts.
    """
    cleaned = np.asarray(contact, dtype=bool).copy()
    for value in (False, True):
        for start, stop in runs(cleaned, value):
            if stop - start < min_frames:
                cleaned[start:stop] = not value
    return cleaned


def drop_scuffs(contact: np.ndarray, fraction: float = SCUFF_FRACTION) -> np.ndarray:
    """One foot's contacts without scuffs: contacts shorter than `fraction` of its typical stance.

    The typical stance is the `TYPICAL_STANCE_PERCENTILE`th percentile of its contacts' lengths,
    so that a few scuffs do not lower it.
    """
    return _drop_short_runs(contact, True, fraction)


def fill_bounces(contact: np.ndarray, fraction: float = BOUNCE_FRACTION) -> np.ndarray:
    """One foot's contacts without bounces: lifts shorter than `fraction` of its typical swing
    are filled, so that a foot hopping inside its stance makes one footfall, not two.

    Only lifts between two contacts count; the typical swing is the
    `TYPICAL_STANCE_PERCENTILE`th percentile of those lifts' lengths.
    """
    return _drop_short_runs(contact, False, fraction)


def _drop_short_runs(contact: np.ndarray, value: bool, fraction: float) -> np.ndarray:
    """`contact` with the inner runs of `value` shorter than `fraction` of the typical one flipped.

    A run of contacts counts wherever it lies; a run of lifts only between two contacts (the
    clip's first and last frames may cut a swing short).
    """
    cleaned = np.asarray(contact, dtype=bool).copy()
    inner = [(start, stop) for start, stop in runs(cleaned, value) if value or (start > 0 and stop < len(cleaned))]
    if not inner:
        return cleaned
    typical = float(np.percentile([stop - start for start, stop in inner], TYPICAL_STANCE_PERCENTILE))
    for start, stop in inner:
        if stop - start < fraction * typical:
            cleaned[start:stop] = not value
    return cleaned


def runs(mask: np.ndarray, value: bool) -> list[tuple[int, int]]:
    """(start, stop) frames of every maximal run of `value` in a boolean array."""
    padded = np.concatenate([[False], np.asarray(mask) == value, [False]]).astype(np.int8)
    edges = np.flatnonzero(np.diff(padded))
    return [(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2])]


def footfalls_of(contact: np.ndarray, tip: np.ndarray) -> tuple[Footfall, ...]:
    """One foot's stances from its cleaned (F,) contacts, with the slip of its (F, 3) toe tip."""
    frames = len(contact)
    result = []
    for start, stop in runs(contact, True):
        touchdown = start if start > 0 else None
        liftoff = stop if stop < frames else None
        slip = None
        if touchdown is not None and liftoff is not None:
            slip = float(np.linalg.norm(np.diff(tip[start:stop, :2], axis=0), axis=1).sum())
        result.append(Footfall(touchdown, liftoff, slip))
    return tuple(result)


def toe_tips(track: AnimalTrack, frames: int | None = None) -> dict[str, np.ndarray]:
    """World position of each toe tip per frame: the far end of the leg's last phalanx.

    A bone's body frame is aligned with the world at rest, so its end offset in that frame is
    `rest_end - rest_start`; each frame rotates it by the bone's orientation.
    """
    tips = {}
    for leg, bone in TOE_BONES.items():
        index = track.roles.index(bone)
        offset = track.rest_end[index] - track.rest_start[index]
        tips[leg] = track.positions[:frames, index] + rotate(track.rotations[:frames, index], offset)
    return tips


def rotate(quaternions: np.ndarray, vector: np.ndarray) -> np.ndarray:
    """Rotate one vector by each (w, x, y, z) unit quaternion of an (N, 4) array: (N, 3)."""
    w = quaternions[:, :1]
    axis = quaternions[:, 1:]
    twice_cross = 2.0 * np.cross(axis, vector)
    return vector + w * twice_cross + np.cross(axis, twice_cross)


def finite_frames(track: AnimalTrack) -> int:
    """Frames from the first before any pose becomes NaN or infinite."""
    bad = ~np.isfinite(track.positions).all(axis=(1, 2)) | ~np.isfinite(track.rotations).all(axis=(1, 2))
    return int(np.argmax(bad)) if bad.any() else int(track.positions.shape[0])


def named_tracks(clip: Clip, animal: str | None) -> list[AnimalTrack]:
    """The clip's animals, or the one named `animal`.

    Raises:
        QuadpipeError: `unknown-animal` when no animal of the clip has that name.
    """
    if animal is None:
        return list(clip.animals)
    tracks = [track for track in clip.animals if track.name == animal]
    if not tracks:
        raise QuadpipeError.single(
            "unknown-animal",
            f"the clip has no animal named {animal!r}",
            hint=did_you_mean(animal, [t.name for t in clip.animals]),
        )
    return tracks
