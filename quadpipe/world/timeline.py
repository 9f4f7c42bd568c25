"""A direction played out in time: where the animal should be, how fast, and when it stands.

`plan_direction` turns one animal's path and beats (evaluated, SI) into a `Timeline`: the
path as a dense polyline (a Catmull-Rom spline sampled, or the points themselves), the
distance along it as a piecewise-linear function of time (`knots`), the asked speed per
interval, and the intervals the animal stands. `quadpipe.world.goals.direction_parameters`
writes it as controller-language text for `direct` (configs/controllers/direct.yaml), and
`analyze` reads it back from the clip's metadata to measure the shot.
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from quadpipe.core.errors import Issue, Location
from quadpipe.quantities.units import STANDARD_GRAVITY

DIRECTION_KEY = "direction"
"""The clip metadata key holding the directed animals' timelines (`timelines_json`)."""

SPLINE_SAMPLES = 6
"""Straight pieces a smooth path has between two of its points."""

STOP_TIME_NATURAL = 2.0
"""How long a `stop` that is not the last beat stands, in natural times (it settles in that time)."""


@dataclass(frozen=True)
class Segment:
    """One beat played out: from `start` to `end` (seconds), the distance along the path
    going from `s0` to `s1` (metres) at `speed` (m/s; 0 while standing).

    Attributes:
        kind: `move`, `hold` or `stop`.
        beat: the beat's index in the file.
        point: the path point a move ends at (-1 for a stand).
        gait: the gait a move asks for (`auto`, `walk`, `trot`, `gallop`; `auto` for a stand).
        look: the point the head turns to during the beat, [x, y, z] metres (None: ahead).
        turn: a turn's angle, radians counter-clockwise (0 for other beats).
        pose: a hold's pose: `stand`, `sit` or `lie` (`stand` for other beats).
        timed: whether a move was asked to arrive at a time (its speed may not change).
    """

    kind: str
    beat: int
    start: float
    end: float
    s0: float
    s1: float
    speed: float
    point: int = -1
    gait: str = "auto"
    look: list[float] | None = None
    turn: float = 0.0
    pose: str = "stand"
    timed: bool = False


@dataclass
class Timeline:
    """One animal's direction in time (metres, seconds).

    Attributes:
        points: the path's dense polyline, (n, 2) metres.
        segments: the beats played out, in order.
        final_stop: whether the animal stands after the last segment (always, today).
    """

    points: np.ndarray
    segments: list[Segment] = field(default_factory=list)

    @property
    def lengths(self) -> np.ndarray:
        """Distance along the path at each point of `points`, metres."""
        steps = np.linalg.norm(np.diff(self.points, axis=0), axis=1)
        return np.concatenate([[0.0], np.cumsum(steps)])

    @property
    def end(self) -> float:
        """When the last beat ends, seconds."""
        return self.segments[-1].end if self.segments else 0.0

    def knots(self) -> list[tuple[float, float]]:
        """The distance along the path in time: (time, distance) corners of a piecewise-linear function."""
        corners = [(0.0, 0.0)]
        for segment in self.segments:
            if segment.end > corners[-1][0]:
                corners.append((segment.end, segment.s1))
        return corners

    def distance_at(self, times: np.ndarray) -> np.ndarray:
        """Where the reference is along the path at `times`, metres."""
        t, s = zip(*self.knots())
        return np.interp(times, t, s)

    def point_at(self, distance: np.ndarray) -> np.ndarray:
        """Points of the path at distances along it (clamped to its ends), (n, 2) metres."""
        lengths = self.lengths
        return np.stack([np.interp(distance, lengths, self.points[:, k]) for k in range(2)], axis=-1)

    def heading_at(self, distance: float) -> np.ndarray:
        """The unit direction of the path's piece that arrives at `distance` (the first's at 0)."""
        lengths = self.lengths
        piece = int(np.clip(np.searchsorted(lengths, distance, side="left") - 1, 0, len(lengths) - 2))
        step = self.points[piece + 1] - self.points[piece]
        return step / max(float(np.linalg.norm(step)), 1e-12)

    def stands(self) -> list[tuple[float, float]]:
        """The intervals the animal stands still, (start, end) seconds (the last one ends at infinity)."""
        spans = [(seg.start, seg.end) for seg in self.segments if seg.kind in ("hold", "stop")]
        return spans + [(self.end, math.inf)]

    def to_dict(self) -> dict[str, Any]:
        """The timeline as JSON-ready data."""
        return {"points": self.points.tolist(), "segments": [asdict(s) for s in self.segments]}

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Timeline:
        """The timeline of `to_dict`'s data."""
        return cls(np.array(data["points"], dtype=float).reshape(-1, 2), [Segment(**s) for s in data["segments"]])


def timelines_json(timelines: dict[str, Timeline]) -> str:
    """Animals' timelines as JSON text, for a clip's metadata (`DIRECTION_KEY`)."""
    return json.dumps({name: timeline.to_dict() for name, timeline in timelines.items()})


def timelines_from_json(text: str) -> dict[str, Timeline]:
    """The timelines a clip's metadata holds (see `timelines_json`)."""
    return {name: Timeline.from_dict(data) for name, data in json.loads(text).items()}


def dense_path(points: np.ndarray, smooth: bool) -> tuple[np.ndarray, list[int]]:
    """The path as a polyline, and the index in it of each of `points` (x, y in metres).

    A smooth path is a uniform Catmull-Rom spline through the points, its ends extended by
    mirroring the neighbouring point, sampled `SPLINE_SAMPLES` times per piece.
    """
    if not smooth or len(points) < 3:
        return points.copy(), list(range(len(points)))
    padded = np.vstack([2 * points[0] - points[1], points, 2 * points[-1] - points[-2]])
    u = np.linspace(0, 1, SPLINE_SAMPLES, endpoint=False)[:, None]
    pieces = []
    for k in range(len(points) - 1):
        p0, p1, p2, p3 = padded[k : k + 4]
        pieces.append(
            0.5 * (2 * p1 + (p2 - p0) * u + (2 * p0 - 5 * p1 + 4 * p2 - p3) * u**2 + (3 * p1 - p0 - 3 * p2 + p3) * u**3)
        )
    dense = np.vstack(pieces + [points[-1:]])
    return dense, [k * SPLINE_SAMPLES for k in range(len(points))]


@dataclass(frozen=True)
class BeatValues:
    """One beat with its values in SI: a move (`point`, `speed` or `arrival`, and `gait`), a
    hold (`hold` seconds), a turn (`turn` radians for `hold` seconds) or a stop (`kind`
    only), and where the head looks (`look`, metres; None: ahead). `where` locates it for
    messages."""

    kind: str
    point: int = 0
    speed: float | None = None
    arrival: float | None = None
    hold: float = 0.0
    gait: str = "auto"
    look: list[float] | None = None
    turn: float = 0.0
    pose: str = "stand"
    where: tuple[Any, ...] = ()


def plan_direction(
    points: np.ndarray,
    smooth: bool,
    beats: Sequence[BeatValues],
    natural_time: float,
    locate: Callable[[tuple[Any, ...]], Location],
) -> tuple[Timeline, list[Issue]]:
    """Play a direction's beats along its path.

    Args:
        points: the path's points, (n, 2) metres.
        smooth: whether the path is a spline through them.
        beats: the beats, in SI.
        natural_time: the animal's sqrt(HP / g), seconds (the length of a `stop`).
        locate: where a value of the file is, from its path (`BeatValues.where` + key).

    Returns:
        the timeline, and the problems found (a move to a point behind the animal or past
        the path's end, an arrival no later than the beat's start), each at its value.
    """
    dense, marks = dense_path(points, smooth)
    timeline = Timeline(dense)
    lengths = timeline.lengths
    issues: list[Issue] = []
    now, at_point, distance = 0.0, 0, 0.0
    for index, beat in enumerate(beats):
        if beat.kind == "move":
            if not at_point < beat.point < len(points):
                issues.append(_bad_point(beat, at_point, len(points), locate(beat.where + ("to",))))
                continue
            target = float(lengths[marks[beat.point]])
            if beat.arrival is not None and beat.arrival <= now:
                issues.append(
                    Issue(
                        "direction-too-soon",
                        f"the move to point {beat.point} arrives at {beat.arrival:g} s, no later than it starts ({now:.3g} s)",
                        locate(beat.where + ("at",)),
                        "give a later `at`, or a `speed`",
                    )
                )
                continue
            speed = (target - distance) / (beat.arrival - now) if beat.arrival is not None else float(beat.speed or 0)
            end = now + (target - distance) / speed
            timeline.segments.append(
                Segment(
                    "move",
                    index,
                    now,
                    end,
                    distance,
                    target,
                    speed,
                    beat.point,
                    beat.gait,
                    beat.look,
                    timed=beat.arrival is not None,
                )
            )
            now, at_point, distance = end, beat.point, target
        else:
            length = beat.hold if beat.kind in ("hold", "turn") else STOP_TIME_NATURAL * natural_time
            timeline.segments.append(
                Segment(
                    beat.kind,
                    index,
                    now,
                    now + length,
                    distance,
                    distance,
                    0.0,
                    look=beat.look,
                    turn=beat.turn,
                    pose=beat.pose,
                )
            )
            now += length
    return timeline, issues


def _bad_point(beat: BeatValues, at_point: int, count: int, where: Location) -> Issue:
    """The issue of a move to a point behind the animal or past the path's end."""
    if beat.point >= count:
        message = f"the path has {count} points (0 to {count - 1}): there is no point {beat.point}"
    else:
        message = f"the animal is at point {at_point} here: a move goes forward along the path, to a later point"
    return Issue("direction-bad-point", message, where, f"use a point from {at_point + 1} to {count - 1}")


WALK_BEND_BODY_LENGTHS = 0.5
"""The tightest bend an animal follows at a walk, as a radius in body lengths (pelvis to the
tip of the head, in the rest pose): the dog and the horse (1.5 HP long) walk the
figure-eight's bends (0.77 HP radius, 1.0 HP as `tight_bends` measures it on the path's
polyline) within 0.3 HP of the path."""

LATERAL_GRIP = 0.3
"""The sideways acceleration an animal turns with at speed, in g: a bend's radius is at
least speed² / (LATERAL_GRIP g), i.e. Fr / 0.3 pelvis heights (2 HP at a trot, Fr 0.6;
8 HP at a gallop, Fr 2.5)."""


@dataclass(frozen=True)
class Bend:
    """A bend of a path tighter than the animal can follow at its speed there.

    Attributes:
        at: where it is, [x, y] metres.
        radius: the path's radius there, metres.
        least: the tightest radius the animal follows at that speed, metres.
        speed: the asked speed there, m/s.
    """

    at: np.ndarray
    radius: float
    least: float
    speed: float


def least_radius(speed: float, body_length: float) -> float:
    """The tightest bend, in metres, an animal `body_length` metres long follows at `speed`
    (m/s): a body length at a walk (`WALK_BEND_BODY_LENGTHS`), more as the sideways grip it
    needs grows with the speed (`LATERAL_GRIP`)."""
    return max(WALK_BEND_BODY_LENGTHS * body_length, speed**2 / (LATERAL_GRIP * STANDARD_GRAVITY))


def tight_bends(timeline: Timeline, body_length: float) -> list[Bend]:
    """The bends of a timeline's path, where the animal moves through them, tighter than it
    can follow (`least_radius`): the tightest of each run of such corners of the polyline.

    A corner's radius is that of the arc turning through its angle over the mean of its two
    pieces: a smooth path's curvature, and for a straight-sided path the roundest cut an
    animal could make through its corner. A corner the animal reaches standing (a move's end
    followed by a hold, a stop or a turn) is not a bend it follows.
    """
    tight: list[Bend] = []
    run: list[Bend] = []
    for k in range(1, len(timeline.points) - 1):
        bend = _tight_corner(timeline, k, body_length)
        if bend is not None:
            run.append(bend)
        if run and (bend is None or k == len(timeline.points) - 2):
            tight.append(min(run, key=lambda item: item.radius))
            run = []
    return tight


def _tight_corner(timeline: Timeline, k: int, body_length: float) -> Bend | None:
    """Corner `k` of a timeline's polyline as a `Bend`, if the animal moves through it and
    it is tighter than it can follow (see `tight_bends`); None otherwise."""
    speed = speed_through(timeline.segments, float(timeline.lengths[k]))
    radius = corner_radius(timeline.points, k)
    if speed <= 0:
        return None
    least = least_radius(speed, body_length)
    return Bend(timeline.points[k].copy(), radius, least, speed) if radius < least * (1 - BEND_ROUNDING) else None


def corner_radius(points: np.ndarray, k: int) -> float:
    """The radius of corner `k` of a polyline, metres (see `tight_bends`; infinite where it is straight)."""
    before, after = points[k] - points[k - 1], points[k + 1] - points[k]
    angle = abs(math.atan2(float(before[0] * after[1] - before[1] * after[0]), float(np.dot(before, after))))
    return 0.5 * float(np.linalg.norm(before) + np.linalg.norm(after)) / angle if angle > 1e-9 else math.inf


BEND_ROUNDING = 1e-9
"""A corner counts as tighter than the animal follows when its radius is under the least by
more than this fraction (`bend_speed` gives the least radius back to rounding)."""

BEND_LEAD_NATURAL = 2.0
"""How long before a bend, in natural times at the speed it slows from, an animal slows for
it (the gait takes one or two natural times to change its speed)."""

BEND_EXIT_BODY_LENGTHS = 1.0
"""How far past a bend an animal keeps its slower speed, body lengths (its hind legs are
still in the bend)."""


def bend_speed(radius: float, body_length: float) -> float:
    """The fastest speed, m/s, at which an animal `body_length` metres long follows a bend of
    `radius` metres (`least_radius` inverted; below half a body length, the speed at which it
    follows its tightest bend)."""
    return math.sqrt(LATERAL_GRIP * STANDARD_GRAVITY * max(radius, WALK_BEND_BODY_LENGTHS * body_length))


def slow_for_bends(timeline: Timeline, body_length: float, natural_time: float) -> Timeline:
    """The timeline with its untimed moves slowed for the bends too tight for their speed
    (`least_radius`): from `BEND_LEAD_NATURAL` before each such corner of the polyline to
    `BEND_EXIT_BODY_LENGTHS` past it, the move goes at `bend_speed` (a move split into
    pieces of the same beat). A timed move keeps its speed: its arrival comes first, and
    `tight_bends` warns of its bends."""
    lengths = timeline.lengths
    corners = [(float(lengths[k]), corner_radius(timeline.points, k)) for k in range(1, len(lengths) - 1)]
    segments: list[Segment] = []
    for segment in timeline.segments:
        now = segments[-1].end if segments else 0.0
        slow = []
        if segment.kind == "move" and not segment.timed:
            lead, past = BEND_LEAD_NATURAL * natural_time * segment.speed, BEND_EXIT_BODY_LENGTHS * body_length
            tight = [
                (at, radius)
                for at, radius in corners
                if segment.s0 < at < segment.s1 and radius < least_radius(segment.speed, body_length)
            ]
            slow = [
                (run[0][0] - lead, run[-1][0] + past, bend_speed(min(r for _, r in run), body_length))
                for run in _runs(tight, lead + past)
            ]
        if slow:
            for s0, s1, speed in _speed_pieces(segment.s0, segment.s1, segment.speed, slow):
                end = now + (s1 - s0) / speed
                segments.append(dataclasses.replace(segment, start=now, end=end, s0=s0, s1=s1, speed=speed))
                now = end
        elif now == segment.start:
            segments.append(segment)
        elif segment.timed and segment.end > now:
            speed = (segment.s1 - segment.s0) / (segment.end - now)
            segments.append(dataclasses.replace(segment, start=now, speed=speed))
        else:
            segments.append(dataclasses.replace(segment, start=now, end=now + segment.end - segment.start))
    return Timeline(timeline.points, segments)


def _runs(corners: Sequence[tuple[float, float]], gap: float) -> list[list[tuple[float, float]]]:
    """Corners (distance along the path, radius) grouped into runs, a run ending where the
    next corner is more than `gap` metres further along."""
    runs: list[list[tuple[float, float]]] = []
    for corner in corners:
        if runs and corner[0] - runs[-1][-1][0] <= gap:
            runs[-1].append(corner)
        else:
            runs.append([corner])
    return runs


def _speed_pieces(
    s0: float, s1: float, speed: float, slow: Sequence[tuple[float, float, float]]
) -> list[tuple[float, float, float]]:
    """A move from `s0` to `s1` metres at `speed` as pieces (from, to, speed), slower on the
    stretches `slow` (from, to, speed) that overlap it: each piece at the slowest speed
    asked over it, neighbours at the same speed merged."""
    cuts = sorted({s0, s1} | {min(max(edge, s0), s1) for start, stop, _ in slow for edge in (start, stop)})
    pieces: list[tuple[float, float, float]] = []
    for start, stop in zip(cuts, cuts[1:]):
        middle = (start + stop) / 2
        wanted = min([speed] + [v for a, b, v in slow if a <= middle <= b])
        if pieces and pieces[-1][2] == wanted:
            pieces[-1] = (pieces[-1][0], stop, wanted)
        elif stop > start:
            pieces.append((start, stop, wanted))
    return pieces


def speed_through(segments: Sequence[Segment], distance: float) -> float:
    """The asked speed of a move passing `distance` along the path (the faster of two moves
    that meet there), 0 where no move passes it."""
    speeds = [
        seg.speed
        for k, seg in enumerate(segments)
        if seg.kind == "move"
        and (
            seg.s0 < distance < seg.s1
            or (distance == seg.s1 and k + 1 < len(segments) and segments[k + 1].kind == "move")
        )
    ]
    return max(speeds, default=0.0)


def follower_timeline(leader: Timeline, behind: float, aside: float) -> Timeline:
    """The timeline of an animal following `leader`: the same beats at the same times, on
    its path moved `behind` metres back along it (the path extended straight back from its
    start) and `aside` metres to its left (each point moved along the mean of its pieces'
    left normals)."""
    points = leader.points
    first = _unit(points[1] - points[0])
    extended = np.vstack([points[0] - behind * first, points]) if behind > 0 else points.copy()
    pieces = np.array([_unit(piece) for piece in np.diff(extended, axis=0)])
    normals = np.column_stack([-pieces[:, 1], pieces[:, 0]])
    at_points = np.vstack([normals[:1], normals[:-1] + normals[1:], normals[-1:]])
    at_points = np.array([_unit(normal) for normal in at_points])
    return Timeline(extended + aside * at_points, list(leader.segments))


def _unit(vector: np.ndarray) -> np.ndarray:
    """A vector scaled to length 1 (itself when it is zero)."""
    length = float(np.linalg.norm(vector))
    return vector / length if length > 0 else vector
