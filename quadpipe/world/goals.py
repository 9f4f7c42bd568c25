"""Goals: controller parameters a scene sets, as controller-language text (a fixed point, a
point moving along timed waypoints, or a direction's timeline for `direct`)."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from quadpipe.animals.library import Animal
from quadpipe.core.errors import Location, QuadpipeError
from quadpipe.core.limits import MAX_TABLE_POINTS
from quadpipe.core.yamlio import dotted
from quadpipe.quantities.expressions import TIME_VARIABLE, ExprError, parse
from quadpipe.world.loading import SceneSpec
from quadpipe.world.timeline import Segment, Timeline, speed_through
from quadpipe.world.values import Values


def goal_text(scene: SceneSpec, values: Values, name: str) -> str:
    """A goal of the scene as controller-language text: its point, or its path in time."""
    goal = scene.file.goals[name]
    base = ("goals", name)
    if goal.point is not None:
        return vector_text(values[base + ("point",)])
    assert goal.path is not None, "a goal has a point or a path (`Goal._one_kind`)"
    path = base + ("path",)
    waypoints = [(values[path + (i, 0)], values[path + (i, 1)]) for i in range(len(goal.path))]
    for i, ((before, _), (after, _)) in enumerate(zip(waypoints, waypoints[1:]), start=1):
        if after <= before:
            raise QuadpipeError.single(
                "invalid-value",
                f"{dotted(path + (i, 0))}: the path's times must increase",
                where=scene.locate(path + (i, 0)),
            )
    return goal_expression(waypoints)


def goal_expression(waypoints: Sequence[tuple[float, np.ndarray]], digits: int = 10) -> str:
    """A piecewise-linear point in time as controller-language text (metres, `t` in seconds):
    a table of the waypoints (`interp`), held at the first before its time and at the last
    after its time; the point itself when there is one."""
    if len(waypoints) == 1:
        return vector_text(waypoints[0][1], digits)
    return table_text([when for when, _ in waypoints], [vector_text(point, digits) for _, point in waypoints], digits)


def table_text(times: Sequence[float], values: Sequence[str], digits: int) -> str:
    """A table in time as text: `interp(t, [t0 s, t1 s, ...], [v0, v1, ...])` (times not
    decreasing; a repeated time is a jump)."""
    breakpoints = ", ".join(f"{number_text(when, digits)} s" for when in times)
    return f"interp({TIME_VARIABLE}, [{breakpoints}], [{', '.join(values)}])"


def steps_text(values: Sequence[tuple[float, str]]) -> str:
    """A piecewise-constant value in time as text: the first value, then each next one from its
    time on (a table whose times repeat at each change; the first value when none changes)."""
    changes = [(when, after) for (_, before), (when, after) in zip(values, values[1:]) if after != before]
    if not changes:
        return values[0][1]
    doubled = [value for _, value in changes for _ in range(2)]
    times = [when for when, _ in changes for _ in range(2)]
    return table_text(times, [values[0][1], *doubled[:-1]], DIRECTION_DIGITS)


def balanced_sum(terms: Sequence[str]) -> str:
    """The sum of expression texts, bracketed as a balanced tree: a long path's expression
    nests log2(n) levels deep, not n (see `MAX_EXPRESSION_DEPTH`)."""
    if len(terms) <= 2:
        return " + ".join(terms)
    middle = len(terms) // 2
    return f"({balanced_sum(terms[:middle])}) + ({balanced_sum(terms[middle:])})"


def vector_text(vector: np.ndarray, digits: int = 10) -> str:
    """A point in metres as controller-language text: `[13.1 m, 0 m, 0 m]`."""
    return "[" + ", ".join(f"{number_text(v, digits)} m" for v in vector) + "]"


def number_text(value: float, digits: int = 10) -> str:
    """A number with `digits` significant digits, without `-0`."""
    text = f"{float(value):.{digits}g}"
    return "0" if text == "-0" else text


LOOK_BEYOND_THORAX_HP = 1.9
"""How far beyond its thorax the point an animal steers toward is, pelvis heights (see
`look_ahead`)."""

STAND_RAMP_NATURAL = 1.0
"""How long the gait takes to fade into a stand (and back), natural times."""

STAND_LEAD = 0.75
"""How much of the fade into a stand comes before the stand starts (the animal's arrival at
its mark), as a fraction of `STAND_RAMP_NATURAL`: the animal brakes before its mark."""

FORCED_GAITS = {"walk": (0.0, 0.0), "trot": (1.0, 0.0), "gallop": (1.0, 1.0)}
"""The gaits a move may ask for, as `auto_gait`'s shares: (running gait, gallop)."""

TURN_RAMP_NATURAL = 0.5
"""How long the legs take to start (and stop) stepping round a turn in place, natural times."""

TURN_HANDOVER = 0.01
"""The steering point's handover from a turn's swing to the path after it, as a fraction of
the turn's time (see `_turns_text`)."""

POSE_RAMP_NATURAL = 3.0
"""How long sitting or lying down takes, and getting up again, natural times."""

DIRECTION_DIGITS = 7
"""Significant digits of the numbers of a direction's expressions (a micrometre on a 10 m path)."""


def look_ahead(animal: Animal) -> float:
    """How far along the path ahead of its place an animal steers, metres: from its pelvis
    to its thorax (the steering couple aims the trunk from the thorax) and
    `LOOK_BEYOND_THORAX_HP` beyond; 2.5 HP for the dog, 3.4 HP for the rat, whose long
    trunk (1.5 HP) left it aiming 1 HP ahead of its thorax, weaving round the figure-eight
    (0.42 HP RMS off it; 0.24 HP with this)."""
    skeleton = animal.skeleton
    trunk = float(np.linalg.norm((skeleton["thorax"].start - skeleton["pelvis"].start)[:2]))
    return trunk + LOOK_BEYOND_THORAX_HP * animal.pelvis_height


def direction_parameters(timeline: Timeline, hp: float, natural_time: float, ahead: float) -> dict[str, str]:
    """The controller parameters that play a timeline (see configs/controllers/direct.yaml),
    for an animal `hp` metres high, `natural_time` seconds, steering `ahead` metres along
    the path (`look_ahead`):

    - `path_point`: where the pelvis should be now, on the path;
    - `path_goal`: the point `ahead` further along, which the animal steers toward (during
      a turn, swinging round the turn's mark);
    - `path_tangent`: the path's direction at `path_point` (a unit vector);
    - `path_yaw_rate`: how fast that direction turns as `path_point` goes round the path's
      bends (rad/s, counter-clockwise; see `_yaw_rate_text`);
    - `path_speed`: the asked speed now (0 while standing);
    - `path_stand`: 0 while moving, 1 while standing, a smooth ramp between;
    - `path_arriving`: 1 while the animal stands where a move brought it (a stop, or a hold
      in no pose, right after a move), 0 otherwise;
    - `path_look` and `path_looking`: the point a beat looks at, and 1 while one does (0
      while looking ahead), ramping like a stand;
    - `path_sit` and `path_lie`: 1 while a hold sits (lies), with ramps down and up;
      `path_rising`: 1 while the animal gets up from a pose into standing (over its ramp up);
    - `path_turning` and `path_turn_rate`: 1 while a turn turns in place (0 otherwise), and
      its rate (rad/s, counter-clockwise), each ramping over `TURN_RAMP_NATURAL`;
    - `path_auto`: 1 while the gait follows the speed, 0 while a move asks for one;
      `path_run` and `path_gallop`: the running gait's and the gallop's shares it asks for
      (see `FORCED_GAITS`), each ramping over the same time as a stand.
    """
    ramp = STAND_RAMP_NATURAL * natural_time
    gaits = [(seg.start, FORCED_GAITS.get(seg.gait)) for seg in timeline.segments if seg.kind == "move"]
    shares = [(when, (1.0, 0.0, 0.0) if forced is None else (0.0, *forced)) for when, forced in gaits]
    return {
        "path_point": timed_points_text(timeline, 0.0),
        "path_goal": " + ".join(
            text for text in (timed_points_text(timeline, ahead), _turns_text(timeline, ahead)) if text
        ),
        "path_tangent": _tangent_text(timeline),
        "path_yaw_rate": _yaw_rate_text(timeline),
        "path_speed": _number_steps_text(
            [(seg.start, seg.speed) for seg in timeline.segments] + [(timeline.end, 0.0)], "m/s"
        ),
        "path_stand": _stand_text(timeline.stands(), ramp),
        "path_arriving": _number_steps_text(_arrivals(timeline.segments), ""),
        **_look_texts(timeline.segments, ramp),
        **_pose_texts(timeline.segments, POSE_RAMP_NATURAL * natural_time),
        **_turn_texts(timeline.segments, TURN_RAMP_NATURAL * natural_time),
        **{
            name: _ramps_text([(when, share[k]) for when, share in shares] or [(0.0, float(k == 0))], ramp)
            for k, name in enumerate(("path_auto", "path_run", "path_gallop"))
        },
    }


def check_direction_length(name: str, parameters: dict[str, str], where: Location) -> None:
    """Refuse a direction whose expressions are over the controller language's limits (a
    table's points, the length outside tables), at the direction rather than at the
    expression the controller cannot read (`parse` keeps what it read for the controller).

    Raises:
        QuadpipeError: `limit-exceeded`, naming the expression.
    """
    for key, text in parameters.items():
        try:
            parse(text)
        except ExprError as error:
            if error.code != "limit-exceeded":
                raise
            raise QuadpipeError.single(
                "limit-exceeded",
                f"the direction of {name} is too long to play: in its {key} expression, {error.message}",
                where=where,
                hint="give it fewer beats, or split the shot in two (a path's points are tables of up to "
                f"{MAX_TABLE_POINTS.value:g} points; a smooth path has 6 between two points, its tangent twice that)",
            ) from None


def timed_points_text(timeline: Timeline, ahead: float) -> str:
    """The point `ahead` metres along the path from the reference, in time, as text: a
    corner wherever it passes a point of the polyline, reaches a turn's mark or the
    reference speed changes. Until a turn is done, the point goes on straight past the
    turn's mark (the animal does not cut across to the path after the turn); it moves to the
    path after the turn over the turn's handover (`_handover`), as `_turns_text` hands over
    to it."""
    lengths = timeline.lengths
    turns = [seg for seg in timeline.segments if seg.kind == "turn"]
    marks = np.concatenate([lengths, [seg.s0 for seg in turns]]) - ahead
    times = _passing_times(timeline.knots(), marks) | {timeline.end} | {seg.end + _handover(seg) for seg in turns}
    ordered = np.array(sorted(times))
    return goal_expression(list(zip(ordered, _ahead_points(timeline, turns, ordered, ahead))), DIRECTION_DIGITS)


def _passing_times(knots: Sequence[tuple[float, float]], marks: np.ndarray) -> set[float]:
    """The times of the distance's corners (`Timeline.knots`) and those at which the
    distance passes each of `marks` (metres along the path), seconds."""
    times = {float(when) for when, _ in knots}
    for (t0, s0), (t1, s1) in zip(knots, knots[1:]):
        if s1 > s0:
            inside = marks[(marks > s0) & (marks < s1)]
            times |= set(t0 + (inside - s0) / (s1 - s0) * (t1 - t0))
    return times


def _ahead_points(timeline: Timeline, turns: Sequence[Segment], times: np.ndarray, ahead: float) -> np.ndarray:
    """The points `ahead` metres along the path from the reference at `times`, (k, 3) metres
    with z = 0: straight on past the mark of a turn not yet done (the first such turn; see
    `timed_points_text`), and straight on past the path's end (held on the end, the point
    came back within the trunk of an animal arriving there, and five animals stood turned
    11-26 degrees off the path)."""
    distances = timeline.distance_at(times)
    points = timeline.point_at(distances + ahead)
    end = timeline.lengths[-1]
    beyond = distances + ahead > end
    past_end = (distances[beyond] + ahead - end)[:, None] * timeline.heading_at(end)
    points[beyond] = timeline.point_at(np.array([end]))[0] + past_end
    for turn in reversed(turns):
        before = (times <= turn.end) & (distances + ahead > turn.s0) & (turn.s0 >= distances)
        past = (distances[before] + ahead - turn.s0)[:, None] * timeline.heading_at(turn.s0)
        points[before] = timeline.point_at(np.array([turn.s0]))[0] + past
    return np.column_stack([points, np.zeros(len(points))])


def _turns_text(timeline: Timeline, ahead: float) -> str:
    """What turns add to the steering point: during each turn, the point `ahead` metres
    from the turn's mark swings from straight on to the turn's angle, at a steady rate; after
    it, this hands over to `timed_points_text`'s point on the path over the turn's handover
    (the two change by opposite amounts, so that their sum stays at the turn's angle)."""
    terms = []
    for seg in (seg for seg in timeline.segments if seg.kind == "turn"):
        straight = timeline.heading_at(seg.s0)
        t0, t1 = (number_text(when, DIRECTION_DIGITS) for when in (seg.start, seg.end))
        handover = number_text(_handover(seg), DIRECTION_DIGITS)
        angle = (
            f"({number_text(math.atan2(straight[1], straight[0]), DIRECTION_DIGITS)} rad + "
            f"{number_text(seg.turn, DIRECTION_DIGITS)} rad * clamp(({TIME_VARIABLE} - {t0} s) / "
            f"({number_text(seg.end - seg.start, DIRECTION_DIGITS)} s), 0, 1))"
        )
        length = f"{number_text(ahead, DIRECTION_DIGITS)} m"
        terms.append(
            f"(step({t0} s, {TIME_VARIABLE}) - clamp(({TIME_VARIABLE} - {t1} s) / ({handover} s), 0, 1)) * "
            f"([{length} * cos({angle}), {length} * sin({angle}), 0 m] - "
            f"{vector_text(np.array([*(ahead * straight), 0.0]), DIRECTION_DIGITS)})"
        )
    return balanced_sum(terms)


def _handover(turn: Segment) -> float:
    """How long the steering point takes to hand over from a turn's swing to the path after
    it, seconds (`TURN_HANDOVER` of the turn's time)."""
    return TURN_HANDOVER * (turn.end - turn.start)


def _tangent_text(timeline: Timeline) -> str:
    """The path's unit tangent at the reference point, in time: it turns as the reference
    passes each point of the polyline."""
    lengths, points = timeline.lengths, timeline.points
    pieces = np.diff(points, axis=0)
    units = pieces / np.maximum(np.linalg.norm(pieces, axis=1, keepdims=True), 1e-12)
    knots = timeline.knots()
    knot_t, knot_s = np.array([k[0] for k in knots]), np.array([k[1] for k in knots])
    directions = [(0.0, _plain_vector(units[0]))]
    for k in range(1, len(units)):
        passed = np.nonzero(knot_s >= lengths[k])[0]
        if len(passed) == 0:
            break
        j = passed[0]
        when = knot_t[0] if j == 0 else np.interp(lengths[k], knot_s[j - 1 : j + 1], knot_t[j - 1 : j + 1])
        directions.append((float(when), _plain_vector(units[k])))
    return steps_text(directions)


def _yaw_rate_text(timeline: Timeline) -> str:
    """The path's heading's rate of turn at the reference point, in time (rad/s): each corner
    of the polyline the animal moves through turns the heading steadily from the middle of
    the piece before it to the middle of the piece after it (a corner it reaches standing,
    where a turn in place turns it, none; a piece of no length keeps the heading before it)."""
    points, lengths = timeline.points, timeline.lengths
    if len(points) < 3:
        return "0 rad/s"
    pieces = np.diff(points, axis=0)
    real = np.linalg.norm(pieces, axis=1) > 0
    last_real = np.maximum.accumulate(np.where(real, np.arange(len(pieces)), 0))
    headings = np.unwrap(np.arctan2(pieces[last_real, 1], pieces[last_real, 0]))
    middles = (lengths[:-1] + lengths[1:]) / 2
    moving = np.array([speed_through(timeline.segments, float(s)) > 0 for s in lengths[1:-1]])
    turned = np.concatenate([[0.0], np.cumsum(np.diff(headings) * moving)])
    knots = timeline.knots()
    knot_t, knot_s = np.array([k[0] for k in knots]), np.array([k[1] for k in knots])
    ordered = np.array(sorted(_passing_times(knots, middles)))
    heading = np.interp(np.interp(ordered, knot_t, knot_s), middles, turned)
    rates = np.diff(heading) / np.maximum(np.diff(ordered), 1e-12)
    return _number_steps_text([*zip(ordered[:-1], rates), (float(ordered[-1]), 0.0)], "rad/s")


def _number_steps_text(values: Sequence[tuple[float, float]], unit: str) -> str:
    """A piecewise-constant value in time as text: `values[0]` then a step at each change."""
    return steps_text([(when, f"{number_text(value, DIRECTION_DIGITS)} {unit}") for when, value in values])


def _arrivals(segments: Sequence[Segment]) -> list[tuple[float, float]]:
    """From each beat's start, 1 for a stand that ends a move (a stop, or a hold in no pose,
    right after a move: the animal should stand on the move's mark), 0 for the others."""
    values = [(0.0, 0.0)]
    for before, seg in zip(segments, segments[1:]):
        ends_a_move = before.kind == "move" and seg.kind in ("hold", "stop") and seg.pose == "stand"
        values.append((seg.start, float(ends_a_move)))
    return values


def _stand_text(stands: Sequence[tuple[float, float]], ramp: float) -> str:
    """1 while standing, 0 while moving: a smooth ramp of `ramp` seconds into each stand
    (`STAND_LEAD` of it before the stand starts) and out of it after it ends."""
    terms = ["0"]
    for start, end in stands:
        begin = start - STAND_LEAD * ramp
        terms.append(
            f"smoothstep({number_text(begin, DIRECTION_DIGITS)} s, {number_text(begin + ramp, DIRECTION_DIGITS)} s, {TIME_VARIABLE})"
        )
        if np.isfinite(end):
            terms.append(
                f"-smoothstep({number_text(end, DIRECTION_DIGITS)} s, {number_text(end + ramp, DIRECTION_DIGITS)} s, {TIME_VARIABLE})"
            )
    return balanced_sum(terms)


def _ramps_text(values: Sequence[tuple[float, float]], ramp: float, unit: str = "") -> str:
    """A value that changes at given times, as text: `values[0]`, then a smooth ramp of `ramp`
    seconds to each next value from its time (numbers in `unit`, none by default)."""
    unit = f" {unit}" if unit else ""
    terms = [number_text(values[0][1], DIRECTION_DIGITS) + unit]
    for (_, before), (when, after) in zip(values, values[1:]):
        if after != before:
            terms.append(
                f"{number_text(after - before, DIRECTION_DIGITS)}{unit} * smoothstep({number_text(when, DIRECTION_DIGITS)} s, {number_text(when + ramp, DIRECTION_DIGITS)} s, {TIME_VARIABLE})"
            )
    return balanced_sum(terms)


def _look_texts(segments: Sequence[Segment], ramp: float) -> dict[str, str]:
    """`path_look` (each looking beat's point from its start, held until the next's) and
    `path_looking` (1 while a beat looks at a point, ramping over `ramp` seconds)."""
    looks = [(seg.start, np.array(seg.look)) for seg in segments if seg.look is not None]
    points = [(when, vector_text(point, DIRECTION_DIGITS)) for when, point in looks] or [
        (0.0, vector_text(np.zeros(3)))
    ]
    looking = [(seg.start, float(seg.look is not None)) for seg in segments] or [(0.0, 0.0)]
    return {"path_look": steps_text(points), "path_looking": _ramps_text([(0.0, 0.0), *looking], ramp)}


POSES = ("sit", "lie")
"""The hold poses that fold the legs (`stand` is the default one)."""


def _pose_texts(segments: Sequence[Segment], ramp: float) -> dict[str, str]:
    """`path_sit` and `path_lie`: 1 while a hold sits (lies), ramping over `ramp` seconds
    from the hold's start, and back over the same time before it ends; into a hold that
    sits or lies next, over the same time after it ends, as that pose ramps in (a sit
    followed by a lie goes down from sitting, not through standing). And `path_rising`: 1
    over the ramp up of a pose into standing, 0 otherwise (getting up is not lying down
    played backward: see `bearing` in configs/controllers/direct.yaml)."""
    texts = {}
    rising = ["0"]
    for pose in POSES:
        terms = ["0"]
        for k, seg in enumerate(segments):
            if seg.kind != "hold" or seg.pose != pose:
                continue
            posed_next = k + 1 < len(segments) and _posed_hold(segments[k + 1])
            down, up = seg.start, seg.end if posed_next else max(seg.start, seg.end - ramp)
            terms += [
                f"smoothstep({number_text(down, DIRECTION_DIGITS)} s, {number_text(down + ramp, DIRECTION_DIGITS)} s, {TIME_VARIABLE})",
                f"-smoothstep({number_text(up, DIRECTION_DIGITS)} s, {number_text(up + ramp, DIRECTION_DIGITS)} s, {TIME_VARIABLE})",
            ]
            if not posed_next:
                rising += [
                    f"step({number_text(up, DIRECTION_DIGITS)} s, {TIME_VARIABLE})",
                    f"-step({number_text(up + ramp, DIRECTION_DIGITS)} s, {TIME_VARIABLE})",
                ]
        texts[f"path_{pose}"] = balanced_sum(terms)
    texts["path_rising"] = balanced_sum(rising)
    return texts


def _posed_hold(segment: Segment) -> bool:
    """Whether a segment is a hold that sits or lies."""
    return segment.kind == "hold" and segment.pose in POSES


def _turn_texts(segments: Sequence[Segment], ramp: float) -> dict[str, str]:
    """`path_turning` (1 during each turn) and `path_turn_rate` (its steady rate, its angle
    over its time, rad/s), from the turn's start to its end, ramping in and out over `ramp`
    seconds from those times."""
    turns = [seg for seg in segments if seg.kind == "turn"]
    turning, rates = [(0.0, 0.0)], [(0.0, 0.0)]
    for seg in turns:
        turning += [(seg.start, 1.0), (seg.end, 0.0)]
        rates += [(seg.start, seg.turn / (seg.end - seg.start)), (seg.end, 0.0)]
    return {"path_turning": _ramps_text(turning, ramp), "path_turn_rate": _ramps_text(rates, ramp, "rad/s")}


def _plain_vector(vector: np.ndarray) -> str:
    """A horizontal unit vector as text: `[0.7071068, 0.7071068, 0]`."""
    return "[" + ", ".join(number_text(v, DIRECTION_DIGITS) for v in (*vector[:2], 0.0)) + "]"
