"""Behaviour of the standing controllers on the dog: rigid, point_target and postures (thesis §5.1-5.3).

Every threshold is in pelvis heights (HP), seconds or degrees, measured on the recorded clip.
The simulations are deterministic and cached per module, so each one runs once.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from quadpipe.anatomy import roles
from tests.conftest import cached_simulation

ANIMAL = "dog"
FIXTURES = Path(__file__).resolve().parent / "fixtures" / "behaviour"
FPS = 30
FOOT_TIPS = {"lf": "lf_fpha1", "rf": "rf_fpha1", "lh": "lh_hpha2", "rh": "rh_hpha2"}
"""Leg -> the toe bone whose far end is the foot's tip (`{leg}.foot` in controllers)."""
LEG_ORDER = ("lf", "rf", "lh", "rh")
"""Order of the legs in `AnimalTrack.foot_contacts`."""

STAND_SECONDS = 10.0
REST_HEIGHT_TOLERANCE = 0.15
"""Standing, the pelvis stays within 15 % of its height at frame 0."""
SETTLE_SECONDS = 3.0
ROCKING_RANGE_HP = 0.02
"""Once settled, the pelvis moves less than this forward and back (the undamped rigid rocked 0.05-0.09 HP)."""

PUSH_START_S, PUSH_SECONDS = 2.0, 6.0
SLIDE_HP = 0.2
"""A push must slide every foot at least this far sideways."""
STILL_FEET_HP = 0.01
"""Before the push, once it has settled, no foot moves more than this."""
FOOT_LIFT_HP = 0.25
"""Sliding, the feet stay on the ground: no foot tip rises higher than this."""
PUSHED_HEIGHT_FRACTION = 0.7
"""Pushed, the pelvis stays above this fraction of its rest height."""
GENTLE_PUSH = (("push_force", "0.2 bw"),)
"""A third of the fixture's push: less than the feet's grip."""
GENTLE_SLIDE_HP = 0.05
"""Pushed gently, no foot moves farther than this: rigid resists before it slides."""
UPRIGHT_DEG = 20.0
"""After the push, the pelvis's up axis is within this of the vertical."""
STILL_SPEED_HP_S = 0.05
"""After the push, the pelvis has come to rest: slower than this over the last second."""

TARGETS_HP = {"ahead_left": (3.0, 1.0, 1.5), "ahead_right": (3.0, -1.0, 1.5)}
"""Targets in HP, world frame: the shipped one (x forward, y left, z up) and its mirror image."""
AIM_AFTER_S, AIM_SECONDS = 3.0, 4.0
AIM_DEG = 20.0
"""From 3 s on, the neck (neck0 -> head) and the body (pelvis -> head) point within this of the target."""
RAISED_FOOT_HP = 0.2
"""A raised foot's tip is at least this high above the ground."""
FALLEN_HP = 0.7
"""Balancing, the pelvis never drops below this."""

POSTURE_HOLD_S = 3.0
"""The shipped `postures` machine switches every 3 s: standing, sitting, lying, standing."""
POSTURE_SECONDS = 4 * POSTURE_HOLD_S - 1.0 / FPS
"""The whole cycle back to standing, ending one frame before the machine would sit again."""
SETTLED_WINDOW_S = 0.5
"""A posture's heights are averaged over the last half second before the next switch."""
SIT_BELOW_STAND_HP = 0.2
"""Sitting, the pelvis is at least this much lower than standing."""
LIE_BELOW_SIT_HP = 0.04
"""Lying, the pelvis is lower again (the hind legs fold no further; the body comes down in front)."""
SIT_THORAX_ABOVE_PELVIS_HP = 0.2
"""Sitting, the thorax is at least this much higher than the pelvis."""
LIE_THORAX_BELOW_SIT_HP = 0.2
"""Lying, the thorax is at least this much lower than sitting."""
TRANSITION_SPEED_HP_S = 1.5
"""Changing posture, pelvis and thorax move slower than this (the old stiff elastics jumped up at 4 HP/s)."""
FRAME_STEP_HP = 0.1
"""No bone moves more than this between two frames (3 HP/s): no jump anywhere in the body."""


# --------------------------------------------------------------------------- clips


def _run(controller: str, seconds: float, parameters: tuple[tuple[str, str], ...] = ()):
    """Simulate the dog under a controller (cached: each simulation runs once per session)."""
    return cached_simulation(ANIMAL, controller, seconds, None, parameters)


def _track(controller: str, seconds: float, parameters: tuple[tuple[str, str], ...] = ()):
    """The dog's recorded motion under a controller."""
    return _run(controller, seconds, parameters).clip.animals[0]


def _target_parameter(target_hp: tuple[float, float, float]) -> tuple[tuple[str, str], ...]:
    """point_target's `target` parameter for a point given in HP."""
    x, y, z = target_hp
    return (("target", f"[{x} HP, {y} HP, {z} HP]"),)


# --------------------------------------------------------------------------- measures


def _rotate(quaternions: np.ndarray, vectors: np.ndarray) -> np.ndarray:
    """Rotate vectors (..., 3) by unit quaternions (..., 4) given as (w, x, y, z)."""
    w, axis = quaternions[..., :1], quaternions[..., 1:]
    twice = 2.0 * np.cross(axis, vectors)
    return vectors + w * twice + np.cross(axis, twice)


def _bone_end(track, role: str) -> np.ndarray:
    """World position of a bone's far end in every frame, (F, 3)."""
    index = roles.ROLES.index(role)
    offset = track.rest_end[index] - track.rest_start[index]
    return track.positions[:, index] + _rotate(
        track.rotations[:, index], np.broadcast_to(offset, track.positions[:, index].shape)
    )


def _joint(track, role: str) -> np.ndarray:
    """World position of a bone's joint in every frame, (F, 3)."""
    return track.positions[:, roles.ROLES.index(role)]


def _tilt_deg(track) -> np.ndarray:
    """Angle between the pelvis's up axis and the vertical, per frame (degrees)."""
    up = _rotate(track.rotations[:, 0], np.broadcast_to([0.0, 0.0, 1.0], track.positions[:, 0].shape))
    return np.degrees(np.arccos(np.clip(up[:, 2], -1.0, 1.0)))


def _angle_deg(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Angle between vectors along the last axis, in degrees."""
    cos = np.sum(a * b, axis=-1) / (np.linalg.norm(a, axis=-1) * np.linalg.norm(b, axis=-1))
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def _speed_hp_s(track, role: str) -> np.ndarray:
    """Speed of a bone's joint between consecutive frames, in HP per second."""
    return np.linalg.norm(np.diff(_joint(track, role), axis=0), axis=1) * FPS / track.pelvis_height


def _frame(seconds: float) -> int:
    """The frame recorded at a time."""
    return round(seconds * FPS)


# --------------------------------------------------------------------------- rigid (§5.1)


def test_rigid_stands_ten_seconds_near_its_rest_height() -> None:
    track = _track("rigid", STAND_SECONDS)
    heights = _joint(track, "pelvis")[:, 2]
    assert np.abs(heights / heights[0] - 1.0).max() < REST_HEIGHT_TOLERANCE
    assert track.foot_contacts[_frame(SETTLE_SECONDS) :].all(), "every foot stays on the ground"


def test_rigid_does_not_rock_once_settled() -> None:
    track = _track("rigid", STAND_SECONDS)
    forward = _joint(track, "pelvis")[_frame(SETTLE_SECONDS) :, 0] / track.pelvis_height
    assert np.ptp(forward) < ROCKING_RANGE_HP


def _foot_tips(track) -> np.ndarray:
    """World positions of the four foot tips, (F, 4, 3)."""
    return np.stack([_bone_end(track, bone) for bone in FOOT_TIPS.values()], axis=1)


def test_a_side_push_makes_rigid_slide_without_falling() -> None:
    track = _track(str(FIXTURES / "rigid_pushed.yaml"), PUSH_SECONDS)
    hp = track.pelvis_height
    start = _frame(PUSH_START_S)
    tips = _foot_tips(track)
    sideways = (tips[:, :, 1] - tips[start, :, 1]) / hp
    assert np.abs(sideways[_frame(PUSH_START_S / 2) : start]).max() < STILL_FEET_HP, (
        "the feet stand still before the push"
    )
    assert sideways[-1].min() > SLIDE_HP, "every foot slid sideways, the way it was pushed"
    assert tips[start:, :, 2].max() / hp < FOOT_LIFT_HP, "the feet slid along the ground"
    heights = _joint(track, "pelvis")[:, 2]
    assert heights.min() > PUSHED_HEIGHT_FRACTION * heights[0]
    assert _tilt_deg(track)[-1] < UPRIGHT_DEG
    assert _speed_hp_s(track, "pelvis")[-FPS:].max() < STILL_SPEED_HP_S, "it comes to rest"


def test_rigid_resists_a_gentle_push() -> None:
    track = _track(str(FIXTURES / "rigid_pushed.yaml"), PUSH_SECONDS, GENTLE_PUSH)
    tips = _foot_tips(track)
    moved = np.linalg.norm(tips[-1] - tips[_frame(PUSH_START_S)], axis=1) / track.pelvis_height
    assert moved.max() < GENTLE_SLIDE_HP


# --------------------------------------------------------------------------- point_target (§5.2)


@pytest.mark.parametrize("target_hp", TARGETS_HP.values(), ids=TARGETS_HP.keys())
def test_point_target_aims_neck_and_body_at_the_target(target_hp: tuple[float, float, float]) -> None:
    track = _track("point_target", AIM_SECONDS, _target_parameter(target_hp))
    target = np.array(target_hp) * track.pelvis_height
    aiming = slice(_frame(AIM_AFTER_S), None)
    neck0, head, pelvis = (_joint(track, role)[aiming] for role in ("neck0", "head", "pelvis"))
    assert _angle_deg(head - neck0, target - neck0).max() < AIM_DEG
    assert _angle_deg(head - pelvis, target - pelvis).max() < AIM_DEG


@pytest.mark.parametrize("target_hp", TARGETS_HP.values(), ids=TARGETS_HP.keys())
def test_point_target_balances_on_two_diagonal_legs(target_hp: tuple[float, float, float]) -> None:
    track = _track("point_target", AIM_SECONDS, _target_parameter(target_hp))
    hp = track.pelvis_height
    balancing = slice(_frame(AIM_AFTER_S), None)
    contacts = dict(zip(LEG_ORDER, track.foot_contacts[balancing].T))
    assert contacts["lf"].all() and contacts["rh"].all(), "it stands on the left fore and right hind feet"
    assert not contacts["rf"].any() and not contacts["lh"].any(), "the two pointing legs are off the ground"
    for leg in ("rf", "lh"):
        assert _bone_end(track, FOOT_TIPS[leg])[balancing, 2].min() / hp > RAISED_FOOT_HP
    assert _joint(track, "pelvis")[:, 2].min() / hp > FALLEN_HP


# --------------------------------------------------------------------------- postures (§5.3)


def _posture_heights(track) -> dict[str, tuple[float, float]]:
    """Posture -> (pelvis, thorax) height in HP, averaged over the end of its hold."""
    hp = track.pelvis_height
    window = _frame(SETTLED_WINDOW_S)
    heights = {}
    for index, posture in enumerate(("standing", "sitting", "lying")):
        end = _frame((index + 1) * POSTURE_HOLD_S)
        frames = slice(end - window, end)
        heights[posture] = tuple(float(_joint(track, role)[frames, 2].mean() / hp) for role in ("pelvis", "thorax"))
    return heights


def test_postures_lower_the_pelvis_from_standing_to_sitting_to_lying() -> None:
    heights = _posture_heights(_track("postures", POSTURE_SECONDS))
    (stand, stand_thorax), (sit, sit_thorax), (lie, lie_thorax) = heights.values()
    assert stand - sit > SIT_BELOW_STAND_HP
    assert sit - lie > LIE_BELOW_SIT_HP
    assert sit_thorax - sit > SIT_THORAX_ABOVE_PELVIS_HP, "sitting, the pelvis is well below the thorax"
    assert sit_thorax - lie_thorax > LIE_THORAX_BELOW_SIT_HP, "lying, the front comes down too"
    assert abs(stand_thorax - stand) < SIT_THORAX_ABOVE_PELVIS_HP / 2, "standing, the back is level"


def test_postures_stand_up_again_at_the_end_of_the_cycle() -> None:
    track = _track("postures", POSTURE_SECONDS)
    heights = _joint(track, "pelvis")[:, 2] / track.pelvis_height
    first = _posture_heights(track)["standing"][0]
    assert heights[-_frame(SETTLED_WINDOW_S) :].mean() == pytest.approx(first, abs=0.05)


def test_changing_posture_moves_smoothly() -> None:
    track = _track("postures", POSTURE_SECONDS)
    switching = slice(_frame(POSTURE_HOLD_S), None)
    for role in ("pelvis", "thorax"):
        assert _speed_hp_s(track, role)[switching].max() < TRANSITION_SPEED_HP_S, role
    steps = np.linalg.norm(np.diff(track.positions, axis=0), axis=2) / track.pelvis_height
    assert steps[switching].max() < FRAME_STEP_HP
