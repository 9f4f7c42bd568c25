"""spine_walk on the dog: it stays up, walks forward, and keeps its footfalls.

Thresholds are in pelvis heights (HP), so they mean the same for every animal.
"""

from __future__ import annotations

import functools

import numpy as np
import pytest

from quadpipe import roles as R
from quadpipe.simulate import simulate

WALK_SECONDS = 20.0
MIN_DISTANCE_HP = 5.0
MIN_PELVIS_HP = 0.8
UPRIGHT_DEG = 30.0


@functools.lru_cache(maxsize=None)
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
    assert up_axis_tilt_deg(track.rotations[:, R.ROLES.index("thorax")]).max() < UPRIGHT_DEG


@pytest.mark.slow
def test_every_foot_steps_during_the_walk():
    contacts = walk("dog").clip.animals[0].foot_contacts[30:].astype(int)
    liftoffs = (np.diff(contacts, axis=0) == -1).sum(axis=0)
    seconds = (len(contacts) - 1) / 30.0
    assert np.all(liftoffs >= 0.5 * seconds / (38 / 30))  # at least half the cycles show a step
