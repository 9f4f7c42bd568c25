"""Directions: a scene's `direction:` section or a direction file, checked and played out.

`load_direction` reads a direction file (`--direction FILE`) with the scene's checks:
structure, then units, each problem at its file:line:col. `scene_timelines` evaluates a
direction for the scene's animals and plays it (`quadpipe.world.timeline.plan_direction`),
reporting moves to points that do not exist and arrivals that come too soon, located.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from quadpipe.animals.library import Animal
from quadpipe.core.errors import Issue, Location, QuadpipeError
from quadpipe.core.textfiles import missing_file
from quadpipe.core.yamlio import YamlDocument, load_yaml
from quadpipe.quantities import units
from quadpipe.world.curves import CURVE_SUFFIXES, CurveError, read_curve
from quadpipe.world.direction_format import MAX_PATH_POINTS, AnimalDirection, DirectionFile, Hold, Move, Turn
from quadpipe.world.loading import SceneSpec, file_order, quantity_issues, schema_issues, validate_part
from quadpipe.world.timeline import (
    BeatValues,
    Timeline,
    follower_timeline,
    plan_direction,
    slow_for_bends,
    tight_bends,
)
from quadpipe.world.values import Values


@dataclass(frozen=True)
class DirectionSpec:
    """A validated direction file: its content and its parsed YAML (to locate values)."""

    file: DirectionFile
    doc: YamlDocument

    def locate(self, path: tuple[Any, ...]) -> Location:
        """Where a value of the file is (or its nearest enclosing value)."""
        return self.doc.locate(path)


def load_direction(path: str | Path) -> DirectionSpec:
    """Load a direction file.

    Raises:
        QuadpipeError: unreadable file, or every problem found in it, each at its file:line:col.
    """
    doc = load_yaml(path, "direction", DirectionFile)
    if not isinstance(doc.data, dict):
        raise QuadpipeError.single(
            "invalid-value", "a direction file must be a mapping of keys (schema, direction)", where=doc.locate(())
        )
    issues = validate_part(DirectionFile, doc.data, (), doc)
    if not issues:
        issues += schema_issues(doc)
    if not issues:
        issues = quantity_issues(DirectionFile.model_validate(doc.data), doc)
    if issues:
        raise QuadpipeError(sorted(issues, key=file_order))
    return DirectionSpec(DirectionFile.model_validate(doc.data), doc)


def scene_timelines(
    scene: SceneSpec,
    values: Values,
    names: list[str],
    scale: units.Scale,
    direction: DirectionSpec | None = None,
    body_lengths: dict[str, float] | None = None,
) -> dict[str, Timeline]:
    """Each directed animal's timeline: the direction file's if given, else the scene's.

    Args:
        scene: the scene, with its values.
        values: the scene's values (SI, for its first animal).
        names: the scene's animals, in order.
        scale: the first animal's scale (a direction file's values are evaluated for it).
        direction: a direction file that replaces the scene's `direction:`.
        body_lengths: the animals' body lengths (`body_length`), metres: an animal given one
            slows for the bends too tight for its speed where no arrival time forbids it
            (`quadpipe.world.timeline.slow_for_bends`; its followers with it).

    Raises:
        QuadpipeError: a direction for an animal the scene does not have, a move to a
            point that does not exist or behind the animal, an arrival no later than its
            beat starts, an animal following one without a path of its own.
    """
    source: SceneSpec | DirectionSpec = direction or scene
    found = direction.file.direction if direction is not None else scene.file.direction
    evaluated = Values(direction, scale) if direction is not None else values
    natural_time = math.sqrt(values.hp / units.STANDARD_GRAVITY)
    issues: list[Issue] = []
    timelines = {}
    for name, animal in found.items():
        path = ("direction", name)
        if name not in names:
            issues.append(
                Issue(
                    "unknown-animal-ref",
                    f"there is no animal {name!r} in this scene",
                    source.locate(path),
                    f"the scene's animals: {', '.join(names[:10])}",
                )
            )
            continue
        if animal.follow is None:
            timeline, found_issues = _play(animal, path, evaluated, natural_time, source)
            length = (body_lengths or {}).get(name)
            timelines[name] = timeline if length is None else slow_for_bends(timeline, length, natural_time)
            issues += found_issues
    if issues:
        raise QuadpipeError(sorted(issues, key=file_order))
    for name, animal in found.items():
        if animal.follow is not None and name in names:
            leader = timelines.get(animal.follow)
            if leader is None:
                issues.append(_bad_leader(name, animal, found, source.locate(("direction", name, "follow"))))
                continue
            values_of = ("direction", name)
            behind, aside = evaluated.get(values_of + ("behind",), 0.0), evaluated.get(values_of + ("aside",), 0.0)
            timelines[name] = follower_timeline(leader, behind, aside)
    if issues:
        raise QuadpipeError(sorted(issues, key=file_order))
    return timelines


def _bad_leader(name: str, animal: AnimalDirection, found: dict[str, AnimalDirection], where: Location) -> Issue:
    """The issue of a `follow` naming no animal with a path and beats of its own."""
    leaders = [other for other, item in found.items() if item.follow is None]
    problem = "follows another animal itself" if animal.follow in found else "has no direction here"
    return Issue(
        "direction-bad-leader",
        f"{name} follows {animal.follow!r}, which {problem}: a leader needs a path and beats of its own",
        where,
        f"follow one of: {', '.join(leaders)}" if leaders else "give the leader a `path` and `beats`",
    )


def _play(
    animal: AnimalDirection,
    path: tuple[Any, ...],
    values: Values,
    natural_time: float,
    source: SceneSpec | DirectionSpec,
) -> tuple[Timeline, list[Issue]]:
    """One animal's own direction (a path and beats), evaluated and played out."""
    assert animal.path is not None and animal.beats is not None, "checked by `AnimalDirection._one_kind`"
    if animal.path.points is not None:
        points = values.items(path + ("path", "points"), len(animal.path.points))
    else:
        assert animal.path.file is not None, "checked by `DirectionPath._points_or_file`"
        points, issue = _curve_points(
            Path(source.doc.file).parent, animal.path.file, animal.path.up, source.locate(path + ("path", "file"))
        )
        if issue is not None:
            return Timeline(np.zeros((0, 2))), [issue]
    beats = [_beat_values(beat, path + ("beats", k), values) for k, beat in enumerate(animal.beats)]
    return plan_direction(points[:, :2], animal.path.smooth, beats, natural_time, source.locate)


def _curve_points(folder: Path, name: str, up: str | None, where: Location) -> tuple[np.ndarray, Issue | None]:
    """A path's points read from a curve file (`quadpipe.world.curves`), or the issue of why not."""
    file = folder / name
    if not file.is_file():
        return np.zeros((0, 3)), missing_file(file, "curve", name=name, where=where, suffixes=CURVE_SUFFIXES)
    try:
        points = read_curve(file, up)
    except CurveError as exc:
        return np.zeros((0, 3)), Issue("direction-bad-curve", f"{name}: {exc}", where)
    problem = None
    if not 2 <= len(points) <= MAX_PATH_POINTS:
        problem = f"the curve has {len(points)} point(s); a path has 2 to {MAX_PATH_POINTS}"
    elif not np.isfinite(points).all():
        problem = "the curve holds numbers that are not finite"
    if problem is not None:
        return points, Issue("direction-bad-curve", f"{name}: {problem}", where)
    return points, None


def _beat_values(beat: Move | Hold | Turn | str, path: tuple[Any, ...], values: Values) -> BeatValues:
    """A beat with its values in SI."""
    if isinstance(beat, Move):
        speed = values.get(path + ("speed",))
        if beat.froude is not None:
            speed = math.sqrt(beat.froude * units.STANDARD_GRAVITY * values.hp)
        return BeatValues(
            "move", beat.to, speed, values.get(path + ("at",)), gait=beat.gait, look=_look(path, values), where=path
        )
    if isinstance(beat, Hold):
        return BeatValues("hold", hold=values[path + ("hold",)], look=_look(path, values), pose=beat.pose, where=path)
    if isinstance(beat, Turn):
        return BeatValues("turn", hold=values[path + ("for",)], turn=values[path + ("turn",)], where=path)
    return BeatValues("stop", where=path)


def _look(path: tuple[Any, ...], values: Values) -> list[float] | None:
    """A beat's `look_at` point in metres, None when it has none."""
    point = values.get(path + ("look_at",))
    return None if point is None else [float(v) for v in point]


def bend_warnings(name: str, animal: Animal, timeline: Timeline, where: Location) -> list[Issue]:
    """Warnings of the bends of an animal's path tighter than it can follow at its speed
    there (`quadpipe.world.timeline.tight_bends`), located at its direction: it cuts them."""
    hp = animal.pelvis_height
    issues = []
    for bend in tight_bends(timeline, body_length(animal)):
        x, y = bend.at / hp
        froude = bend.speed**2 / (units.STANDARD_GRAVITY * hp)
        issues.append(
            Issue(
                "direction-tight-bend",
                f"the path of {name} bends at ({x:.1f} HP, {y:.1f} HP) with a radius of {bend.radius / hp:.2f} HP: "
                f"at Fr {froude:.2f} a {animal.name} follows no tighter than {bend.least / hp:.2f} HP, "
                "and cuts the bend",
                where,
                "give the bend more room (spread its points), slow down for it, or stop there and `turn` in place",
                severity="warning",
            )
        )
    return issues


def body_length(animal: Animal) -> float:
    """An animal's length, metres: from its pelvis to the tip of its head, horizontally, in
    the rest pose."""
    skeleton = animal.skeleton
    return float(np.linalg.norm((skeleton["head"].end - skeleton["pelvis"].start)[:2]))
