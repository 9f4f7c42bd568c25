"""OpenUSD (`.usda` text, `.usdc` binary, `.usdz` package) through usd-core's `pxr`.

Stage: upAxis Z, metersPerUnit 1 (quadpipe's frame as it is: +X forward, +Y left, +Z up,
metres), timeCodesPerSecond = framesPerSecond = the clip's fps, startTimeCode 0 and
endTimeCode the last frame: one time code per frame. The default prim `/World` holds:

- `animals`: one `SkelRoot` holding every animal, each a `Skeleton` named after it
  (`/World/animals/dog`; joint paths following the hierarchy, `pelvis/spine0/spine1`; world
  bind transforms and local rest transforms, both pure translations since bone frames are
  world-aligned at rest) with, under it, its `SkelAnimation` (local translations, rotations and
  scales, sampled at every frame) and its body: one `Mesh`, `<animal>_body`, its points at the
  rest pose, skinned smoothly (vertex `jointIndices`/`jointWeights`, four per point, identity
  `geomBindTransform`); or, for `--look bones`, one `Mesh` per bone under `meshes/`, bound
  rigidly to its joint (constant `jointIndices`/`jointWeights` of element size 1). Meshes
  under their skeleton are what Blender parents to the armature it makes of the skeleton,
  named after the animal;
- `props/<name>`: a `Mesh` named as in the scene, moved by time-sampled translate and orient
  ops; while it is out of the scene (a thrown box before its throw) it holds still
  (`quadpipe.exporters.layout`), its `visibility` is `invisible` and, for importers that
  read no visibility (Blender), a scale op is 0, stepping to 1 between the frame before it
  enters and the frame it does;
- `terrain`: the static world shapes as one mesh;
- `looks/<mesh>`: a `UsdPreviewSurface` material for each mesh, bound with
  `MaterialBindingAPI` (its colour, or its vertex colours through a primvar reader).

`pxr` is imported only when a USD file is written. A `.usdz` is the `.usdc` layer packed alone
into an uncompressed, 64-byte aligned zip.
"""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from quadpipe.clip.bind import USD_BONE_AXIS, bound_poses
from quadpipe.clip.kinematics import continuous, normalize
from quadpipe.clip.meshes import TriangleMesh, shape_mesh, shapes_mesh
from quadpipe.clip.model import AnimalTrack, BodyMesh, Clip, PropTrack
from quadpipe.core.atomic import atomic_path, scratch_path
from quadpipe.core.signals import signals_deferred
from quadpipe.core.version import __version__
from quadpipe.exporters.layout import BODY_SUFFIX, held_poses, switches

if TYPE_CHECKING:
    from pxr import Usd, UsdGeom, UsdSkel, Vt

WORLD = "/World"
"""The default prim."""

ANIMALS, PROPS, TERRAIN, LOOKS = (f"{WORLD}/{name}" for name in ("animals", "props", "terrain", "looks"))
"""The SkelRoot of the animals, the scope of the props, the terrain mesh, the materials' scope."""


FPS_PROPERTY = "userProperties:quadpipe:fps"
"""The clip's frame rate again, on `/World`, for importers that read no stage frame rate
(Blender's makes it the `quadpipe:fps` custom property of the World object, which the script
of `quadpipe blender-script` reads)."""

ROUGHNESS = 0.8
"""Every material is matte and not metallic (as glTF's)."""

PACKAGED_LAYER_MTIME = time.mktime((2000, 1, 1, 0, 0, 0, 0, 0, -1))
"""Modification time given to the layer packed into a .usdz (the zip records it), so that the
same clip gives the same bytes."""


def build_stage(clip: Clip) -> Usd.Stage:
    """An in-memory stage holding the clip."""
    from pxr import Sdf, Usd, UsdGeom, UsdSkel

    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, UsdGeom.LinearUnits.meters)
    stage.SetTimeCodesPerSecond(clip.fps)
    stage.SetFramesPerSecond(clip.fps)
    stage.SetStartTimeCode(0)
    stage.SetEndTimeCode(max(clip.frame_count - 1, 0))
    layer = stage.GetRootLayer()
    layer.customLayerData = {"quadpipe": {"version": __version__, **clip.metadata}}
    world = UsdGeom.Xform.Define(stage, WORLD)
    stage.SetDefaultPrim(world.GetPrim())
    world.GetPrim().CreateAttribute(FPS_PROPERTY, Sdf.ValueTypeNames.Double, custom=True).Set(float(clip.fps))
    UsdGeom.Scope.Define(stage, LOOKS)
    names = _UniqueNames()
    if clip.animals:
        UsdSkel.Root.Define(stage, ANIMALS)
    for track in clip.animals:
        _add_animal(stage, f"{ANIMALS}/{names.take(track.name)}", track)
    if clip.props:
        UsdGeom.Scope.Define(stage, PROPS)
    for prop in clip.props:
        _add_prop(stage, f"{PROPS}/{names.take(prop.name)}", prop)
    if clip.terrain:
        _add_mesh(stage, TERRAIN, shapes_mesh(clip.terrain))
    return stage


class _UniqueNames:
    """Valid, unique prim names made from free-form names (`box/1` -> `box_1`, then `box_1_1`)."""

    def __init__(self) -> None:
        self.taken: set[str] = {path.rpartition("/")[2] for path in (ANIMALS, PROPS, TERRAIN, LOOKS)}

    def take(self, name: str) -> str:
        from pxr import Tf

        base = Tf.MakeValidIdentifier(name)
        candidate, count = base, 0
        while candidate in self.taken:
            count += 1
            candidate = f"{base}_{count}"
        self.taken.add(candidate)
        return candidate


def joint_paths(track: AnimalTrack) -> list[str]:
    """Each bone's joint path in the Skeleton: its ancestors' names and its own, joined by '/',
    each made a valid, unique identifier (a rig's `Bip01 Pelvis` -> `Bip01_Pelvis`; roles are
    already; `jointNames` keeps the names as they are)."""
    names = _UniqueNames()
    paths: list[str] = []
    for role, parent in zip(track.roles, track.parents):
        token = names.take(role)
        paths.append(token if parent < 0 else f"{paths[parent]}/{token}")
    return paths


def _transform_matrices(rotations: np.ndarray, translations: np.ndarray) -> list:
    """Gf matrices of rotations (w, x, y, z) then translations."""
    from pxr import Gf

    return [
        Gf.Matrix4d(1.0).SetTransform(Gf.Rotation(Gf.Quatd(*map(float, q))), Gf.Vec3d(*map(float, t)))
        for q, t in zip(rotations, translations)
    ]


def _quatf_array(quats: np.ndarray) -> Vt.QuatfArray:
    """(N, 4) quaternions (w, x, y, z) as a `Vt.QuatfArray`.

    GfQuatf stores its imaginary part first, so numpy data must be handed over as (x, y, z, w).
    """
    from pxr import Vt

    return Vt.QuatfArray.FromNumpy(np.ascontiguousarray(np.roll(quats, -1, axis=-1), dtype=np.float32))


def _add_animal(stage: Usd.Stage, path: str, track: AnimalTrack) -> None:
    from pxr import UsdGeom, UsdSkel, Vt

    name = path.rpartition("/")[2]
    skeleton = UsdSkel.Skeleton.Define(stage, path)
    paths = joint_paths(track)
    joints = Vt.TokenArray(paths)
    skeleton.CreateJointsAttr(joints)
    skeleton.CreateJointNamesAttr(Vt.TokenArray(list(track.roles)))
    poses = bound_poses(track, USD_BONE_AXIS)  # each joint's local +Y along its bone at rest
    skeleton.CreateBindTransformsAttr(_transform_matrices(poses.bind, track.rest_start))
    skeleton.CreateRestTransformsAttr(_transform_matrices(poses.rest_rotations, poses.rest_translations))

    animation = UsdSkel.Animation.Define(stage, f"{path}/animation")
    animation.CreateJointsAttr(joints)
    translation_attr = animation.CreateTranslationsAttr()
    rotation_attr = animation.CreateRotationsAttr()
    for frame in range(track.positions.shape[0]):
        translation_attr.Set(Vt.Vec3fArray.FromNumpy(poses.translations[frame].astype(np.float32)), frame)
        rotation_attr.Set(_quatf_array(poses.rotations[frame]), frame)
    animation.CreateScalesAttr(Vt.Vec3hArray.FromNumpy(np.ones((len(track.roles), 3), dtype=np.float16)))
    UsdSkel.BindingAPI.Apply(skeleton.GetPrim()).CreateAnimationSourceRel().SetTargets([animation.GetPath()])

    if track.body is not None:
        _add_body(stage, f"{path}/{name}{BODY_SUFFIX}", track.body, skeleton)
        return
    UsdGeom.Xform.Define(stage, f"{path}/meshes")
    for index, shapes in enumerate(track.shapes):
        if shapes:
            mesh = shapes_mesh(shapes).translated(track.rest_start[index])
            bone = _add_mesh(stage, f"{path}/meshes/{paths[index].rpartition('/')[2]}", mesh, look=f"{name}_bones")
            _bind_rigidly(bone, skeleton, index)


def _add_body(stage: Usd.Stage, path: str, body: BodyMesh, skeleton: UsdSkel.Skeleton) -> None:
    """The animal's body: one mesh, smoothly skinned (per-vertex joints and weights)."""
    from pxr import Gf, UsdSkel, Vt

    mesh = _add_mesh(stage, path, TriangleMesh(body.vertices, body.normals, body.colors, body.faces))
    binding = UsdSkel.BindingAPI.Apply(mesh.GetPrim())
    binding.CreateSkeletonRel().SetTargets([skeleton.GetPath()])
    influences = body.joints.shape[1]
    binding.CreateJointIndicesPrimvar(False, influences).Set(
        Vt.IntArray.FromNumpy(body.joints.reshape(-1).astype(np.int32))
    )
    binding.CreateJointWeightsPrimvar(False, influences).Set(
        Vt.FloatArray.FromNumpy(body.weights.reshape(-1).astype(np.float32))
    )
    binding.CreateGeomBindTransformAttr(Gf.Matrix4d(1.0))


def _bind_rigidly(mesh: UsdGeom.Mesh, skeleton: UsdSkel.Skeleton, joint: int) -> None:
    """Skin a mesh wholly to one joint (constant joint influence, weight 1)."""
    from pxr import Gf, UsdSkel, Vt

    binding = UsdSkel.BindingAPI.Apply(mesh.GetPrim())
    binding.CreateSkeletonRel().SetTargets([skeleton.GetPath()])
    binding.CreateJointIndicesPrimvar(True, 1).Set(Vt.IntArray([joint]))
    binding.CreateJointWeightsPrimvar(True, 1).Set(Vt.FloatArray([1.0]))
    binding.CreateGeomBindTransformAttr(Gf.Matrix4d(1.0))


def _add_mesh(stage: Usd.Stage, path: str, mesh: TriangleMesh, look: str | None = None) -> UsdGeom.Mesh:
    """A polygon mesh prim (triangles, vertex normals, display colour), never subdivided, with
    its material: its own, named after it, or the shared `look` that draws display colours."""
    from pxr import UsdGeom, Vt

    prim = UsdGeom.Mesh.Define(stage, path)
    points = mesh.vertices.astype(np.float32)
    prim.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(points))
    prim.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.full(len(mesh.faces), 3, dtype=np.int32)))
    prim.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(mesh.faces.reshape(-1).astype(np.int32)))
    prim.CreateNormalsAttr(Vt.Vec3fArray.FromNumpy(mesh.normals.astype(np.float32)))
    prim.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
    prim.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    prim.CreateExtentAttr(Vt.Vec3fArray.FromNumpy(np.stack([points.min(axis=0), points.max(axis=0)])))
    colors = np.unique(mesh.colors[:, :3], axis=0)
    uniform = len(colors) == 1
    interpolation = UsdGeom.Tokens.constant if uniform else UsdGeom.Tokens.vertex
    values = colors if uniform else mesh.colors[:, :3]
    prim.CreateDisplayColorPrimvar(interpolation).Set(Vt.Vec3fArray.FromNumpy(values.astype(np.float32)))
    own_color = colors[0] if uniform and look is None else None
    _bind_material(stage, prim, look or prim.GetPath().name, own_color)
    return prim


def _bind_material(stage: Usd.Stage, mesh: UsdGeom.Mesh, name: str, color: np.ndarray | None) -> None:
    """Bind a UsdPreviewSurface material, `looks/<name>` (made on first use), to a mesh: matte,
    of `color`, or of the mesh's vertex colours (its `displayColor` primvar) when `color` is None."""
    from pxr import Gf, Sdf, UsdShade

    path = f"{LOOKS}/{name}"
    existing = UsdShade.Material.Get(stage, path)
    if existing:
        UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(existing)
        return
    material = UsdShade.Material.Define(stage, path)
    shader = UsdShade.Shader.Define(stage, f"{path}/surface")
    shader.CreateIdAttr("UsdPreviewSurface")
    diffuse = shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f)
    if color is None:
        reader = UsdShade.Shader.Define(stage, f"{path}/display_color")
        reader.CreateIdAttr("UsdPrimvarReader_float3")
        reader.CreateInput("varname", Sdf.ValueTypeNames.String).Set("displayColor")
        diffuse.ConnectToSource(
            reader.ConnectableAPI(), "result", UsdShade.AttributeType.Output, Sdf.ValueTypeNames.Float3
        )
    else:
        diffuse.Set(Gf.Vec3f(*map(float, color)))
    shader.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(ROUGHNESS)
    shader.CreateInput("metallic", Sdf.ValueTypeNames.Float).Set(0.0)
    material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(material)


def _add_prop(stage: Usd.Stage, path: str, prop: PropTrack) -> None:
    """A prop: its mesh, moved by time-sampled translate and orient ops, invisible while it is
    out of the scene (and then held at its nearest pose in the scene)."""
    from pxr import Gf, UsdGeom

    mesh = _add_mesh(stage, path, shape_mesh(prop.shape))
    translate = mesh.AddTranslateOp(UsdGeom.XformOp.PrecisionDouble)
    orient = mesh.AddOrientOp(UsdGeom.XformOp.PrecisionDouble)
    positions, rotations = held_poses(prop)
    for frame, (position, rotation) in enumerate(zip(positions, continuous(normalize(rotations)))):
        translate.Set(Gf.Vec3d(*map(float, position)), frame)
        orient.Set(Gf.Quatd(float(rotation[0]), Gf.Vec3d(*map(float, rotation[1:]))), frame)
    frames, present = switches(prop)
    if len(frames) > 1 or not present[0]:
        visibility = mesh.CreateVisibilityAttr()
        scale = mesh.AddScaleOp(UsdGeom.XformOp.PrecisionFloat)
        for frame, shown in zip(frames, present):
            visibility.Set(UsdGeom.Tokens.inherited if shown else UsdGeom.Tokens.invisible, int(frame))
        for frame, shown in _stepped(frames, present):
            scale.Set(Gf.Vec3f(float(shown)), frame)


def _stepped(frames: np.ndarray, values: np.ndarray) -> list[tuple[int, bool]]:
    """Time samples of a step function set to `values` at `frames`: a sample at each switch
    and one repeating the old value the frame before, so that linear interpolation changes it
    only between those two frames."""
    samples: list[tuple[int, bool]] = []
    for frame, value in zip(frames.tolist(), values.tolist()):
        if samples and samples[-1][0] < frame - 1:
            samples.append((frame - 1, samples[-1][1]))
        samples.append((frame, value))
    return samples


def _export_layer(stage: Usd.Stage, target: Path) -> None:
    """Write the stage's root layer to `target`, in the format `target`'s suffix names."""
    from pxr import Tf

    try:
        saved = stage.GetRootLayer().Export(str(target))
    except Tf.ErrorException as exc:
        raise OSError(str(exc).strip()) from None
    if not saved:
        raise OSError(f"USD could not write {target.name}")


def _export_layer_file(clip: Clip, path: Path) -> None:
    with atomic_path(path, path.suffix.lower()) as temporary, signals_deferred():
        _export_layer(build_stage(clip), temporary)


def export_usda(clip: Clip, path: Path) -> None:
    """OpenUSD text layer: UsdSkel animals, animated props, terrain."""
    _export_layer_file(clip, path)


def export_usdc(clip: Clip, path: Path) -> None:
    """OpenUSD binary (crate) layer: same content as .usda."""
    _export_layer_file(clip, path)


def export_usdz(clip: Clip, path: Path) -> None:
    """OpenUSD package: the .usdc layer in a zip, for AR Quick Look and sharing."""
    with scratch_path(path, ".usdc") as layer, atomic_path(path, ".usdz") as package, signals_deferred():
        from pxr import Sdf

        _export_layer(build_stage(clip), layer)
        os.utime(layer, (PACKAGED_LAYER_MTIME, PACKAGED_LAYER_MTIME))
        writer = Sdf.ZipFileWriter.CreateNew(str(package))
        writer.AddFile(str(layer), f"{path.stem}.usdc")
        writer.Save()
