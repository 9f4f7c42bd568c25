"""Static terrain: ramps, hills, stairs and blocks, each made of boxes (`Slab`s), and sets
(mesh files) made into height fields (`quadpipe.world.sets`)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from quadpipe.animals.model import FRICTION
from quadpipe.world.format import Hill, Slope, Stairs, TerrainBox
from quadpipe.world.loading import SceneSpec, set_path
from quadpipe.world.placement import WORLD_CONAFFINITY, WORLD_CONTYPE, euler_quat
from quadpipe.world.set_format import TerrainMesh
from quadpipe.world.values import Values

RAMP_BASE_HP = 0.1
"""How far a ramp's slab reaches below the ground, in pelvis heights (no gap under its high end)."""

TERRAIN_RGBA = (0.52, 0.47, 0.40, 1.0)
"""Display colour of terrain."""


@dataclass(frozen=True)
class Slab:
    """A static terrain box: name, centre (m), half sizes (m), orientation (w, x, y, z)."""

    name: str
    centre: np.ndarray
    half: np.ndarray
    quat: np.ndarray


SET_BASE_M = 0.1
"""Depth of a set's height field below its lowest point, metres (MuJoCo's hfield `size[3]`)."""

MIN_SET_RELIEF_M = 1e-6
"""Elevation range given to a flat set's height field (MuJoCo needs a positive one), metres."""


def add_terrain(spec: mujoco.MjSpec, scene: SceneSpec, values: Values, friction: float) -> None:
    """Add the boxes and height fields of every terrain item to the world, with the ground's sliding friction."""
    ground = {
        "rgba": list(TERRAIN_RGBA),
        "contype": WORLD_CONTYPE,
        "conaffinity": WORLD_CONAFFINITY,
        "friction": [friction, *FRICTION[1:]],
    }
    for index, item in enumerate(scene.file.terrain):
        if isinstance(item, TerrainMesh):
            _add_set(spec, f"terrain{index}_mesh", scene, index, item, ground)
            continue
        for slab in terrain_slabs(index, item, values):
            spec.worldbody.add_geom(
                name=slab.name,
                type=mujoco.mjtGeom.mjGEOM_BOX,
                pos=slab.centre,
                size=slab.half,
                quat=slab.quat,
                **ground,
            )


def _add_set(
    spec: mujoco.MjSpec, name: str, scene: SceneSpec, index: int, item: TerrainMesh, ground: dict[str, Any]
) -> None:
    """A set file as a height field geom named `name`, placed in the set's own coordinates."""
    from quadpipe.world.sets import height_grid

    where = scene.locate(("terrain", index, "file"))
    grid = height_grid(set_path(scene.doc, item), item.file, where, item.scale, item.up, item.resolution)
    low = float(grid.heights.min())
    relief = max(float(grid.heights.max()) - low, MIN_SET_RELIEF_M)
    rows, columns = grid.heights.shape
    spec.add_hfield(
        name=name,
        size=[*grid.half_sizes, relief, SET_BASE_M],
        nrow=rows,
        ncol=columns,
        userdata=((grid.heights - low) / relief).astype(np.float32).ravel().tolist(),
    )
    spec.worldbody.add_geom(
        name=name, type=mujoco.mjtGeom.mjGEOM_HFIELD, hfieldname=name, pos=[*grid.centre, low], **ground
    )


def terrain_slabs(index: int, item: Any, values: Values) -> list[Slab]:
    """The boxes of one terrain item (named `terrain<index>_<type>[_<part>]`)."""
    base = ("terrain", index)
    name = f"terrain{index}_{item.type}"
    if isinstance(item, TerrainBox):
        return [
            Slab(
                name,
                values[base + ("at",)],
                values.items(base + ("size",), 3) / 2,
                euler_quat(values[base + ("euler",)]),
            )
        ]
    start, width = values[base + ("start",)], values[base + ("width",)]
    reach_down = RAMP_BASE_HP * values.hp
    if isinstance(item, Slope):
        angle, run, top = values[base + ("angle",)], values[base + ("length",)], values[base + ("top",)]
        rise = run * math.tan(angle)
        return [
            _ramp(f"{name}_ramp", start, 0.0, run, angle, True, width, reach_down),
            *_block(f"{name}_top", start + run, top, rise, width),
        ]
    if isinstance(item, Hill):
        angle, height, top = values[base + ("angle",)], values[base + ("height",)], values[base + ("top",)]
        run = height / math.tan(angle)
        return [
            _ramp(f"{name}_up", start, 0.0, run, angle, True, width, reach_down),
            *_block(f"{name}_top", start + run, top, height, width),
            _ramp(f"{name}_down", start + run + top, height, run, angle, False, width, reach_down),
        ]
    return _stairs(name, item, start, width, values, base)


def _stairs(name: str, item: Stairs, start: float, width: float, values: Values, base: tuple[Any, ...]) -> list[Slab]:
    rise, depth, landing = values[base + ("step_height",)], values[base + ("step_depth",)], values[base + ("landing",)]
    count = item.steps
    if item.direction == "up":
        steps = [
            slab
            for k in range(1, count + 1)
            for slab in _block(f"{name}_step{k}", start + (k - 1) * depth, depth, k * rise, width)
        ]
        return steps + _block(f"{name}_landing", start + count * depth, landing, count * rise, width)
    steps = [
        slab
        for k in range(1, count)
        for slab in _block(f"{name}_step{k}", start + (k - 1) * depth, depth, (count - k) * rise, width)
    ]
    return _block(f"{name}_landing", start - landing, landing, count * rise, width) + steps


def _block(name: str, x0: float, length: float, height: float, width: float) -> list[Slab]:
    """A box from the ground up to `height`, from x0 over `length`; none if it is empty."""
    if length <= 0 or height <= 0:
        return []
    centre = np.array([x0 + length / 2, 0.0, height / 2])
    return [Slab(name, centre, np.array([length / 2, width / 2, height / 2]), np.array([1.0, 0.0, 0.0, 0.0]))]


def _ramp(
    name: str, x0: float, z0: float, run: float, angle: float, rising: bool, width: float, reach_down: float
) -> Slab:
    """A tilted slab whose top face runs from (x0, z0) over `run` along x, up or down at `angle`.

    It is thick enough to reach below the ground under its high end, so no gap shows.
    """
    sign = 1.0 if rising else -1.0
    rise = run * math.tan(angle)
    thickness = rise / math.cos(angle) + reach_down
    normal = np.array([-sign * math.sin(angle), 0.0, math.cos(angle)])
    top_middle = np.array([x0 + run / 2, 0.0, z0 + sign * rise / 2])
    pitch = -sign * angle
    return Slab(
        name,
        top_middle - normal * thickness / 2,
        np.array([run / (2 * math.cos(angle)), width / 2, thickness / 2]),
        np.array([math.cos(pitch / 2), 0.0, math.sin(pitch / 2), 0.0]),
    )
