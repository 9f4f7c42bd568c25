"""The world an animal runs in: floor, terrain, props, thrown objects, goals, and where the
animals start. Scenes are `configs/scenes/<name>.yaml` files (see docs/scenes.md); their
numbers carry units of the controller language (`3 HP`, `10 deg`, `0.1 bm`, `4 m/s`), so one
scene works for a rat and an elephant: `HP`, `bw` and `bm` are those of the scene's FIRST animal.

- `load_scene(name_or_path)` -> `SceneSpec` (validated; errors point at file:line:col);
- `available_scenes()` -> the built-in scene names;
- `build_scene(scene, species)` -> `SceneSetup`: the world's `MjSpec` with the animals
  attached, their placements, the goal parameters as controller expressions, and
  `events(model)`, the callables that throw objects during the simulation;
- `build_world(placements)`: a floor and animals, without a scene;
- `scene_json_schema()`: `schemas/scene.schema.json` (regenerate with `python -m quadpipe.world.generate`).

Modules, lowest first: `placement` (floor, light, animals lifted onto the ground; collision
bits: world geoms contype 1 / conaffinity 3, bones contype 2 / conaffinity 1, plus a bit of
their own per animal in a scene whose animals collide), `format` (the
pydantic models of scene files), `loading`, `values` (quantities evaluated for the animals'
size), `sets` (a mesh file read and sampled into a height field), `terrain`, `props`,
`throws`, `direction_format`, `timeline` and `direction` (an animal's path and beats: the
format, played out in time, loaded and checked; docs/direction.md), `goals`, `build`, `schema`
(and `generate`, which rewrites the schema files). Terrain, props and thrown objects are boxes,
spheres and capsules, the shapes a `quadpipe.clip.model.Clip` carries; a set (`type: mesh`
terrain) is a height field, which clips leave out (the animator has the set's file).
"""

from quadpipe.world.build import SceneSetup, build_scene
from quadpipe.world.loading import SCENE_KIND, SceneSpec, available_scenes, load_scene
from quadpipe.world.placement import Placement, build_world
from quadpipe.world.schema import scene_json_schema

__all__ = [
    "SCENE_KIND",
    "Placement",
    "SceneSetup",
    "SceneSpec",
    "available_scenes",
    "build_scene",
    "build_world",
    "load_scene",
    "scene_json_schema",
]
