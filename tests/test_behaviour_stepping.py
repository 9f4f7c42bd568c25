"""Stepping controllers on the dog: `leash` (thesis §5.4) and `leg_by_leg` (§5.5).

Both must move the dog by steps: every foot leaves the ground and lands again, the feet move
forward while they are in the air, and planted feet barely slide. Thresholds are in pelvis
heights (HP). The simulations are deterministic and cached, so each one runs once.
"""

from __future__ import annotations

import numpy as np
import pytest

from quadpipe.anatomy import roles
from tests.conftest import cached_simulation

ANIMAL = "dog"
FPS = 30
LEG_ORDER = ("lf", "rf", "lh", "rh")
"""Order of the legs in `AnimalTrack.foot_contacts`."""
FOOT_TIPS = {"lf": "lf_fpha1", "rf": "rf_fpha1", "lh": "lh_hpha2", "rh": "rh_hpha2"}
"""Leg -> its last toe bone, whose position stands for the foot."""

LEASH_SECONDS = 5.0
LEASH_START_S = 1.0
"""The shipped leash starts pulling after about 1 s (4 natural times for the dog)."""
LEASH_MIN_FORWARD_HP = 1.0
LEG_BY_LEG_SECONDS = 10.0
LEG_BY_LEG_MIN_FORWARD_HP = 1.5
SETTLE_S = 1.0
"""Steps are counted from here on: the dog is dropped on its feet at the start."""

MIN_PELVIS_HP = 0.8
"""Walking, the pelvis stays above this height (it stands at about 1.05 HP)."""
MAX_SIDEWAYS_HP = 0.5
MIN_LEASH_STEPS = 2
MIN_LEG_BY_LEG_STEPS = 4
"""Steps (a lift, then a landing) every leg takes at least."""
MIN_TRAVEL_WITH_A_FOOT_UP = 0.6
"""Share of the pelvis's forward travel made while at least one foot is off the ground."""
MAX_PLANTED_SLIDE = 0.25
"""A planted foot slides (in any direction) less than this share of the pelvis's travel."""
MIN_FOOT_FOLLOWS = 0.5
"""Every foot ends at least this share of the pelvis's travel ahead of where it started."""
MIN_FOOT_TRAVEL_IN_AIR = 0.75
"""At least this share of a foot's forward travel happens in the air."""
STILL_HP = 0.2
"""Without the pull or the push, the dog moves less than this."""


def _run(controller: str, seconds: float, parameters: tuple[tuple[str, str], ...] = ()):
    """Simulate the dog under a controller (cached: each simulation runs once per session)."""
    return cached_simulation(ANIMAL, controller, seconds, None, parameters)


def _figures(controller: str, seconds: float, parameters: tuple[tuple[str, str], ...] = ()) -> dict:
    """The dog's `clip_metrics` figures for one (cached) run."""
    return _run(controller, seconds, parameters).metrics["animals"][ANIMAL]


def _track(controller: str, seconds: float, parameters: tuple[tuple[str, str], ...] = ()):
    """The dog's recorded track for one (cached) run."""
    return _run(controller, seconds, parameters).clip.animals[0]


def _steps(track, since_s: float) -> dict[str, int]:
    """Per leg, how many times the foot left the ground and came back after `since_s`."""
    contacts = track.foot_contacts[int(since_s * FPS) :].astype(bool)
    steps = {}
    for index, leg in enumerate(LEG_ORDER):
        down = contacts[:, index]
        lifts = np.flatnonzero(down[:-1] & ~down[1:])
        lands = np.flatnonzero(~down[:-1] & down[1:])
        # contact alternates, so each landing after the first lift closes one step
        steps[leg] = int((lands > lifts[0]).sum()) if lifts.size else 0
    return steps


def _pelvis_hp(track, axis: int) -> np.ndarray:
    """Pelvis position along a world axis per frame (0: forward, 1: left), in HP from where it started."""
    x = track.positions[:, roles.ROLES.index("pelvis"), axis]
    return (x - x[0]) / track.pelvis_height


def _foot_travel_hp(track, leg: str) -> tuple[float, float, float]:
    """A foot's travel in HP: net forward; sliding while planted (any direction); forward in the air."""
    xy = track.positions[:, roles.ROLES.index(FOOT_TIPS[leg]), :2] / track.pelvis_height
    down = track.foot_contacts[:, LEG_ORDER.index(leg)].astype(bool)
    moves = np.diff(xy, axis=0)
    planted = down[:-1] & down[1:]
    slide = np.linalg.norm(moves[planted], axis=1).sum()
    return float(xy[-1, 0] - xy[0, 0]), float(slide), float(moves[~planted, 0].sum())


def _share_with_a_foot_up(track) -> float:
    """Share of the pelvis's forward travel made in frames where some foot is off the ground."""
    moves = np.diff(_pelvis_hp(track, 0))
    foot_up = ~track.foot_contacts[1:].astype(bool).all(axis=1)
    return float(moves[foot_up].sum() / moves.sum())


# --------------------------------------------------------------------------- leash


def test_a_gentle_leash_pull_walks_the_dog_forward_without_falling():
    figures = _figures("leash", LEASH_SECONDS)
    track = _track("leash", LEASH_SECONDS)
    sideways = _pelvis_hp(track, 1)
    assert figures["forward_hp"] >= LEASH_MIN_FORWARD_HP
    assert not figures["fell"]
    assert figures["pelvis_height_min_hp"] > MIN_PELVIS_HP
    assert np.abs(sideways).max() < MAX_SIDEWAYS_HP


def test_the_leash_walk_is_made_of_steps_of_every_leg():
    track = _track("leash", LEASH_SECONDS)
    steps = _steps(track, LEASH_START_S)
    assert min(steps.values()) >= MIN_LEASH_STEPS, steps
    assert _share_with_a_foot_up(track) >= MIN_TRAVEL_WITH_A_FOOT_UP


def test_the_leashed_dog_carries_its_feet_instead_of_dragging_them():
    track = _track("leash", LEASH_SECONDS)
    pelvis = _pelvis_hp(track, 0)[-1]
    for leg in LEG_ORDER:
        net, slide, in_air = _foot_travel_hp(track, leg)
        assert net >= MIN_FOOT_FOLLOWS * pelvis, leg
        assert slide <= MAX_PLANTED_SLIDE * pelvis, leg
        assert in_air >= MIN_FOOT_TRAVEL_IN_AIR * net, leg


def test_without_a_pull_the_dog_stands_and_does_not_step():
    parameters = (("leash_force", "0 bw"),)
    track = _track("leash", LEASH_SECONDS, parameters)
    assert abs(_figures("leash", LEASH_SECONDS, parameters)["forward_hp"]) < STILL_HP
    assert max(_steps(track, SETTLE_S).values()) == 0


# --------------------------------------------------------------------------- leg by leg


def test_leg_by_leg_pushes_the_dog_forward_and_it_stays_up():
    figures = _figures("leg_by_leg", LEG_BY_LEG_SECONDS)
    assert figures["forward_hp"] >= LEG_BY_LEG_MIN_FORWARD_HP
    assert not figures["fell"]
    assert figures["pelvis_height_min_hp"] > MIN_PELVIS_HP


def test_leg_by_leg_moves_by_steps_with_planted_feet():
    track = _track("leg_by_leg", LEG_BY_LEG_SECONDS)
    pelvis = _pelvis_hp(track, 0)[-1]
    steps = _steps(track, SETTLE_S)
    assert min(steps.values()) >= MIN_LEG_BY_LEG_STEPS, steps
    assert _share_with_a_foot_up(track) >= MIN_TRAVEL_WITH_A_FOOT_UP
    for leg in LEG_ORDER:
        net, slide, in_air = _foot_travel_hp(track, leg)
        assert net >= MIN_FOOT_FOLLOWS * pelvis, leg
        assert slide <= MAX_PLANTED_SLIDE * pelvis, leg
        assert in_air >= MIN_FOOT_TRAVEL_IN_AIR * net, leg


def test_the_push_state_is_what_moves_leg_by_leg():
    parameters = (("push_force", "0 bw"),)
    assert abs(_figures("leg_by_leg", LEG_BY_LEG_SECONDS, parameters)["forward_hp"]) < STILL_HP
    assert max(_steps(_track("leg_by_leg", LEG_BY_LEG_SECONDS, parameters), SETTLE_S).values()) == 0


@pytest.mark.parametrize("leg", LEG_ORDER)
def test_only_supporting_legs_push(leg: str):
    """A swinging leg's push is off, so it does not drive its own foot backward."""
    from quadpipe.controllers.language import load_controller

    machine = load_controller("leg_by_leg").machines["gait"]
    assert f"{leg}_stance_push" in machine.owned
    for state in (f"{leg}_seek", f"{leg}_land"):
        assert machine.states[state].elements[f"{leg}_stance_push"].enabled is False
    assert all(
        f"{leg}_stance_push" not in machine.states[state].elements
        for state in machine.states
        if not state.startswith(leg)
    )
