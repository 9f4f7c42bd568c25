"""spine_walk on the dog: it stays up, walks forward, and keeps its footfalls.

Thresholds are in pelvis heights (HP), so they mean the same for every animal.
"""

from __future__ import annotations

import functools

import numpy as np
import pytest

from quadpipe.anatomy import roles
from quadpipe.sim.simulation import simulate

WALK_SECONDS = 20.0
MIN_DISTANCE_HP = 5.0
MIN_PELVIS_HP = 0.8
UPRIGHT_DEG = 30.0


@functools.cache
def walk(animal: str):
    return simulate(animal, "spine_walk", seconds=WALK_SECONDS)


def up_axis_tilt_deg(rotations: np.ndarray) -> np.ndarray:
    """Angle between a body's local +Z and the world's +Z, per frame, from (w, x, y, z) quaternions."""
    w, x, y, z = rotations.T
    up_z = 1.0 - 2.0 * (x * x + y * y)
    return np.degrees(np.arccos(np.clip(up_z, -1.0, 1.0)))


@pytest.mark.slow
def test_the_dog_walks_20_s_without_falling_and_covers_5_hp():
    result = walk("dog")
    track = result.clip.animals[0]
    figures = result.metrics["animals"]["dog"]
    assert not figures["fell"]
    assert figures["pelvis_height_min_hp"] > MIN_PELVIS_HP
    assert figures["forward_hp"] >= MIN_DISTANCE_HP
    assert up_axis_tilt_deg(track.rotations[:, roles.ROLES.index("thorax")]).max() < UPRIGHT_DEG


@pytest.mark.slow
def test_every_foot_steps_during_the_walk():
    contacts = walk("dog").clip.animals[0].foot_contacts[30:].astype(int)
    liftoffs = (np.diff(contacts, axis=0) == -1).sum(axis=0)
    seconds = (len(contacts) - 1) / 30.0
    assert np.all(liftoffs >= 0.5 * seconds / (38 / 30))  # at least half the cycles show a step


HILL_SECONDS = 30.0
HILL_END_HP = 4 + 2 * 0.5 / np.tan(np.radians(12)) + 3  # start + up and down ramps + plateau (configs/scenes/hill.yaml)
THROWS_AT = ((3.0, "thorax"), (6.0, "pelvis"), (9.0, "thorax"))
"""Each box's throw time (s) and the bone it is aimed at (configs/scenes/throws.yaml, `target`)."""
RECOVERY_S = 3.0


@pytest.mark.slow
def test_on_the_hill_it_climbs_and_descends_without_tumbling():
    result = simulate("dog", "spine_walk", seconds=HILL_SECONDS, scene="hill")
    track = result.clip.animals[0]
    hp = track.pelvis_height
    pelvis = track.positions[:, 0]
    forward = (pelvis[:, 0] - pelvis[0, 0]) / hp
    on_top = np.flatnonzero(pelvis[:, 2] > pelvis[0, 2] + 0.4 * hp)
    assert on_top.size > 0, "it never got onto the plateau"
    assert forward[-1] > HILL_END_HP, "it did not get past the far foot of the hill"
    assert abs(pelvis[-1, 2] - pelvis[0, 2]) < 0.15 * hp  # back down on the ground
    assert not result.metrics["animals"]["dog"]["fell"]
    assert up_axis_tilt_deg(track.rotations[:, roles.ROLES.index("thorax")]).max() < 45.0


@pytest.mark.slow
def test_hit_by_thrown_boxes_it_recovers_and_resumes_toward_the_goal():
    result = simulate("dog", "spine_walk", seconds=15.0, scene="throws")
    clip = result.clip
    track = clip.animals[0]
    hp = track.pelvis_height
    tilt = up_axis_tilt_deg(track.rotations[:, roles.ROLES.index("thorax")])
    boxes = [prop for prop in clip.props if prop.name.startswith("thrown")]
    assert len(boxes) == len(THROWS_AT)
    for box, (throw_time, aimed_at) in zip(boxes, THROWS_AT):
        frame = round(throw_time * clip.fps)
        later = slice(frame, frame + clip.fps)
        bone = track.positions[later, roles.ROLES.index(aimed_at)]
        miss = np.linalg.norm(box.positions[later] - bone, axis=1).min()
        assert miss < 0.5 * hp, f"the box thrown at {throw_time} s missed the {aimed_at}"
        recovered = frame + round(RECOVERY_S * clip.fps)
        assert tilt[recovered] < 25.0 and track.positions[recovered, 0, 2] > 0.85 * hp
    goal = np.array([20 * hp, 0.0])
    start = round((THROWS_AT[-1][0] + RECOVERY_S) * clip.fps)
    before = np.linalg.norm(goal - track.positions[start, 0, :2])
    after = np.linalg.norm(goal - track.positions[-1, 0, :2])
    assert before - after > 1.0 * hp  # heading for the goal again
    assert not result.metrics["animals"]["dog"]["fell"]
