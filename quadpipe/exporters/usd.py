"""OpenUSD (`.usda` text, `.usdc` binary, `.usdz` package) through usd-core's `pxr`.

Stage: upAxis Z, metersPerUnit 1 (quadpipe's frame as it is: +X forward, +Y left, +Z up,
metres), timeCodesPerSecond = framesPerSecond = the clip's fps, one time code per frame from 0.
The default prim `/World` holds:

- one `SkelRoot` per animal (`/World/dog`) with a `Skeleton` (joint paths following the
  hierarchy, `pelvis/spine0/spine1`; world bind transforms and local rest transforms, both
  pure translations since bone frames are world-aligned at rest), a `SkelAnimation` (local
  translations, rotations and scales, sampled at every frame) bound with `SkelBindingAPI`, and
  its body: one `Mesh`, `body`, its points at the rest pose, skinned smoothly (vertex
  `jointIndices`/`jointWeights`, four per point, identity `geomBindTransform`) - what Blender
  and Maya import as a skinned mesh; or, for `--look bones`, one `Mesh` per bone under
  `meshes/`, bound rigidly to its joint (constant `jointIndices`/`jointWeights` of element
  size 1);
- `props/<name>`: an `Xform` moved by time-sampled translate and orient ops, with its mesh;
- `terrain`: the static world shapes as one mesh.

`pxr` is imported only when a USD file is written. A `.usdz` is the `.usdc` layer packed alone
into an uncompressed, 64-byte aligned zip.
"""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from quadpipe.clip.kinematics import continuous, local_poses, normalize, rest_offsets
from quadpipe.clip.meshes import TriangleMesh, shape_mesh, shapes_mesh
from quadpipe.clip.model import AnimalTrack, BodyMesh, Clip, PropTrack
from quadpipe.core.atomic import atomic_path, scratch_path
from quadpipe.core.signals import signals_deferred
from quadpipe.core.version import __version__

if TYPE_CHECKING:
    from pxr import Usd, UsdGeom, UsdSkel, Vt

WORLD = "/World"
"""The default prim."""

PACKAGED_LAYER_MTIME = time.mktime((2000, 1, 1, 0, 0, 0, 0, 0, -1))
"""Modification time given to the layer packed into a .usdz (the zip records it), so that the
same clip gives the same bytes."""


def build_stage(clip: Clip) -> Usd.Stage:
    """An in-memory stage holding the clip."""
    from pxr import Usd, UsdGeom

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
    names = _UniqueNames()
    for track in clip.animals:
        _add_animal(stage, f"{WORLD}/{names.take(track.name)}", track)
    if clip.props:
        UsdGeom.Scope.Define(stage, f"{WORLD}/props")
    for prop in clip.props:
        _add_prop(stage, f"{WORLD}/props/{names.take(prop.name)}", prop)
    if clip.terrain:
        _add_mesh(stage, f"{WORLD}/terrain", shapes_mesh(clip.terrain))
    return stage


class _UniqueNames:
    """Valid, unique prim names made from free-form names (`box/1` -> `box_1`, then `box_1_1`)."""

    def __init__(self) -> None:
        self.taken: set[str] = {"props", "terrain"}

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
    """Each bone's joint path in the Skeleton: its ancestors' roles and its own, joined by '/'."""
    paths: list[str] = []
    for role, parent in zip(track.roles, track.parents):
        paths.append(role if parent < 0 else f"{paths[parent]}/{role}")
    return paths


def _translation_matrices(translations: np.ndarray) -> list:
    from pxr import Gf

    return [Gf.Matrix4d(1.0).SetTranslate(Gf.Vec3d(*map(float, t))) for t in translations]


def _quatf_array(quats: np.ndarray) -> Vt.QuatfArray:
    """(N, 4) quaternions (w, x, y, z) as a `Vt.QuatfArray`.

    GfQuatf stores its imaginary part first, so numpy data must be handed over as (x, y, z, w).
    """
    from pxr import Vt

    return Vt.QuatfArray.FromNumpy(np.ascontiguousarray(np.roll(quats, -1, axis=-1), dtype=np.float32))


def _add_animal(stage: Usd.Stage, path: str, track: AnimalTrack) -> None:
    from pxr import UsdGeom, UsdSkel, Vt

    UsdSkel.Root.Define(stage, path)
    skeleton = UsdSkel.Skeleton.Define(stage, f"{path}/skeleton")
    joints = Vt.TokenArray(joint_paths(track))
    skeleton.CreateJointsAttr(joints)
    skeleton.CreateJointNamesAttr(Vt.TokenArray(list(track.roles)))
    skeleton.CreateBindTransformsAttr(_translation_matrices(track.rest_start))
    skeleton.CreateRestTransformsAttr(_translation_matrices(rest_offsets(track)))

    animation = UsdSkel.Animation.Define(stage, f"{path}/animation")
    animation.CreateJointsAttr(joints)
    translations, rotations = local_poses(track)
    translation_attr = animation.CreateTranslationsAttr()
    rotation_attr = animation.CreateRotationsAttr()
    for frame in range(track.positions.shape[0]):
        translation_attr.Set(Vt.Vec3fArray.FromNumpy(translations[frame].astype(np.float32)), frame)
        rotation_attr.Set(_quatf_array(rotations[frame]), frame)
    animation.CreateScalesAttr(Vt.Vec3hArray.FromNumpy(np.ones((len(track.roles), 3), dtype=np.float16)))
    UsdSkel.BindingAPI.Apply(skeleton.GetPrim()).CreateAnimationSourceRel().SetTargets([animation.GetPath()])

    if track.body is not None:
        _add_body(stage, f"{path}/body", track.body, skeleton)
        return
    UsdGeom.Xform.Define(stage, f"{path}/meshes")
    for index, (role, shapes) in enumerate(zip(track.roles, track.shapes)):
        if shapes:
            mesh = shapes_mesh(shapes).translated(track.rest_start[index])
            _bind_rigidly(_add_mesh(stage, f"{path}/meshes/{role}", mesh), skeleton, index)


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


def _add_mesh(stage: Usd.Stage, path: str, mesh: TriangleMesh) -> UsdGeom.Mesh:
    """A polygon mesh prim (triangles, vertex normals, display colour), never subdivided."""
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
    return prim


def _add_prop(stage: Usd.Stage, path: str, prop: PropTrack) -> None:
    from pxr import Gf, UsdGeom

    xform = UsdGeom.Xform.Define(stage, path)
    translate = xform.AddTranslateOp(UsdGeom.XformOp.PrecisionDouble)
    orient = xform.AddOrientOp(UsdGeom.XformOp.PrecisionDouble)
    rotations = continuous(normalize(prop.rotations))
    for frame, (position, rotation) in enumerate(zip(prop.positions, rotations)):
        translate.Set(Gf.Vec3d(*map(float, position)), frame)
        orient.Set(Gf.Quatd(float(rotation[0]), Gf.Vec3d(*map(float, rotation[1:]))), frame)
    _add_mesh(stage, f"{path}/mesh", shape_mesh(prop.shape))


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
