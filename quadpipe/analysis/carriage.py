"""Posture measured on a baked clip: joint flexion in stance, trunk height and sway, head and tail
carriage, and how the feet slip, drag and sink, all against the animal's own standing pose.

The standing reference is the clip's rest pose (`rest_start`, `rest_end`): a skeleton's rest
pose is its standing pose, facing +X. Figures are in degrees and pelvis heights (HP), and
time is measured in natural times sqrt(HP / g), so one threshold holds from rat to elephant.
docs/analysis.md defines each figure; `posture_report` is the entry point.
"""

from __future__ import annotations

import numpy as np

from quadpipe.analysis.footfalls import (
    clean_contacts,
    finite_frames,
    min_run_frames,
    named_tracks,
    rotate,
    runs,
    toe_tips,
)
from quadpipe.analysis.gait import REFERENCE_LEG
from quadpipe.analysis.ground import ground_height, lowest_point_slides, lowest_points
from quadpipe.analysis.posture import (
    AnimalPosture,
    HeadTailPosture,
    JointFlexion,
    LegPosture,
    PostureReport,
    TrunkPosture,
)
from quadpipe.anatomy import roles
from quadpipe.animals.sizing import natural_time
from quadpipe.clip.model import AnimalTrack, Clip

SETTLE_NATURAL_TIMES = 4.0
"""Frames before this many natural times are not measured: the animal rising into its gait
(1 s for the dog). At most half the clip is skipped."""

STANCE_TRIM_FRACTION = 0.1
"""Each stance's first and last tenth are left out of joint angles and slip: touchdown and
lift-off transients."""

DRAG_FRACTION = 0.25
"""Toe drag is the toe tip's forward travel over the last quarter of each stance."""

SWING_MIDDLE = (0.25, 0.75)
"""Swing clearance is measured over the middle half of each swing: lift-off and landing left out."""

TOUCHDOWN_FRAMES = 2
"""A touchdown's speed is the foot's fastest descent over this many frames up to its landing frame."""

TAIL_TOUCH_HP = 0.01
"""A tail shape whose lowest point is within this many HP of the ground touches it."""

JOINTS: dict[bool, tuple[tuple[str, str, str, float], ...]] = {
    True: (
        ("shoulder", "scapula", "shoulder", 1.0),
        ("elbow", "shoulder", "elbow", -1.0),
        ("carpus", "elbow", "wrist", 1.0),
    ),
    False: (("hip", "pelvis", "hip", -1.0), ("knee", "hip", "knee", 1.0), ("hock", "knee", "ankle", -1.0)),
}
"""Per front (True) / hind leg: joint name, proximal and distal bone (the leg's prefix added to
leg bones), and the sign that makes flexion positive. The signed angle from the proximal to
the distal bone about the animal's left (+Y) axis grows when the distal bone swings back:
flexion at the shoulder, carpus and knee, extension at the hip, elbow and hock."""

FORWARD = np.array([1.0, 0.0, 0.0])
LEFT = np.array([0.0, 1.0, 0.0])
UP = np.array([0.0, 0.0, 1.0])


def posture_report(
    clip: Clip, animal: str | None = None, settle_natural_times: float = SETTLE_NATURAL_TIMES
) -> PostureReport:
    """Measure the posture of every animal of a clip, or of the one named `animal`.

    Args:
        settle_natural_times: natural times sqrt(HP / g) left out at the start (at most half
            the clip); 0 measures every frame.

    Raises:
        QuadpipeError: `unknown-animal` when no animal of the clip has that name.
    """
    tracks = named_tracks(clip, animal)
    return PostureReport(clip.fps, tuple(_animal_posture(clip, track, settle_natural_times) for track in tracks))


def _animal_posture(clip: Clip, track: AnimalTrack, settle_natural_times: float) -> AnimalPosture:
    stop = finite_frames(track)
    first = min(round(settle_natural_times * natural_time(track.pelvis_height) * clip.fps), stop // 2)
    window = slice(first, stop)
    min_frames = min_run_frames(clip.fps, track.pelvis_height)
    contacts = {
        leg: clean_contacts(track.foot_contacts[:stop, i], min_frames)[first:] for i, leg in enumerate(roles.LEGS)
    }
    strides = [start for start, _ in runs(contacts[REFERENCE_LEG], True) if start > 0]
    notes = []
    if stop < track.positions.shape[0]:
        notes.append(f"poses are not finite from frame {stop} on: only frames up to {stop - 1} are measured")
    if len(strides) < 2:
        notes.append("no whole stride of the left hind foot: sway is measured over all the frames")
    legs = {leg: _leg_posture(clip, track, leg, contacts[leg], window) for leg in roles.LEGS}
    return AnimalPosture(
        name=track.name,
        species=track.species,
        pelvis_height=track.pelvis_height,
        fps=clip.fps,
        first_frame=first,
        frames=stop - first,
        strides=max(0, len(strides) - 1),
        legs=legs,
        trunk=_trunk(clip, track, window, strides),
        head_tail=_head_tail(clip, track, window),
        notes=tuple(notes),
    )


# --------------------------------------------------------------------------- geometry


def bone_direction(track: AnimalTrack, role: str, window: slice) -> np.ndarray:
    """(F, 3) world direction of a bone, from its joint to its end (its rest vector turned)."""
    index = track.roles.index(role)
    return rotate(track.rotations[window, index], track.rest_end[index] - track.rest_start[index])


def rest_direction(track: AnimalTrack, role: str) -> np.ndarray:
    """(1, 3) a bone's direction in the standing (rest) pose."""
    index = track.roles.index(role)
    return (track.rest_end[index] - track.rest_start[index])[None, :]


def heading(track: AnimalTrack, role: str, window: slice) -> np.ndarray:
    """(F, 3) horizontal unit forward axis of a bone's body frame (+X at rest)."""
    forward = rotate(track.rotations[window, track.roles.index(role)], FORWARD)
    forward[:, 2] = 0.0
    return forward / np.maximum(np.linalg.norm(forward, axis=1, keepdims=True), 1e-12)


def sagittal_angle(proximal: np.ndarray, distal: np.ndarray, forward: np.ndarray) -> np.ndarray:
    """Signed angle (degrees) from `proximal` to `distal` about the left axis of the vertical
    plane through `forward`, both directions projected onto that plane (each (F, 3))."""
    left = np.cross(UP, forward)
    left /= np.maximum(np.linalg.norm(left, axis=1, keepdims=True), 1e-12)
    p = proximal - (proximal * left).sum(axis=1, keepdims=True) * left
    d = distal - (distal * left).sum(axis=1, keepdims=True) * left
    sine = (np.cross(p, d) * left).sum(axis=1)
    return np.degrees(np.arctan2(sine, (p * d).sum(axis=1)))


def elevation(vectors: np.ndarray) -> np.ndarray:
    """Angle above the horizontal of each of (F, 3) vectors, degrees."""
    return np.degrees(np.arctan2(vectors[:, 2], np.linalg.norm(vectors[:, :2], axis=1)))


def height_above_ground(clip: Clip, points: np.ndarray) -> np.ndarray:
    """Height of each of (F, 3) points above the ground under it, metres."""
    return points[:, 2] - ground_height(clip.terrain, points[:, :2])


# --------------------------------------------------------------------------- legs


def flexion(track: AnimalTrack, leg: str, joint: str, window: slice) -> np.ndarray:
    """(F,) flexion of a leg joint, degrees beyond its standing angle (positive: closing)."""
    front = leg.endswith("f")
    _, proximal, distal, sign = next(spec for spec in JOINTS[front] if spec[0] == joint)
    proximal_role = proximal if proximal in roles.ROLES else f"{leg}_{proximal}"
    distal_role = f"{leg}_{distal}"
    forward = heading(track, "thorax" if front else "pelvis", window)
    angle = sagittal_angle(
        bone_direction(track, proximal_role, window), bone_direction(track, distal_role, window), forward
    )
    rest = sagittal_angle(rest_direction(track, proximal_role), rest_direction(track, distal_role), FORWARD[None, :])
    return sign * _wrap_degrees(angle - rest)


def _wrap_degrees(angle: np.ndarray) -> np.ndarray:
    return (angle + 180.0) % 360.0 - 180.0


def stance_core(contact: np.ndarray) -> np.ndarray:
    """(F,) the stance frames without each stance's first and last `STANCE_TRIM_FRACTION`."""
    core = np.zeros(len(contact), dtype=bool)
    for start, stop in runs(contact, True):
        trim = int(STANCE_TRIM_FRACTION * (stop - start))
        core[start + trim : stop - trim] = True
    return core


def _leg_posture(clip: Clip, track: AnimalTrack, leg: str, contact: np.ndarray, window: slice) -> LegPosture:
    core = stance_core(contact)
    touchdowns = [start for start, _ in runs(contact, True) if start > 0]
    joints = {}
    for name, *_ in JOINTS[leg.endswith("f")]:
        values = flexion(track, leg, name, window)
        joints[name] = _joint_flexion(name, values[core], values[~contact], values[touchdowns])
    complete = [(a, b) for a, b in runs(contact, True) if a > 0 and b < len(contact)]
    hp = track.pelvis_height
    foot = [track.roles.index(bone) for bone in roles.FOOT_BONES[leg]]
    low = lowest_points(track, foot, window)
    slides = lowest_point_slides(track, foot, window)
    slips = [] if slides is None else [_slip(slides[:, :2], a, b) / hp for a, b in complete]
    tip = toe_tips(track)[leg][window]
    forward = heading(track, "thorax" if leg.endswith("f") else "pelvis", window)
    drags = [_drag(tip, forward, a, b) / hp for a, b in complete]
    depth = None if low is None else -height_above_ground(clip, low) / hp
    swings = [(a, b) for a, b in runs(contact, False) if a > 0 and b < len(contact)]
    clearances = [] if depth is None else [_clearance(-depth, a, b) for a, b in swings]
    landings = [a for a, _ in runs(contact, True) if a >= TOUCHDOWN_FRAMES]
    frames_per_natural_time = clip.fps * natural_time(hp)
    speeds = [] if depth is None else [_touchdown_descent(-depth, a) * frames_per_natural_time for a in landings]
    return LegPosture(
        leg=leg,
        joints=joints,
        stances=len(complete),
        slip_hp=_mean(slips),
        slip_max_hp=max(slips, default=None),
        toe_drag_hp=_mean(drags),
        toe_drag_max_hp=max(drags, default=None),
        penetration_dynamic_hp=None if depth is None else float(depth.max()),
        penetration_rest_hp=None if depth is None or not core.any() else float(np.median(depth[core])),
        swing_clearance_hp=min(clearances, default=None),
        touchdown_speed=max(speeds, default=None),
    )


def _joint_flexion(name: str, stance: np.ndarray, swing: np.ndarray, landings: np.ndarray) -> JointFlexion:
    swing_max = float(swing.max()) if len(swing) else None
    landing_max = float(landings.max()) if len(landings) else None
    if not len(stance):
        return JointFlexion(name, None, None, None, swing_max, landing_max)
    return JointFlexion(name, float(stance.max()), float(stance.mean()), float(stance.min()), swing_max, landing_max)


def _slip(slides_xy: np.ndarray, start: int, stop: int) -> float:
    """How far (m) the foot slides horizontally from where it settled over the stance's core:
    the largest distance of the summed slides of its lowest point (rolling over it is no slide)."""
    trim = int(STANCE_TRIM_FRACTION * (stop - start))
    path = np.cumsum(slides_xy[start + trim : stop - trim - 1], axis=0)
    return float(np.linalg.norm(path, axis=1).max()) if len(path) else 0.0


def _drag(tip: np.ndarray, forward: np.ndarray, start: int, stop: int) -> float:
    """How far (m) the toe tip moves forward over the last `DRAG_FRACTION` of a stance."""
    begin = stop - max(1, round(DRAG_FRACTION * (stop - start)))
    travel = ((tip[begin:stop, :2] - tip[begin, :2]) * forward[begin, :2]).sum(axis=1)
    return float(max(0.0, travel.max()))


def _clearance(height: np.ndarray, start: int, stop: int) -> float:
    """The foot's lowest height above the ground over the middle of one swing (`SWING_MIDDLE`)."""
    first, last = (start + round(share * (stop - start)) for share in SWING_MIDDLE)
    return float(height[first : max(last, first + 1)].min())


def _touchdown_descent(height: np.ndarray, landing: int) -> float:
    """The foot's fastest descent (HP per frame, positive down) over the frames up to a landing."""
    return float(max(0.0, -np.diff(height[landing - TOUCHDOWN_FRAMES : landing + 1]).min()))


def _mean(values: list[float]) -> float | None:
    return float(np.mean(values)) if values else None


# --------------------------------------------------------------------------- trunk, head, tail


def _trunk(clip: Clip, track: AnimalTrack, window: slice, strides: list[int]) -> TrunkPosture:
    pelvis = track.roles.index("pelvis")
    rotations = track.rotations[window, pelvis]
    roll = np.degrees(np.arcsin(np.clip(rotate(rotations, LEFT)[:, 2], -1.0, 1.0)))
    forward = rotate(rotations, FORWARD)
    yaw = np.degrees(np.unwrap(np.arctan2(forward[:, 1], forward[:, 0])))
    pelvis_ratio = _height_ratio(clip, track, "pelvis", window)
    return TrunkPosture(
        pelvis_height_ratio=float(pelvis_ratio.mean()),
        pelvis_height_ratio_min=float(pelvis_ratio.min()),
        withers_height_ratio=float(_height_ratio(clip, track, "thorax", window).mean()),
        roll_mean_deg=float(roll.mean()),
        roll_amplitude_deg=oscillation_amplitude(roll, strides),
        yaw_amplitude_deg=oscillation_amplitude(yaw, strides),
    )


def _height_ratio(clip: Clip, track: AnimalTrack, role: str, window: slice) -> np.ndarray:
    """(F,) height of a bone's joint above the ground over its standing height."""
    index = track.roles.index(role)
    standing = height_above_ground(clip, track.rest_start[index][None, :])[0]
    return height_above_ground(clip, track.positions[window, index]) / standing


def oscillation_amplitude(signal: np.ndarray, strides: list[int]) -> float:
    """Half the peak-to-peak of a signal about its straight-line trend, per stride, averaged.

    `strides` are the frames that start successive strides (fewer than two: the whole signal
    is one stretch). The trend joins the stretch's end values, so a steady turn or drift is not
    counted as sway.
    """
    bounds = list(zip(strides, strides[1:])) if len(strides) >= 2 else [(0, len(signal) - 1)]
    amplitudes = []
    for start, stop in bounds:
        stretch = signal[start : stop + 1]
        trend = np.linspace(stretch[0], stretch[-1], len(stretch))
        detrended = stretch - trend
        amplitudes.append(0.5 * float(detrended.max() - detrended.min()))
    return float(np.mean(amplitudes))


def _head_tail(clip: Clip, track: AnimalTrack, window: slice) -> HeadTailPosture:
    hp = track.pelvis_height
    head = track.roles.index("head")
    centre = track.positions[window, head] + 0.5 * bone_direction(track, "head", window)
    rest_centre = track.rest_start[head] + 0.5 * rest_direction(track, "head")
    dz = (height_above_ground(clip, centre) - height_above_ground(clip, rest_centre)[0]) / hp
    neck = track.positions[window, head] - track.positions[window, track.roles.index("neck0")]
    rest_neck = (track.rest_start[head] - track.rest_start[track.roles.index("neck0")])[None, :]
    tail = [track.roles.index(bone) for bone in roles.TAIL]
    tail_low = lowest_points(track, tail, window)
    touching = None if tail_low is None else height_above_ground(clip, tail_low) <= TAIL_TOUCH_HP * hp
    return HeadTailPosture(
        head_dz_hp=float(dz.mean()),
        head_dz_max_abs_hp=float(np.abs(dz).max()),
        head_pitch_deg=_mean_elevation_change(bone_direction(track, "head", window), rest_direction(track, "head")),
        neck_angle_deg=_mean_elevation_change(neck, rest_neck),
        tail_ground_fraction=None if touching is None else float(touching.mean()),
        tail_elevation_deg=float(elevation(bone_direction(track, "tail0", window)).mean()),
        tail_elevation_rest_deg=float(elevation(rest_direction(track, "tail0"))[0]),
        tail_chord_deg=float(elevation(_tail_chord(track, window)).mean()),
    )


def _tail_chord(track: AnimalTrack, window: slice) -> np.ndarray:
    """(F, 3) the line from the tail's root (its first joint) to its tip (its last bone's end)."""
    root = track.positions[window, track.roles.index(roles.TAIL[0])]
    last = roles.TAIL[-1]
    tip = track.positions[window, track.roles.index(last)] + bone_direction(track, last, window)
    return tip - root


def _mean_elevation_change(vectors: np.ndarray, rest: np.ndarray) -> float:
    return float(elevation(vectors).mean() - elevation(rest)[0])
