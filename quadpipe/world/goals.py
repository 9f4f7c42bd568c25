"""Goals: controller parameters a scene sets, as controller-language text (a fixed point, or
a point moving along timed waypoints)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from quadpipe.core.errors import QuadpipeError
from quadpipe.core.yamlio import dotted
from quadpipe.quantities.expressions import TIME_VARIABLE
from quadpipe.world.loading import SceneSpec
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


def goal_expression(waypoints: Sequence[tuple[float, np.ndarray]]) -> str:
    """A piecewise-linear point in time as controller-language text (metres, `t` in seconds).

    The point is the first waypoint plus, for each segment, its displacement times the
    fraction of the segment elapsed: `clamp((t - t0) / (t1 - t0), 0, 1)`.
    """
    terms = [vector_text(waypoints[0][1])]
    for (t0, p0), (t1, p1) in zip(waypoints, waypoints[1:]):
        terms.append(
            f"{vector_text(p1 - p0)} * clamp(({TIME_VARIABLE} - {number_text(t0)} s) / ({number_text(t1 - t0)} s), 0, 1)"
        )
    return " + ".join(terms)


def vector_text(vector: np.ndarray) -> str:
    """A point in metres as controller-language text: `[13.1 m, 0 m, 0 m]`."""
    return "[" + ", ".join(f"{number_text(v)} m" for v in vector) + "]"


def number_text(value: float) -> str:
    """A number with 10 significant digits, without `-0`."""
    text = f"{float(value):.10g}"
    return "0" if text == "-0" else text
