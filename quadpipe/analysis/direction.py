"""How well a directed animal played its shot: path error, arrival times, speeds and stands.

A clip baked with a direction carries its timelines in its metadata (`DIRECTION_KEY`, see
`quadpipe.world.timeline`). `direction_reports` follows each directed animal's pelvis along the path
(its projection, searched near the last one, so that a figure-eight's crossing does not
jump branches) and measures, per beat: for a move, when the pelvis reached its end against
when it was asked to, its mean speed against the asked one and its lateral error; for a
stand, whether all four feet are down and the pelvis still once it has settled.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from quadpipe.anatomy import roles
from quadpipe.clip.model import AnimalTrack, Clip
from quadpipe.world.timeline import DIRECTION_KEY, Segment, Timeline, timelines_from_json

GRAVITY = 9.80665
"""Standard gravity, m/s^2 (natural time sqrt(HP / g))."""

SETTLE_NATURAL = 2.0
"""A stand is measured from this many natural times after it starts (it settles first)."""

REACHED_HP = 0.1
"""A mark on the path counts as reached within this distance of it, pelvis heights (an animal
that brakes for a stop stands about there)."""

BACKWARD_COST = 0.5
"""Metres of distance from the path a place behind the last one costs per metre back: where
the path doubles back over itself (a hairpin after a turn), the place further along wins."""

SEARCH_BEHIND_HP = 1.0
SEARCH_AHEAD_HP = 3.0
"""The pelvis's place on the path is searched this far behind and ahead of its last one, HP."""


@dataclass(frozen=True)
class BeatFigures:
    """One beat as played.

    Attributes:
        kind: `move`, `hold` or `stop` (`end` for the stand after the last beat).
        beat: its index among the beats (-1 for `end`).
        asked_start_s, asked_end_s: when it was asked to start and end.
        arrival_s: a move: when the pelvis reached its end, within `REACHED_HP` (None: never).
        arrival_error_s: a move: arrival_s - asked_end_s.
        asked_speed_hp: a move: the asked speed, HP per natural time.
        speed_error: a move: its mean speed / asked - 1, its mean speed being its length over
            the time from when the pelvis reached its start (or when the move was asked to
            start, if later: a move after a stand) to its arrival.
        strides: a move: its length in Alexander strides at the asked speed (2.3 Fr^0.3 HP).
        lateral_rms_hp: a move: RMS distance of the pelvis from the path while on it, HP.
        feet_down: a stand: fraction of its settled frames with all four feet down.
        still_speed_hp: a stand: highest pelvis speed over its settled frames, HP per natural time.
        stand_error_hp: a stand: how far past its mark on the path the pelvis stands (negative:
            short of it), mean over its settled frames, HP.
        asked_turn_deg, turned_deg: a turn: the angle asked for, and how far the trunk
            (pelvis to thorax) turned from its start to its end, degrees counter-clockwise.
        drift_hp: a turn: how far from its mark the pelvis is at its end, HP.
    """

    kind: str
    beat: int
    asked_start_s: float
    asked_end_s: float
    arrival_s: float | None = None
    arrival_error_s: float | None = None
    asked_speed_hp: float | None = None
    speed_error: float | None = None
    strides: float | None = None
    lateral_rms_hp: float | None = None
    feet_down: float | None = None
    still_speed_hp: float | None = None
    stand_error_hp: float | None = None
    asked_turn_deg: float | None = None
    turned_deg: float | None = None
    drift_hp: float | None = None


@dataclass(frozen=True)
class DirectionReport:
    """A directed animal's shot as played: its beats, and the shot's own figures.

    Attributes:
        animal: the directed animal's name.
        shot_s: when the last beat was asked to end.
        beats: per beat, in order, then the final stand (`end`).
        lateral_rms_hp: RMS lateral error over every move after the first, HP (None: no such move).
    """

    animal: str
    shot_s: float
    beats: tuple[BeatFigures, ...]
    lateral_rms_hp: float | None

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready."""
        return asdict(self)


def direction_reports(clip: Clip) -> tuple[DirectionReport, ...]:
    """The direction report of each directed animal of a clip (none without a direction)."""
    if DIRECTION_KEY not in clip.metadata:
        return ()
    tracks = {track.name: track for track in clip.animals}
    timelines = timelines_from_json(clip.metadata[DIRECTION_KEY])
    return tuple(_report(clip, tracks[name], timeline) for name, timeline in timelines.items() if name in tracks)


def _report(clip: Clip, track: AnimalTrack, timeline: Timeline) -> DirectionReport:
    """One directed animal's report."""
    hp = track.pelvis_height
    natural = math.sqrt(hp / GRAVITY)
    pelvis = track.positions[:, roles.ROLES.index("pelvis"), :2]
    times = np.arange(len(pelvis)) / clip.fps
    along, aside = follow(timeline, pelvis, hp)
    thorax = track.positions[:, roles.ROLES.index("thorax"), :2]
    measure = _Measure(timeline, times, along, aside, pelvis, thorax, track.foot_contacts, hp, natural)
    final = timeline.segments[-1].s1 if timeline.segments else 0.0
    stands = [Segment("end", -1, timeline.end, math.inf, final, final, 0.0)]
    beats = tuple(measure.beat(segment) for segment in [*timeline.segments, *stands])
    later = [k for k, seg in enumerate(timeline.segments) if seg.kind == "move"][1:]
    errors = np.concatenate([measure.lateral(timeline.segments[k]) for k in later]) if later else np.array([])
    rms = float(np.sqrt(np.mean(errors**2)) / hp) if len(errors) else None
    return DirectionReport(track.name, timeline.end, beats, rms)


def follow(timeline: Timeline, pelvis: np.ndarray, hp: float) -> tuple[np.ndarray, np.ndarray]:
    """The pelvis's distance along the path and its distance from it, per frame (metres).

    Each frame's place is the nearest point of the path within `SEARCH_BEHIND_HP` behind and
    `SEARCH_AHEAD_HP` ahead of the last frame's place, places behind it counting as further
    (`BACKWARD_COST`).
    """
    points, lengths = timeline.points, timeline.lengths
    starts, pieces = points[:-1], np.diff(points, axis=0)
    piece_lengths = np.maximum(np.linalg.norm(pieces, axis=1), 1e-12)
    along, aside = np.zeros(len(pelvis)), np.zeros(len(pelvis))
    last = 0.0
    for frame, where in enumerate(pelvis):
        fraction = np.clip(np.einsum("ij,ij->i", where - starts, pieces) / piece_lengths**2, 0, 1)
        nearest = starts + fraction[:, None] * pieces
        distance = np.linalg.norm(where - nearest, axis=1)
        place = lengths[:-1] + fraction * piece_lengths
        near = (place >= last - SEARCH_BEHIND_HP * hp) & (place <= last + SEARCH_AHEAD_HP * hp)
        cost = distance + BACKWARD_COST * np.maximum(last - place, 0.0)
        best = int(np.argmin(np.where(near, cost, np.inf))) if near.any() else int(np.argmin(distance))
        along[frame], aside[frame] = place[best], distance[best]
        last = along[frame]
    return along, aside


@dataclass
class _Measure:
    """What measuring the beats shares: the clip's frames and the pelvis's place on the path."""

    timeline: Timeline
    times: np.ndarray
    along: np.ndarray
    aside: np.ndarray
    pelvis: np.ndarray
    thorax: np.ndarray
    contacts: np.ndarray
    hp: float
    natural: float

    def reached(self, distance: float) -> float | None:
        """When the pelvis first came within `REACHED_HP` of `distance` along the path (None: never)."""
        done = np.nonzero(self.along >= distance - REACHED_HP * self.hp)[0]
        return float(self.times[done[0]]) if len(done) else None

    def lateral(self, segment: Segment) -> np.ndarray:
        """The pelvis's distances from the path while it was on a move's stretch, metres."""
        return self.aside[(self.along > segment.s0) & (self.along < segment.s1)]

    def beat(self, segment: Segment) -> BeatFigures:
        """One beat's figures (see `BeatFigures`)."""
        if segment.kind == "move":
            return self._move(segment)
        if segment.kind == "turn":
            return self._turn(segment)
        return self._stand(segment)

    def _turn(self, segment: Segment) -> BeatFigures:
        last = len(self.times) - 1
        start, end = (min(int(round(when * self.fps)), last) for when in (segment.start, segment.end))
        trunk = self.thorax - self.pelvis
        yaw = np.unwrap(np.arctan2(trunk[start : end + 1, 1], trunk[start : end + 1, 0]))
        mark = self.timeline.point_at(np.array([segment.s0]))[0]
        return BeatFigures(
            segment.kind,
            segment.beat,
            segment.start,
            segment.end,
            asked_turn_deg=math.degrees(segment.turn),
            turned_deg=float(np.degrees(yaw[-1] - yaw[0])),
            drift_hp=float(np.linalg.norm(self.pelvis[end] - mark) / self.hp),
        )

    @property
    def fps(self) -> float:
        """Frames per second of the clip."""
        return 1.0 / float(self.times[1] - self.times[0]) if len(self.times) > 1 else 1.0

    def _move(self, segment: Segment) -> BeatFigures:
        reached, arrival = self.reached(segment.s0), self.reached(segment.s1)
        start = None if reached is None else max(reached, segment.start)
        asked = segment.speed * self.natural / self.hp
        froude = segment.speed**2 / (GRAVITY * self.hp)
        strides = (segment.s1 - segment.s0) / (2.3 * froude**0.3 * self.hp)
        speed_error = None
        if start is not None and arrival is not None and arrival > start:
            speed_error = (segment.s1 - segment.s0) / (arrival - start) / segment.speed - 1
        lateral = self.lateral(segment)
        return BeatFigures(
            segment.kind,
            segment.beat,
            segment.start,
            segment.end,
            arrival,
            None if arrival is None else arrival - segment.end,
            asked,
            speed_error,
            strides,
            float(np.sqrt(np.mean(lateral**2)) / self.hp) if len(lateral) else None,
        )

    def _stand(self, segment: Segment) -> BeatFigures:
        frames = (self.times >= segment.start + SETTLE_NATURAL * self.natural) & (self.times <= segment.end)
        figures = BeatFigures(segment.kind, segment.beat, segment.start, segment.end)
        if frames.sum() < 2:
            return figures
        speeds = np.linalg.norm(np.gradient(self.pelvis, self.times, axis=0), axis=1)[frames]
        feet = self.contacts[frames].all(axis=1)
        return BeatFigures(
            segment.kind,
            segment.beat,
            segment.start,
            segment.end,
            feet_down=float(feet.mean()),
            still_speed_hp=float(speeds.max() * self.natural / self.hp),
            stand_error_hp=float(self._past_mark(frames, segment.s1) / self.hp),
        )

    def _past_mark(self, frames: np.ndarray, mark: float) -> float:
        """How far past `mark` (a distance along the path) the pelvis is over `frames`, on
        average, metres: along the path, or beyond its end along its last piece."""
        points = self.timeline.points
        last = points[-1] - points[-2]
        beyond = np.einsum("ij,j->i", self.pelvis[frames] - points[-1], last / np.linalg.norm(last))
        along = self.along[frames] + np.where(self.along[frames] >= self.timeline.lengths[-1] - 1e-9, beyond, 0.0)
        return float(np.mean(along) - mark)


def format_direction(report: DirectionReport) -> str:
    """The direction report as text for the terminal: a line per beat."""
    lines = [
        f"direction of {report.animal}: shot {report.shot_s:.2f} s, lateral error after the first move "
        f"{_figure(report.lateral_rms_hp, 3)} HP RMS",
        "  beat  kind  asked(s)       arrived(s)  error(% shot)  speed(HP/T)  speed err(%)  lateral(HP)  feet down  still(HP/T)  past mark(HP)",
    ]
    for b in report.beats:
        error = None if b.arrival_error_s is None else 100 * b.arrival_error_s / report.shot_s
        lines.append(
            f"  {b.beat:>4}  {b.kind:<4}  {b.asked_start_s:5.2f}-{b.asked_end_s:<7.2f}  {_figure(b.arrival_s):>10}  "
            f"{_figure(error, 1):>13}  {_figure(b.asked_speed_hp, 3):>11}  "
            f"{_figure(None if b.speed_error is None else 100 * b.speed_error, 1):>12}  "
            f"{_figure(b.lateral_rms_hp, 3):>11}  {_figure(b.feet_down):>9}  {_figure(b.still_speed_hp, 3):>11}  "
            f"{_figure(b.stand_error_hp):>13}"
            + (
                f"  turned {b.turned_deg:.0f} of {b.asked_turn_deg:.0f} deg, {b.drift_hp:.2f} HP from its mark"
                if b.turned_deg is not None and b.asked_turn_deg is not None and b.drift_hp is not None
                else ""
            )
        )
    return "\n".join(lines)


def _figure(value: float | None, digits: int = 2) -> str:
    """A number with `digits` decimals, or `-` when not measured."""
    return "-" if value is None else f"{value:.{digits}f}"
