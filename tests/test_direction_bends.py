"""Directions (#16) round bends: the look-ahead and turning radius at walk and trot, slowing
for a bend too tight for the asked speed, and turning in place on every animal."""

from __future__ import annotations

import functools
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from quadpipe.analysis.direction import direction_reports, format_direction
from quadpipe.clip.model import Clip
from quadpipe.core.configs import available
from quadpipe.core.errors import Location
from quadpipe.world.timeline import (
    BeatValues,
    bend_speed,
    plan_direction,
    slow_for_bends,
    tight_bends,
)

GRAVITY = 9.80665
RADIUS_HP = 0.3
"""A circle's pelvis track: its mean radius within this of the asked one, pelvis heights (the
issue's lateral error)."""

LATERAL_HP = 0.3
"""Round a bend: RMS distance of the pelvis from the path, pelvis heights."""

IN_PLACE_DEG = 10.0
IN_PLACE_HP = 0.3
"""A turn in place (issue #16): turned the asked angle within `IN_PLACE_DEG`, the pelvis
never further than `IN_PLACE_HP` from its mark."""


def nowhere(path: tuple) -> Location:
    return Location()


def circle(radius_hp: float, degrees: float = 270.0, step: float = 15.0) -> list[list]:
    """Points of a circle of `radius_hp` HP from the origin heading +x, turning left, every `step` degrees."""
    turns = np.radians(np.arange(0.0, degrees + step / 2, step))
    return [[f"{radius_hp * math.sin(a):.5f} HP", f"{radius_hp * (1 - math.cos(a)):.5f} HP", 0] for a in turns]


@functools.cache
def played(animal: str, body_text: str, folder: Path) -> tuple:
    """A direction (YAML text of one animal's body) simulated under `direct` to its end: the
    clip, its timeline and the build's warnings (once per session); no animal may fall."""
    from quadpipe.sim.simulation import Simulation, simulate

    path = folder / f"{animal}_{abs(hash(body_text))}.direction.yaml"
    path.write_text(yaml.safe_dump({"schema": 1, "direction": {animal: yaml.safe_load(body_text)}}))
    build = Simulation.build(animal, None, direction=path)
    (timeline,) = build.setup.timelines.values()
    result = simulate(animal, "direct", seconds=timeline.end, direction=path)
    assert not any(figures["fell"] for figures in result.metrics["animals"].values()), f"{animal} fell"
    return result.clip, timeline, build.warnings


def pelvis_hp(clip: Clip) -> np.ndarray:
    """The pelvis's (x, y) track in pelvis heights."""
    from quadpipe.anatomy import roles

    track = clip.animals[0]
    return track.positions[:, roles.ROLES.index("pelvis"), :2] / track.pelvis_height


# --------------------------------------------------------------------------- the speed plan


def test_an_untimed_move_slows_for_a_bend_too_tight_for_its_speed_and_a_timed_one_does_not() -> None:
    hp, body = 0.5, 0.75
    natural = math.sqrt(hp / GRAVITY)
    radius = 0.5
    turn = np.radians(np.arange(0, 181, 15))
    bend = radius * np.column_stack([np.sin(turn), 1 - np.cos(turn)])
    points = np.vstack([[[-3.0, 0.0]], bend, [[-3.0, 2 * radius]]])
    last = len(points) - 1
    trot = math.sqrt(0.6 * GRAVITY * hp)
    untimed, _ = plan_direction(points, False, [BeatValues("move", last, speed=trot)], natural, nowhere)
    assert len(tight_bends(untimed, body)) == 1, "a bend of 1 HP is too tight at a trot (2 HP)"
    slowed = slow_for_bends(untimed, body, natural)
    assert tight_bends(slowed, body) == []
    assert [seg.beat for seg in slowed.segments] == [0, 0, 0]
    fast, slow, again = (seg.speed for seg in slowed.segments)
    assert fast == again == trot and slow == pytest.approx(bend_speed(radius, body), rel=0.05) and slow < trot
    assert slowed.segments[-1].s1 == untimed.segments[-1].s1 and slowed.end > untimed.end
    timed, _ = plan_direction(points, False, [BeatValues("move", last, arrival=untimed.end)], natural, nowhere)
    assert slow_for_bends(timed, body, natural).segments == timed.segments, "an arrival time keeps its speed"
    assert len(tight_bends(timed, body)) == 1, "and is warned of"


def test_a_path_without_tight_bends_plays_as_planned() -> None:
    points = np.array([[0.0, 0.0], [3.0, 3.0], [6.0, 0.0]])
    beats = [BeatValues("move", 1, speed=1.0), BeatValues("hold", hold=1.0), BeatValues("move", 2, arrival=9.0)]
    timeline, _ = plan_direction(points, True, beats, 0.25, nowhere)
    assert slow_for_bends(timeline, 0.75, 0.25).segments == timeline.segments


# --------------------------------------------------------------------------- shots played

CIRCLES = [
    ("dog", 0.15, 1.5),
    ("dog", 0.6, 3.0),
    ("horse", 0.15, 1.5),
    ("horse", 0.6, 3.0),
    ("rat", 0.15, 1.5),
    ("elephant", 0.6, 3.0),
]
"""(animal, Froude number, radius HP): three quarters of a circle (a polyline, a corner every
15 degrees) at a walk and at a trot, wider than the tightest bend of each (0.75, 2 HP; the
rat's walk, 1.7 HP, is tighter than its tightest)."""


@pytest.mark.slow
@pytest.mark.parametrize(("animal", "froude", "radius"), CIRCLES)
def test_the_animal_turns_at_the_radius_asked(
    tmp_path_factory: pytest.TempPathFactory, animal: str, froude: float, radius: float
) -> None:
    points = circle(radius)
    body = {"path": {"points": points}, "beats": [{"to": len(points) - 1, "froude": froude}]}
    clip, timeline, _ = played(animal, yaml.safe_dump(body), tmp_path_factory.getbasetemp())
    (move,) = timeline.segments
    times = np.arange(len(clip.animals[0].positions)) / clip.fps
    settled = (times > move.start + (move.end - move.start) / 4) & (times < move.end)
    measured = np.linalg.norm(pelvis_hp(clip)[settled] - [0.0, radius], axis=1).mean()
    assert abs(measured - radius) <= RADIUS_HP, f"turned at {measured:.2f} HP, asked {radius} HP"


def hairpin(radius_hp: float) -> list[list]:
    """A straight 4 HP along +x, a half circle of `radius_hp` HP to the left, 4 HP back."""
    half = np.radians(np.arange(15.0, 180.0, 15.0))
    bend = [[4 + radius_hp * math.sin(a), radius_hp * (1 - math.cos(a))] for a in half]
    corners = [[0.0, 0.0], [4.0, 0.0], *bend, [4.0, 2 * radius_hp], [0.0, 2 * radius_hp]]
    return [[f"{x:.5f} HP", f"{y:.5f} HP", 0] for x, y in corners]


@pytest.mark.slow
def test_an_untimed_trot_slows_for_a_tight_bend_and_follows_it(tmp_path_factory: pytest.TempPathFactory) -> None:
    points = hairpin(1.0)
    body = {"path": {"points": points}, "beats": [{"to": len(points) - 1, "froude": 0.6}]}
    clip, timeline, warnings = played("dog", yaml.safe_dump(body), tmp_path_factory.getbasetemp())
    assert warnings == [], "the bend (1 HP, the trot's tightest is 2 HP) is slowed for, not warned of"
    assert min(seg.speed for seg in timeline.segments) < max(seg.speed for seg in timeline.segments)
    (report,) = direction_reports(clip)
    lateral = [b.lateral_rms_hp for b in report.beats if b.kind == "move" and b.lateral_rms_hp is not None]
    assert max(lateral) <= LATERAL_HP, format_direction(report)


TURN_NATURAL = 12.0
"""A turn in place lasts this many natural times (3 s for the dog, as in the issue's shot)."""


def turn_in_place(animal: str) -> dict:
    """A direction that stands, turns 180 degrees in place, and stands."""
    from quadpipe.animals.library import load_animal

    natural = math.sqrt(load_animal(animal).pelvis_height / GRAVITY)
    return {
        "path": {"points": [[0, 0, 0], ["2 HP", 0, 0]]},
        "beats": [{"hold": f"{2 * natural:.4f} s"}, {"turn": "180 deg", "for": f"{TURN_NATURAL * natural:.4f} s"}],
    }


@pytest.mark.slow
@pytest.mark.parametrize("animal", available("animals"))
def test_every_animal_turns_in_place(tmp_path_factory: pytest.TempPathFactory, animal: str) -> None:
    clip, _, _ = played(animal, yaml.safe_dump(turn_in_place(animal)), tmp_path_factory.getbasetemp())
    (report,) = direction_reports(clip)
    turn = next(b for b in report.beats if b.kind == "turn")
    assert turn.turned_deg is not None and turn.asked_turn_deg is not None and turn.drift_hp is not None
    assert abs(turn.turned_deg - turn.asked_turn_deg) <= IN_PLACE_DEG, format_direction(report)
    assert turn.drift_hp <= IN_PLACE_HP, format_direction(report)
