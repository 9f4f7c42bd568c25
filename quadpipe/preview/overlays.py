"""The live preview's overlay layers: control segments, balance vectors, forces, contacts, the goal.

Each layer is computed from the controller runtime and the MuJoCo state at the current step,
as plain numpy (`quadpipe.preview.scenery.OverlayLayer`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import mujoco
import numpy as np

from quadpipe.anatomy import roles
from quadpipe.animals import sizing
from quadpipe.preview.scenery import OverlayLayer, layer
from quadpipe.world.placement import Placement

if TYPE_CHECKING:
    from quadpipe.controllers.runtime.runtime import ControllerRuntime

BALANCE_HORIZON_S = 1.0
"""Horizon of the drawn balance vectors, gravity + velocity / horizon (the thesis's 1 s)."""

FORCE_ARROW_HP_PER_BW = 0.5
"""Length of a force arrow, in pelvis heights per body weight of the animal it acts on."""

CONTACT_NORMAL_HP = 0.3
"""Length of a drawn contact normal, pelvis heights."""

SEGMENT_RGBA = (0.58, 0.25, 0.85, 1.0)
BALANCE_RGBA = (1.0, 0.85, 0.1, 1.0)
CONTACT_RGBA = (0.2, 0.85, 0.3, 1.0)
GOAL_RGBA = (0.1, 0.8, 0.9, 1.0)
"""Overlay colours: control segments violet (as in the thesis's figures), balance vectors
yellow, contacts green, the goal cyan."""

FORCE_RGBA: dict[str, tuple[float, float, float, float]] = {
    "segment": (0.9, 0.15, 0.35, 1.0),
    "elastic": (0.35, 0.55, 1.0, 1.0),
    "cycle": (1.0, 0.5, 0.1, 1.0),
    "pull": (0.95, 0.2, 0.2, 1.0),
    "force_pair": (0.95, 0.35, 0.7, 1.0),
}
"""Colour of a force arrow by the kind of element that applied it."""

LIVE_OVERLAYS = ("segments", "balance", "forces", "contacts", "goal")
"""Overlay layers of a live preview, by name (all shown at the start)."""


def segments_layer(runtime: ControllerRuntime, data: mujoco.MjData) -> OverlayLayer:
    """The controller's control segments, as lines between their two points."""
    pairs = [(e.spec.from_, e.spec.to) for e in runtime.compiled.elements.values() if e.type == "segment"]
    starts = [runtime.point(data, a) for a, _ in pairs]
    ends = [runtime.point(data, b) for _, b in pairs]
    return layer("segments", "line", _stack(starts), _stack(ends), SEGMENT_RGBA)


def balance_layer(
    runtime: ControllerRuntime, model: mujoco.MjModel, data: mujoco.MjData, placements: Sequence[Placement]
) -> OverlayLayer:
    """Gravity + velocity / horizon at each leg's top, one HP long for gravity alone."""
    from quadpipe.quantities import expressions

    gravity = np.asarray(model.opt.gravity)
    hp = animal_hp(placements)[:, None]
    starts, ends = [], []
    for leg in roles.LEGS:
        top = expressions.resolve_point_name(f"{leg}.top")
        at = runtime.point(data, top)
        vector = gravity + runtime.point_velocity(data, top) / BALANCE_HORIZON_S
        starts.append(at)
        ends.append(at + vector / np.linalg.norm(gravity) * hp)
    return layer("balance", "arrow", _stack(starts), _stack(ends), BALANCE_RGBA)


def forces_layer(runtime: ControllerRuntime, placements: Sequence[Placement]) -> OverlayLayer:
    """Last step's Cartesian forces, `FORCE_ARROW_HP_PER_BW` HP per body weight."""
    last = runtime.last
    weight = np.array([p.built.animal.mass_kg * sizing.GRAVITY for p in placements])
    scale = FORCE_ARROW_HP_PER_BW * animal_hp(placements) / weight
    ends = last.points + last.forces * scale[last.animals][:, None]
    colors = np.array([FORCE_RGBA[kind] for kind in last.kinds]).reshape(-1, 4)
    return layer("forces", "arrow", last.points, ends, colors)


def contacts_layer(data: mujoco.MjData, hp: float) -> OverlayLayer:
    """Every contact's normal, `CONTACT_NORMAL_HP` long (`hp`: the first animal's pelvis height)."""
    count = data.ncon
    points = data.contact.pos[:count]
    normals = data.contact.frame[:count, :3]
    return layer("contacts", "arrow", points, points + normals * CONTACT_NORMAL_HP * hp, CONTACT_RGBA)


def goal_layer(point: np.ndarray | None) -> OverlayLayer:
    """The goal as a point (no point without a goal)."""
    return layer("goal", "point", np.zeros((0, 3)) if point is None else point, None, GOAL_RGBA)


def animal_hp(placements: Sequence[Placement]) -> np.ndarray:
    """Each animal's pelvis height, metres."""
    return np.array([p.built.animal.pelvis_height for p in placements])


def _stack(rows: list[np.ndarray]) -> np.ndarray:
    return np.concatenate(rows) if rows else np.zeros((0, 3))
