"""Posture figures (`quadpipe.analysis.carriage.posture_report`) on clips whose answer is known.

A stick dog (39 bones, straight legs, capsule feet and tail, pelvis height `HP_M`) is posed by
forward kinematics: each bone's world rotation is given, each joint sits where its parent's
rotation carries its rest offset. The rest pose held still measures zero everywhere; a joint
bent by a known angle measures that angle, with the anatomical sign; a foot slid, a tail
lowered into the floor, a body sunk or rolled measure what was done to them.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from quadpipe.analysis.carriage import JOINTS, TAIL_TOUCH_HP, flexion, posture_report
from quadpipe.analysis.footfalls import rotate, runs, toe_tips
from quadpipe.analysis.ground import ground_height, lowest_point_slides
from quadpipe.anatomy.roles import FOOT_BONES, LEGS, PARENT, ROLES, TAIL, leg_chain
from quadpipe.animals.sizing import natural_time
from quadpipe.clip.model import AnimalTrack, Clip, Shape

HP_M = 0.5
FPS = 60.0
SECONDS = 4.0
PERIOD_S = 1.0
DUTY = 0.5
PHASES = {"lh": 0.0, "lf": 0.25, "rh": 0.5, "rf": 0.75}
FRAMES = round(SECONDS * FPS)
RADIUS_HP = 0.02
"""Radius of the stick dog's foot and tail capsules, HP."""

FORE_JOINTS_HP = ((0.9, 1.0), (0.95, 0.8), (0.9, 0.55), (0.9, 0.25), (0.92, 0.08), (0.95, RADIUS_HP), (1.0, RADIUS_HP))
"""Fore leg joints (x, z) in HP at rest, body to toe tip: scapula, shoulder, elbow, carpus, two phalanges."""

HIND_JOINTS_HP = (
    (0.0, 0.95),
    (0.1, 0.6),
    (0.0, 0.3),
    (0.02, 0.08),
    (0.05, RADIUS_HP),
    (0.09, RADIUS_HP),
    (0.12, RADIUS_HP),
)
"""Hind leg joints (x, z) in HP at rest: hip, knee, hock, three phalanges, toe tip."""

TAIL_STEP_HP = (-0.295, -0.052)
"""Each tail bone at rest, (x, z) in HP: 0.3 HP long, 10 degrees below the horizontal."""


def _axial_rest() -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Rest (start, end) in HP of the trunk, neck, head and tail."""
    bones = {"pelvis": ((0.0, 0.0, 1.0), (0.2, 0.0, 1.0))}
    for i, name in enumerate(("spine0", "spine1", "spine2", "thorax")):
        bones[name] = ((0.2 * (i + 1), 0.0, 1.0), (0.2 * (i + 2), 0.0, 1.0))
    for i in range(5):
        bones[f"neck{i}"] = ((1.0 + 0.05 * i, 0.0, 1.0 + 0.05 * i), (1.05 + 0.05 * i, 0.0, 1.05 + 0.05 * i))
    bones["head"] = ((1.25, 0.0, 1.25), (1.45, 0.0, 1.15))
    for i, name in enumerate(TAIL):
        start = (-0.05 + i * TAIL_STEP_HP[0], 0.0, 1.0 + i * TAIL_STEP_HP[1])
        bones[name] = (start, (start[0] + TAIL_STEP_HP[0], 0.0, start[2] + TAIL_STEP_HP[1]))
    return {name: (np.array(a), np.array(b)) for name, (a, b) in bones.items()}


def _capsule(start: np.ndarray, end: np.ndarray) -> Shape:
    """A capsule of radius `RADIUS_HP` along a bone, in the bone's (world-aligned) frame, metres."""
    vector = (end - start) * HP_M
    half = 0.5 * float(np.linalg.norm(vector))
    axis = vector / (2 * half)
    angle = math.acos(float(np.clip(axis[2], -1.0, 1.0)))
    turn = np.cross([0.0, 0.0, 1.0], axis)
    turn = turn / np.linalg.norm(turn) if np.linalg.norm(turn) > 0 else np.array([1.0, 0.0, 0.0])
    quat = (math.cos(angle / 2), *(math.sin(angle / 2) * turn))
    return Shape("capsule", (RADIUS_HP * HP_M, half), tuple(0.5 * vector), quat)


def rest_pose() -> tuple[np.ndarray, np.ndarray, list[list[Shape]]]:
    """The stick dog's rest (start, end) in metres and its shapes."""
    bones = _axial_rest()
    for leg in LEGS:
        joints = FORE_JOINTS_HP if leg.endswith("f") else HIND_JOINTS_HP
        side = 0.1 if leg.startswith("l") else -0.1
        for bone, (a, b) in zip(leg_chain(leg), zip(joints, joints[1:])):
            bones[f"{leg}_{bone}"] = (np.array([a[0], side, a[1]]), np.array([b[0], side, b[1]]))
    start = np.array([bones[r][0] for r in ROLES]) * HP_M
    end = np.array([bones[r][1] for r in ROLES]) * HP_M
    with_shapes = set(TAIL) | {bone for pair in FOOT_BONES.values() for bone in pair}
    shapes = [[_capsule(*bones[r])] if r in with_shapes else [] for r in ROLES]
    return start, end, shapes


def about_y(degrees: float) -> np.ndarray:
    """The (w, x, y, z) rotation by `degrees` about +Y (the animal's left): + turns down into back."""
    half = math.radians(degrees) / 2
    return np.array([math.cos(half), 0.0, math.sin(half), 0.0])


def about_x(degrees: float) -> np.ndarray:
    half = math.radians(degrees) / 2
    return np.array([math.cos(half), math.sin(half), 0.0, 0.0])


def multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Quaternion product a * b, each (..., 4)."""
    w1, x1, y1, z1 = np.moveaxis(a, -1, 0)
    w2, x2, y2, z2 = np.moveaxis(b, -1, 0)
    return np.stack(
        [
            w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
            w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
            w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
            w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
        ],
        axis=-1,
    )


def descendants(role: str) -> list[str]:
    """A bone and every bone below it."""
    found = [role]
    for child, parent in PARENT.items():
        if parent in found and child not in found:
            found.append(child)
    return found


def contacts() -> np.ndarray:
    """(F, 4) foot contacts of a walk: each foot down for `DUTY` of every `PERIOD_S` from its phase."""
    cycles = np.arange(FRAMES)[:, None] / FPS / PERIOD_S - np.array([PHASES[leg] for leg in LEGS])
    return np.mod(cycles, 1.0) < DUTY


class StickDog:
    """A stick dog's motion being composed: per-frame bone rotations and root offset, then posed."""

    def __init__(self) -> None:
        self.start, self.end, self.shapes = rest_pose()
        self.rotations = np.zeros((FRAMES, len(ROLES), 4))
        self.rotations[..., 0] = 1.0
        self.root = np.repeat(self.start[:1], FRAMES, axis=0)
        self.offsets = np.zeros((FRAMES, len(ROLES), 3))
        self.contacts = np.ones((FRAMES, len(LEGS)), dtype=bool)

    def turn(self, role: str, quat: np.ndarray, frames: np.ndarray | None = None) -> StickDog:
        """Turn a bone and everything below it (in world) by `quat`, at the given frames (default all)."""
        mask = np.ones(FRAMES, dtype=bool) if frames is None else frames
        for bone in descendants(role):
            index = ROLES.index(bone)
            self.rotations[mask, index] = multiply(quat, self.rotations[mask, index])
        return self

    def track(self) -> AnimalTrack:
        """The posed track: joints placed by forward kinematics, then each bone's extra offset added."""
        positions = np.zeros((FRAMES, len(ROLES), 3))
        positions[:, 0] = self.root
        for index, role in enumerate(ROLES[1:], start=1):
            parent = ROLES.index(PARENT[role])
            offset = self.start[index] - self.start[parent]
            positions[:, index] = positions[:, parent] + rotate(self.rotations[:, parent], offset)
        return AnimalTrack(
            name="stick",
            species="stick",
            roles=ROLES,
            parents=np.array([ROLES.index(PARENT[r]) if PARENT[r] else -1 for r in ROLES]),
            rest_start=self.start,
            rest_end=self.end,
            shapes=self.shapes,
            positions=positions + self.offsets,
            rotations=self.rotations,
            pelvis_height=HP_M,
            mass_kg=30.0,
            foot_contacts=self.contacts,
        )


def measure(dog: StickDog, terrain: list[Shape] | None = None):
    """The stick dog's posture, every frame measured."""
    clip = Clip(FPS, [dog.track()], terrain=list(terrain or []))
    return posture_report(clip, settle_natural_times=0.0).animals[0]


def all_joints() -> list[tuple[str, str]]:
    return [(leg, spec[0]) for leg in LEGS for spec in JOINTS[leg.endswith("f")]]


# --------------------------------------------------------------------------- standing still


def test_the_rest_pose_measures_zero_everywhere():
    posture = measure(StickDog())
    for leg in posture.legs.values():
        for joint in leg.joints.values():
            assert joint.stance_max_deg == pytest.approx(0.0, abs=1e-9)
            assert joint.stance_min_deg == pytest.approx(0.0, abs=1e-9)
        assert leg.penetration_rest_hp == pytest.approx(0.0, abs=1e-9)
        assert leg.penetration_dynamic_hp == pytest.approx(0.0, abs=1e-9)
    trunk, head = posture.trunk, posture.head_tail
    assert trunk.pelvis_height_ratio == pytest.approx(1.0)
    assert trunk.withers_height_ratio == pytest.approx(1.0)
    assert trunk.roll_amplitude_deg == pytest.approx(0.0, abs=1e-9)
    assert trunk.yaw_amplitude_deg == pytest.approx(0.0, abs=1e-9)
    assert head.head_dz_max_abs_hp == pytest.approx(0.0, abs=1e-9)
    assert head.head_pitch_deg == pytest.approx(0.0, abs=1e-9)
    assert head.neck_angle_deg == pytest.approx(0.0, abs=1e-9)
    assert head.tail_ground_fraction == 0.0
    assert head.tail_elevation_deg == pytest.approx(head.tail_elevation_rest_deg)
    assert head.tail_elevation_rest_deg == pytest.approx(math.degrees(math.atan2(-0.052, 0.295)))
    assert head.tail_chord_deg == pytest.approx(head.tail_elevation_rest_deg)  # a straight tail's line is its base's


# --------------------------------------------------------------------------- joints

BENDS = [
    # joint, its distal bone, turn about +y that flexes it, which way the toe must go when it flexes
    ("lf", "elbow", "lf_elbow", -1.0, "forward"),
    ("lf", "carpus", "lf_wrist", 1.0, "back"),
    ("lh", "knee", "lh_knee", 1.0, "back"),
    ("lh", "hock", "lh_ankle", -1.0, "forward"),
    ("rf", "shoulder", "rf_shoulder", 1.0, "back"),
    ("rh", "hip", "rh_hip", -1.0, "forward"),
]


@pytest.mark.parametrize(("leg", "joint", "bone", "turn", "toe_goes"), BENDS)
def test_a_joint_bent_in_stance_measures_the_bend_as_flexion(leg, joint, bone, turn, toe_goes):
    dog = StickDog()
    dog.contacts = contacts()
    stance = dog.contacts[:, LEGS.index(leg)]
    dog.turn(bone, about_y(turn * 20.0), stance)
    posture = measure(dog)
    bent = posture.legs[leg].joints[joint]
    assert bent.stance_max_deg == pytest.approx(20.0)
    assert bent.stance_min_deg == pytest.approx(20.0)
    assert bent.swing_max_deg == pytest.approx(0.0, abs=1e-9)
    others = [j for name, j in posture.legs[leg].joints.items() if name != joint]
    assert all(abs(j.stance_max_deg) < 1e-9 for j in others), "only the bent joint changes"
    track = dog.track()
    toe = toe_tips(track)[leg]
    rest_toe_x = toe_tips(StickDog().track())[leg][0, 0]
    moved = toe[np.flatnonzero(stance)[0], 0] - rest_toe_x
    assert (moved > 0) == (toe_goes == "forward"), "flexion moves the paw as anatomy says"


@pytest.mark.parametrize(("leg", "joint", "bone", "turn", "toe_goes"), BENDS)
def test_a_joint_still_folded_as_its_foot_lands_measures_the_fold_at_the_landing(leg, joint, bone, turn, toe_goes):
    dog = StickDog()
    dog.contacts = contacts()
    stance = dog.contacts[:, LEGS.index(leg)]
    landings = np.zeros(FRAMES, dtype=bool)
    landings[[start for start, _ in runs(stance, True) if start > 0]] = True
    dog.turn(bone, about_y(turn * 25.0), landings)
    posture = measure(dog)
    folded = posture.legs[leg].joints[joint]
    assert folded.landing_max_deg == pytest.approx(25.0)
    assert folded.stance_max_deg == pytest.approx(0.0, abs=1e-9), "a stance's first tenth is not its core"
    others = [j for name, j in posture.legs[leg].joints.items() if name != joint]
    assert all(abs(j.landing_max_deg) < 1e-9 for j in others), "only the folded joint lands folded"
    assert posture.to_dict()["legs"][leg]["joints"][joint]["landing_max_deg"] == pytest.approx(25.0)


@pytest.mark.parametrize(("leg", "joint"), all_joints())
def test_flexion_and_extension_have_opposite_signs(leg, joint):
    spec = next(s for s in JOINTS[leg.endswith("f")] if s[0] == joint)
    distal = f"{leg}_{spec[2]}"
    dog = StickDog()
    half = np.arange(FRAMES) < FRAMES // 2
    dog.turn(distal, about_y(spec[3] * 12.0), half).turn(distal, about_y(-spec[3] * 7.0), ~half)
    values = flexion(dog.track(), leg, joint, slice(None))
    assert values[half] == pytest.approx(12.0)
    assert values[~half] == pytest.approx(-7.0)


def test_joint_angles_ignore_the_trunks_heading_and_pitch():
    dog = StickDog()
    dog.turn("lh_knee", about_y(15.0))
    turned = StickDog().turn("lh_knee", about_y(15.0)).turn("pelvis", about_y(-10.0)).turn("pelvis", _about_z(70.0))
    for bent in (dog, turned):
        assert measure(bent).legs["lh"].joints["knee"].stance_mean_deg == pytest.approx(15.0)


def _about_z(degrees: float) -> np.ndarray:
    half = math.radians(degrees) / 2
    return np.array([math.cos(half), 0.0, 0.0, math.sin(half)])


# --------------------------------------------------------------------------- feet


def _stance_ramp(stance: np.ndarray, begin: float, end: float) -> np.ndarray:
    """(F,) 0 before `begin` of each stance, rising to 1 at `end` (fractions), 1 after; 0 in swing."""
    ramp = np.zeros(FRAMES)
    edges = np.flatnonzero(np.diff(np.concatenate([[0], stance.astype(int), [0]])))
    for start, stop in zip(edges[::2], edges[1::2]):
        last = stop - 1
        for frame in range(start, stop):
            fraction = (frame - start) / (last - start)
            ramp[frame] = np.clip((fraction - begin) / (end - begin), 0.0, 1.0)
    return ramp


def test_a_foot_sliding_in_stance_measures_its_slip():
    dog = StickDog()
    dog.contacts = contacts()
    slide_hp = 0.08
    ramp = _stance_ramp(dog.contacts[:, LEGS.index("rf")], 0.2, 0.8)
    for bone in FOOT_BONES["rf"]:
        dog.offsets[:, ROLES.index(bone), 1] = slide_hp * HP_M * ramp
    posture = measure(dog)
    assert posture.legs["rf"].slip_max_hp == pytest.approx(slide_hp)
    assert posture.legs["rf"].slip_hp == pytest.approx(slide_hp)
    assert posture.legs["rf"].stances >= 3
    assert posture.worst("slip_max_hp") == pytest.approx(slide_hp)
    for leg in ("lf", "lh", "rh"):
        assert posture.legs[leg].slip_max_hp == pytest.approx(0.0, abs=1e-9)


def test_a_toe_rolling_over_the_ground_does_not_slide_and_a_skating_one_does():
    dog = StickDog()
    toe = ROLES.index(FOOT_BONES["rf"][1])
    radius = dog.shapes[toe][0].size[0]
    end = dog.end[toe]
    angles = np.radians(np.linspace(0.0, 20.0, FRAMES))
    quats = np.array([about_y(math.degrees(a)) for a in angles])
    # Rolling: turned about its end's centre, which moves forward by radius x angle.
    dog.rotations[:, toe] = quats
    dog.offsets[:, toe] = end + rotate(quats, dog.start[toe] - end) - dog.start[toe]
    dog.offsets[:, toe, 0] += radius * angles
    rolling = lowest_point_slides(dog.track(), [toe], slice(None))
    assert np.abs(rolling).sum(axis=0)[:2] == pytest.approx([0.0, 0.0], abs=1e-3 * HP_M)
    # Skating: the same toe, unturned, pushed sideways.
    skate = StickDog()
    skate.offsets[:, toe, 1] = np.linspace(0.0, 0.05 * HP_M, FRAMES)
    sliding = lowest_point_slides(skate.track(), [toe], slice(None))
    assert sliding.sum(axis=0)[:2] == pytest.approx([0.0, 0.05 * HP_M])


def test_a_foot_lifted_in_swing_measures_its_clearance():
    dog = StickDog()
    dog.contacts = contacts()
    lift_hp = 0.04
    swing = ~dog.contacts[:, LEGS.index("lh")]
    for bone in FOOT_BONES["lh"]:
        dog.offsets[:, ROLES.index(bone), 2] = lift_hp * HP_M * swing
    posture = measure(dog)
    assert posture.legs["lh"].swing_clearance_hp == pytest.approx(lift_hp)
    assert posture.legs["rh"].swing_clearance_hp == pytest.approx(0.0, abs=1e-9)
    assert posture.lowest("swing_clearance_hp") == pytest.approx(0.0, abs=1e-9)


def test_a_foot_coming_down_measures_its_touchdown_speed():
    dog = StickDog()
    dog.contacts = contacts()
    speed_m_s = 0.4
    swing = ~dog.contacts[:, LEGS.index("lh")]
    height = np.zeros(FRAMES)
    for start, stop in runs(swing, True):
        height[start:stop] = speed_m_s / FPS * np.arange(stop - start, 0, -1)  # down to the ground at `stop`
    for bone in FOOT_BONES["lh"]:
        dog.offsets[:, ROLES.index(bone), 2] = height
    posture = measure(dog)
    assert posture.legs["lh"].touchdown_speed == pytest.approx(speed_m_s * natural_time(HP_M) / HP_M, rel=1e-6)
    assert posture.legs["rh"].touchdown_speed == pytest.approx(0.0, abs=1e-9)
    assert posture.worst("touchdown_speed") == posture.legs["lh"].touchdown_speed


def test_a_toe_pushed_forward_before_lift_off_measures_its_drag():
    dog = StickDog()
    dog.contacts = contacts()
    drag_hp = 0.05
    ramp = _stance_ramp(dog.contacts[:, LEGS.index("lh")], 0.8, 1.0)
    dog.offsets[:, ROLES.index(FOOT_BONES["lh"][1]), 0] = drag_hp * HP_M * ramp
    posture = measure(dog)
    assert posture.legs["lh"].toe_drag_max_hp == pytest.approx(drag_hp)
    assert posture.legs["rh"].toe_drag_max_hp == pytest.approx(0.0, abs=1e-9)


def test_a_sunken_body_measures_its_penetration_and_lower_trunk():
    dog = StickDog()
    depth_hp = 0.03
    dog.root[:, 2] -= depth_hp * HP_M
    posture = measure(dog)
    for leg in posture.legs.values():
        assert leg.penetration_rest_hp == pytest.approx(depth_hp)
        assert leg.penetration_dynamic_hp == pytest.approx(depth_hp)
    assert posture.trunk.pelvis_height_ratio == pytest.approx(1.0 - depth_hp)
    assert posture.head_tail.head_dz_hp == pytest.approx(-depth_hp)


def test_heights_are_measured_from_the_terrain_under_the_animal():
    step_hp = 0.2
    dog = StickDog()
    for points in (dog.start, dog.end, dog.root):
        points[:, 2] += step_hp * HP_M
    block = Shape("box", (5.0, 5.0, 0.5 * step_hp * HP_M), (0.0, 0.0, 0.5 * step_hp * HP_M))
    floor = Shape("plane", (50.0, 50.0))
    posture = measure(dog, [floor, block])
    assert posture.trunk.pelvis_height_ratio == pytest.approx(1.0)
    assert posture.legs["lf"].penetration_rest_hp == pytest.approx(0.0, abs=1e-9)


def test_ground_height_follows_planes_and_turned_boxes():
    tilted = Shape("plane", (10.0, 10.0), quat=tuple(about_y(10.0)))
    box = Shape("box", (1.0, 1.0, 0.5), (3.0, 0.0, 0.5), tuple(_about_z(45.0)))
    xy = np.array([[1.0, 0.0], [3.0, 0.0], [3.0 + 1.3, 0.0], [3.0 + 1.5, 0.0]])
    heights = ground_height([tilted, box], xy)
    slope = -math.tan(math.radians(10.0))
    assert heights[0] == pytest.approx(slope * 1.0)
    assert heights[1] == pytest.approx(1.0)
    assert heights[2] == pytest.approx(1.0), "inside the box turned by 45 degrees (half diagonal 1.41 m)"
    assert heights[3] == pytest.approx(slope * 4.5)
    assert ground_height([], xy) == pytest.approx(np.zeros(4))


# --------------------------------------------------------------------------- trunk, head, tail


def test_a_rolling_pelvis_measures_its_roll_amplitude():
    dog = StickDog()
    dog.contacts = contacts()
    amplitude = 6.0
    roll = amplitude * np.sin(2 * math.pi * np.arange(FRAMES) / FPS / PERIOD_S)
    for frame, degrees in enumerate(roll):
        dog.turn("pelvis", about_x(degrees), np.arange(FRAMES) == frame)
    posture = measure(dog)
    assert posture.strides == 2
    assert posture.trunk.roll_amplitude_deg == pytest.approx(amplitude)
    assert posture.trunk.roll_mean_deg == pytest.approx(0.0, abs=0.1)
    assert posture.trunk.yaw_amplitude_deg == pytest.approx(0.0, abs=1e-9)


def test_a_lowered_head_measures_its_pitch_and_drop():
    dog = StickDog().turn("head", about_y(25.0))
    head = measure(dog).head_tail
    half_head = 0.5 * (dog.end - dog.start)[ROLES.index("head")]
    drop_hp = (rotate(about_y(25.0)[None, :], half_head)[0, 2] - half_head[2]) / HP_M
    assert head.head_pitch_deg == pytest.approx(-25.0)
    assert head.head_dz_hp == pytest.approx(drop_hp)
    assert drop_hp < -0.03
    assert head.neck_angle_deg == pytest.approx(0.0, abs=1e-9)


def tail_lowered_to(clearance_hp: float) -> float:
    """How far (degrees) to lower the stick dog's tail for its lowest point to clear the floor by this much."""
    length = len(TAIL) * math.hypot(*TAIL_STEP_HP)
    return math.degrees(math.asin((1.0 - RADIUS_HP - clearance_hp) / length)) - math.degrees(
        math.atan2(-TAIL_STEP_HP[1], -TAIL_STEP_HP[0])
    )


def test_a_tail_lowered_into_the_floor_is_counted():
    dog = StickDog()
    half = np.arange(FRAMES) < FRAMES // 2
    lowered = tail_lowered_to(-0.05)
    dog.turn("tail0", about_y(-lowered), half)
    tail = measure(dog).head_tail
    assert tail.tail_ground_fraction == pytest.approx(half.mean())
    rest = tail.tail_elevation_rest_deg
    assert tail.tail_elevation_deg == pytest.approx(half.mean() * (rest - lowered) + (1 - half.mean()) * rest)
    assert tail.tail_chord_deg == pytest.approx(tail.tail_elevation_deg)  # the whole straight tail turned with its base


@pytest.mark.parametrize(("clearance", "counted"), [(0.5 * TAIL_TOUCH_HP, True), (2.0 * TAIL_TOUCH_HP, False)])
def test_a_tail_within_the_tolerance_of_the_floor_touches_it(clearance, counted):
    dog = StickDog().turn("tail0", about_y(-tail_lowered_to(clearance)))
    lowest = dog.track().positions[:, ROLES.index("tail3")] + rotate(
        dog.rotations[:, ROLES.index("tail3")], (dog.end - dog.start)[ROLES.index("tail3")]
    )
    assert lowest[:, 2] - RADIUS_HP * HP_M == pytest.approx(clearance * HP_M)
    assert measure(dog).head_tail.tail_ground_fraction == (1.0 if counted else 0.0)


# --------------------------------------------------------------------------- a real walk

SWING_FOLD_DEG = 30.0
"""The locomotion controller's swing springs fold the elbow, carpus, knee and hock: in the
swing each must measure at least this much flexion, or the signs are wrong."""


@pytest.mark.slow
def test_the_walks_swing_fold_measures_as_flexion():
    from quadpipe.sim.simulation import simulate

    posture = posture_report(simulate("dog", "walk", seconds=4.0).clip).animals[0]
    for leg in LEGS:
        for joint in ("elbow", "carpus") if leg.endswith("f") else ("knee", "hock"):
            swing = posture.legs[leg].joints[joint].swing_max_deg
            assert swing is not None and swing > SWING_FOLD_DEG, (leg, joint, swing)


# --------------------------------------------------------------------------- quadpipe analyze


def test_analyze_prints_and_writes_the_posture(cli, tmp_path):
    from quadpipe.exporters.npz import export_npz

    dog = StickDog()
    dog.contacts = contacts()
    dog.root[:, 2] -= 0.03 * HP_M
    dog.turn("lf_elbow", about_y(-20.0), dog.contacts[:, LEGS.index("lf")])
    path = tmp_path / "stick.npz"
    export_npz(Clip(FPS, [dog.track()]), path)
    text = cli("analyze", str(path), "--settle", "0")
    assert text.returncode == 0, text.stderr
    assert "Posture (vs the standing pose" in text.stdout
    assert "elbow 20/20/20" in text.stdout
    report = tmp_path / "report.json"
    shown = cli("analyze", str(path), "--settle", "0", "--format", "json", "-o", str(report))
    assert shown.returncode == 0, shown.stderr
    printed = json.loads(shown.stdout.split("\nwrote ")[0])
    assert printed == json.loads(report.read_text())
    posture = printed["animals"]["stick"]["posture"]
    assert posture["first_frame"] == 0
    assert posture["legs"]["lf"]["joints"]["elbow"]["stance_max_deg"] == pytest.approx(20.0)
    assert posture["trunk"]["pelvis_height_ratio"] == pytest.approx(0.97)
    assert posture["worst"]["penetration_rest_hp"] == pytest.approx(0.03)
