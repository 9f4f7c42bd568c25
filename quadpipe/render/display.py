"""The display model: a physics-free MuJoCo model that shows a clip (mocap bodies, terrain, floor, sky, sun)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from quadpipe.clip.model import BodyMesh, Clip, Shape
from quadpipe.render.camera import FOVY_DEG
from quadpipe.render.poses import clip_scale

if TYPE_CHECKING:
    import mujoco

SHADOW_MAP_PX = 2048
"""Side of the sun's shadow map, pixels (MuJoCo's default 4096 costs 40 % more CPU a frame)."""

VIDEO_MULTISAMPLES, SHEET_MULTISAMPLES = 0, 4
"""Anti-aliasing samples per pixel: none for video (4 samples double the CPU time of a frame),
4 for contact sheets, which are few frames and meant for documents."""

SCENE_EXTENT_HP = 3.0
"""MuJoCo's scene extent (its unit for clipping planes and shadows), in pelvis heights."""

SHADOW_RADIUS_EXTENTS = 2.0
"""Radius around the camera target that the sun's shadows cover, in scene extents."""

SUN_DIRECTION = (0.3, 0.2, -1.0)
"""Direction the sunlight travels in (high, from behind the animal's right), as in `quadpipe.world.placement`."""

SUN_DISTANCE_HP = 10.0
"""How far up-sun from the camera target the sun sits, pelvis heights (for the shadow map)."""

SKY_TOP_RGB, SKY_HORIZON_RGB = (0.55, 0.7, 0.85), (0.1, 0.12, 0.15)
CHECKER_RGB = ((0.32, 0.36, 0.40), (0.24, 0.27, 0.30))
"""Sky gradient and floor checker colours, as in `quadpipe.world.placement`."""

CHECKER_SQUARE_HP = 0.5
"""Side of one floor checker square, in pelvis heights (so a rat and an elephant read alike)."""

HEADLIGHT_AMBIENT, HEADLIGHT_DIFFUSE, HEADLIGHT_SPECULAR = 0.25, 0.35, 0.1
"""The camera's headlight: enough fill to see the shadowed side of the animal."""

PLANE_GRID_M = 1.0
"""Spacing of a plane's rendering grid (MuJoCo subdivides planes for lighting), metres."""


def display_spec(clip: Clip, width: int, height: int, multisamples: int = VIDEO_MULTISAMPLES) -> mujoco.MjSpec:
    """A physics-free MuJoCo model that shows the clip: mocap bodies, terrain, floor, sky, sun.

    Bodies, in mocap order: every bone of every animal (`<animal>/<role>`), every prop
    (`prop/<name>`), then the sun (`sun`), whose directional light follows the camera target
    so that its shadow map covers what the camera sees.
    """
    import mujoco

    scale = clip_scale(clip)
    spec = mujoco.MjSpec()
    spec.modelname = "display"
    spec.compiler.degree = False
    _set_visual(spec, clip, width, height, multisamples)
    spec.add_texture(
        name="sky",
        type=mujoco.mjtTexture.mjTEXTURE_SKYBOX,
        builtin=mujoco.mjtBuiltin.mjBUILTIN_GRADIENT,
        rgb1=list(SKY_TOP_RGB),
        rgb2=list(SKY_HORIZON_RGB),
        width=256,
        height=256,
    )
    spec.add_texture(
        name="checker",
        type=mujoco.mjtTexture.mjTEXTURE_2D,
        builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER,
        rgb1=list(CHECKER_RGB[0]),
        rgb2=list(CHECKER_RGB[1]),
        width=256,
        height=256,
    )
    repeat = 1.0 / (2 * CHECKER_SQUARE_HP * scale)
    spec.add_material(name="checker", textures=["", "checker"], texrepeat=[repeat, repeat], texuniform=True)
    for track in clip.animals:
        for role, shapes in zip(track.roles, track.shapes):
            _add_mocap_body(spec, f"{track.name}/{role}", shapes if track.body is None else ())
        if track.body is not None:
            _add_skin(spec, track.name, track.roles, track.rest_start, track.body)
    for prop in clip.props:
        _add_mocap_body(spec, f"prop/{prop.name}", [prop.shape])
    for shape in clip.terrain:
        _add_geom(spec.worldbody, shape, material="checker" if shape.kind == "plane" else None)
    sun = spec.worldbody.add_body(name="sun", mocap=True)
    sun.add_light(
        name="sun",
        type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL,
        dir=list(SUN_DIRECTION),
        diffuse=[0.8, 0.8, 0.8],
        castshadow=True,
    )
    return spec


def _set_visual(spec: mujoco.MjSpec, clip: Clip, width: int, height: int, multisamples: int) -> None:
    """Buffer size, shadows, anti-aliasing, clipping planes and headlight of the display model."""
    scale = clip_scale(clip)
    visual = spec.visual
    visual.global_.offwidth, visual.global_.offheight = width, height
    visual.global_.fovy = FOVY_DEG
    visual.quality.shadowsize = SHADOW_MAP_PX
    visual.quality.offsamples = multisamples
    visual.map.shadowclip = SHADOW_RADIUS_EXTENTS
    visual.headlight.ambient = [HEADLIGHT_AMBIENT] * 3
    visual.headlight.diffuse = [HEADLIGHT_DIFFUSE] * 3
    visual.headlight.specular = [HEADLIGHT_SPECULAR] * 3
    spec.stat.extent = SCENE_EXTENT_HP * scale
    spec.stat.center = list(clip.animals[0].rest_start[0])


def _add_mocap_body(spec: mujoco.MjSpec, name: str, shapes: Sequence[Shape]) -> None:
    body = spec.worldbody.add_body(name=name, mocap=True)
    for shape in shapes:
        _add_geom(body, shape)


def _add_skin(spec: mujoco.MjSpec, animal: str, roles: Sequence[str], rest_start: np.ndarray, body: BodyMesh) -> None:
    """An animal's body mesh as a MuJoCo skin on its bone bodies (bound at their rest poses)."""
    skin = spec.add_skin(name=f"{animal}/body")
    skin.vert = body.vertices.astype(np.float32).reshape(-1).tolist()
    skin.face = body.faces.astype(np.int32).reshape(-1).tolist()
    skin.rgba = list(body.colors[0])
    bones = np.unique(body.joints[body.weights > 0])
    skin.bodyname = [f"{animal}/{roles[b]}" for b in bones]
    skin.bindpos = rest_start[bones].reshape(-1).tolist()
    skin.bindquat = np.tile([1.0, 0.0, 0.0, 0.0], len(bones)).tolist()
    vertex_ids, vertex_weights = [], []
    for bone in bones:
        rows, columns = np.nonzero((body.joints == bone) & (body.weights > 0))
        vertex_ids.append(rows.tolist())
        vertex_weights.append(body.weights[rows, columns].tolist())
    skin.vertid = vertex_ids
    skin.vertweight = vertex_weights


def _add_geom(body: mujoco.MjsBody, shape: Shape, material: str | None = None) -> None:
    """A shape as a display-only geom (it collides with nothing)."""
    import mujoco

    kinds = {
        "capsule": mujoco.mjtGeom.mjGEOM_CAPSULE,
        "box": mujoco.mjtGeom.mjGEOM_BOX,
        "sphere": mujoco.mjtGeom.mjGEOM_SPHERE,
        "plane": mujoco.mjtGeom.mjGEOM_PLANE,
    }
    size = list(shape.size) + [0.0] * (3 - len(shape.size))
    if shape.kind == "plane":
        size[2] = PLANE_GRID_M
    geom = body.add_geom(
        type=kinds[shape.kind],
        size=size,
        pos=list(shape.pos),
        quat=list(shape.quat),
        rgba=list(shape.rgba),
        contype=0,
        conaffinity=0,
    )
    if material is not None:
        geom.material = material
        geom.rgba = [1.0, 1.0, 1.0, 1.0]
