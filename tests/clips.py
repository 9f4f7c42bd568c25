"""Real clips for exporter tests: the dog simulated under deterministic pushes, cached per session.

The pushes (sinusoidal forces and torques on the head, legs and tail, through
`data.xfrc_applied`) make every bone translate and rotate, so a round trip that mixed up axes,
quaternion order or parent frames would show. A thrown box adds a moving prop; the floor is
the terrain.
"""

from __future__ import annotations

import copy
import functools
import math

import mujoco
import numpy as np

from quadpipe.animals import sizing
from quadpipe.clip.model import AnimalTrack, Clip, PropTrack
from quadpipe.sim.recording import Recorder
from quadpipe.world.placement import Placement, build_world
from tests.conftest import built_animal

CLIP_SECONDS = 2.0
"""Length of the single-dog clip (61 frames at 30 fps)."""

SHORT_CLIP_SECONDS = 0.5
"""Length of the two-dog clip."""

PUSH_WEIGHTS = 0.25
"""Peak push force on the head and each lower leg, in body weights."""

TWIST_WEIGHT_HP = 0.02
"""Peak twisting torque on the pelvis and the tail, in body weights x HP."""

PUSH_HZ = (1.3, 2.1, 0.7)
"""Frequencies of the pushes along x, y and z, in hertz."""

PUSHED_BONES = ("head", "lf_wrist", "rf_elbow", "lh_ankle", "rh_knee", "tail2")
TWISTED_BONES = ("pelvis", "tail0")

BOX_HALF_SIZE_M = 0.08
BOX_START = (1.2, -0.6, 0.9)
BOX_SPIN_RAD_S = (3.0, -5.0, 2.0)
BOX_VELOCITY_M_S = (-0.5, 0.4, 1.0)

SECOND_DOG_XY = (0.0, 1.5)
"""Where the second dog of the two-dog clip stands, metres."""

BLOW_UP_FRAME = 20
"""The frame from which the blown-up clip holds NaNs."""


def _add_box(spec: mujoco.MjSpec) -> None:
    body = spec.worldbody.add_body(name="crate", pos=list(BOX_START))
    body.add_freejoint(name="crate")
    body.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[BOX_HALF_SIZE_M] * 3, rgba=[0.7, 0.45, 0.2, 1.0], mass=2.0)


def _push(model: mujoco.MjModel, data: mujoco.MjData, placements: list[Placement]) -> None:
    """Set this step's deterministic pushes on every animal (layout: force, torque)."""
    data.xfrc_applied[:] = 0.0
    t = data.time
    wave = np.array([math.sin(2 * math.pi * hz * t + phase) for hz, phase in zip(PUSH_HZ, (0.0, 1.0, 2.0))])
    for placement in placements:
        animal = placement.built.animal
        weight = animal.mass_kg * sizing.GRAVITY
        for index, bone in enumerate(PUSHED_BONES):
            body = model.body(f"{placement.name}/{bone}").id
            data.xfrc_applied[body, :3] = PUSH_WEIGHTS * weight * np.roll(wave, index)
        for index, bone in enumerate(TWISTED_BONES):
            body = model.body(f"{placement.name}/{bone}").id
            data.xfrc_applied[body, 3:] = TWIST_WEIGHT_HP * weight * animal.pelvis_height * np.roll(wave, index + 1)


def simulate(placements: list[Placement], seconds: float, *, box: bool) -> Clip:
    """Simulate the placed animals under pushes and record a clip at 30 fps (4 steps a frame)."""
    spec = build_world(placements)
    if box:
        _add_box(spec)
    model = spec.compile()
    data = mujoco.MjData(model)
    if box:
        joint = model.joint("crate")
        data.qvel[joint.dofadr[0] : joint.dofadr[0] + 6] = [*BOX_VELOCITY_M_S, *BOX_SPIN_RAD_S]
    recorder = Recorder(model, placements, sizing.FRAME_RATE)
    steps = round(1.0 / (sizing.FRAME_RATE * model.opt.timestep))
    mujoco.mj_forward(model, data)
    recorder.capture(data)
    for _ in range(round(seconds * sizing.FRAME_RATE)):
        for _ in range(steps):
            _push(model, data, placements)
            mujoco.mj_step(model, data)
        recorder.capture(data)
    return recorder.clip({"status": "ok", "scene": "exporter-test", "seed": "0"})


@functools.cache
def _dog_clip() -> Clip:
    return simulate([Placement("dog", built_animal("dog"))], CLIP_SECONDS, box=True)


@functools.cache
def _two_dog_clip() -> Clip:
    dog = built_animal("dog")
    return simulate([Placement("dog", dog), Placement("dog2", dog, SECOND_DOG_XY)], SHORT_CLIP_SECONDS, box=False)


def dog_clip() -> Clip:
    """The dog pushed about for 2 s with a box thrown beside it (a private copy of the cached clip)."""
    return copy.deepcopy(_dog_clip())


def two_dog_clip() -> Clip:
    """Two dogs side by side, pushed for 0.5 s, no prop (a private copy)."""
    return copy.deepcopy(_two_dog_clip())


def blown_up_clip() -> Clip:
    """The dog clip as a diverged simulation leaves it: NaN poses from a frame on, status not ok."""
    clip = dog_clip()
    clip.metadata["status"] = f"simulation blew up at frame {BLOW_UP_FRAME}"
    clip.animals[0].positions[BLOW_UP_FRAME:] = np.nan
    clip.animals[0].rotations[BLOW_UP_FRAME:] = np.nan
    return clip


def assert_tracks_equal(a: AnimalTrack | PropTrack, b: AnimalTrack | PropTrack) -> None:
    """Every field of two tracks is equal (arrays exactly, dtype included)."""
    assert type(a) is type(b)
    for name, value in vars(a).items():
        other = getattr(b, name)
        if isinstance(value, np.ndarray):
            assert value.dtype == other.dtype and value.shape == other.shape, name
            np.testing.assert_array_equal(value, other, err_msg=name)
        else:
            assert value == other, name


def assert_clips_equal(a: Clip, b: Clip) -> None:
    """Two clips hold the same frames, tracks, terrain, sensors and metadata, exactly."""
    assert (a.fps, a.terrain, a.metadata) == (b.fps, b.terrain, b.metadata)
    assert len(a.animals) == len(b.animals) and len(a.props) == len(b.props)
    for first, second in zip(a.animals + a.props, b.animals + b.props):
        assert_tracks_equal(first, second)
    assert sorted(a.sensors) == sorted(b.sensors)
    for name, values in a.sensors.items():
        np.testing.assert_array_equal(values, b.sensors[name], err_msg=name)
