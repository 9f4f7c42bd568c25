"""Import quadpipe clips into Blender at the clip's frame rate and frame range.

Blender's own importers take a clip's motion but not its time: the glTF importer keys the
animation at the scene's frame rate (24 fps by default) whatever the file's, the USD importer
sets the frame range but not the rate, and the BVH importer starts at frame 1. This script
reads the clip's rate and length from the file first (glTF: `asset.extras.fps` and the
animation's key times; USD: the `quadpipe:fps` property quadpipe writes on `/World` beside the
stage's `timeCodesPerSecond`, and the stage's start and end time codes; BVH: `Frame Time` and
`Frames`), sets the scene to them (frame 0 = the clip's first frame), then imports, so that
every frame of the clip is a whole Blender frame.

Use it any of three ways (`quadpipe blender-script -o quadpipe_import.py` writes it out):

- command line: `blender -P quadpipe_import.py -- walk.glb` (several files may follow `--`;
  add `-b` to work without a window);
- Blender's Text Editor: open the file, Run Script, then File > Import > quadpipe clip;
  or install it as an add-on (Edit > Preferences > Add-ons > Install from Disk);
- Python inside Blender (or `bpy` from PyPI): `import quadpipe_import;
  quadpipe_import.import_clip("walk.usdc")`.

It runs inside Blender's Python and needs nothing but `bpy`: it imports no quadpipe module.
"""

from __future__ import annotations

import json
import re
import struct
import sys
from pathlib import Path

import bpy

bl_info = {
    "name": "quadpipe clip",
    "description": "Import quadpipe clips (.glb .gltf .usd .usda .usdc .usdz .bvh) at their frame rate and range",
    "blender": (4, 2, 0),
    "category": "Import-Export",
    "location": "File > Import > quadpipe clip",
}

GLTF_SUFFIXES = (".glb", ".gltf")
USD_SUFFIXES = (".usd", ".usda", ".usdc", ".usdz")
BVH_SUFFIXES = (".bvh",)
SUFFIXES = GLTF_SUFFIXES + USD_SUFFIXES + BVH_SUFFIXES

USD_FPS_PROPERTY = "quadpipe:fps"
"""The custom property Blender's USD importer gives `/World`'s object from quadpipe's
`userProperties:quadpipe:fps` attribute (Blender's importer reads no stage frame rate)."""

BVH_SCALE = 0.01
"""quadpipe's BVH lengths are centimetres; Blender works in metres."""

BVH_FPS_DECIMALS = 3
"""A BVH `Frame Time` has a few decimals (0.03333333): the rate it gives is rounded to a
thousandth of a frame per second (30, not 30.0000036)."""

GLB_HEADER = struct.Struct("<III")
"""A .glb file's header (magic, version, length), followed by its JSON chunk."""
GLB_CHUNK = struct.Struct("<II")
"""A chunk's header: its length and type."""


def import_clip(path: str | Path) -> list[bpy.types.Object]:
    """Import one clip into the current scene, first setting the scene's frame rate and range
    to the clip's. Returns the objects the import made.

    Raises:
        ValueError: a file of another kind (its suffix is not one of glTF, USD or BVH's).
    """
    path = Path(path)
    suffix = path.suffix.lower()
    before = set(bpy.data.objects)
    scene = bpy.context.scene
    if suffix in GLTF_SUFFIXES:
        set_scene_time(scene, *gltf_timing(path))
        bpy.ops.import_scene.gltf(filepath=str(path), disable_bone_shape=True)  # no stray Icosphere object
        return _created(before)
    if suffix in USD_SUFFIXES:
        bpy.ops.wm.usd_import(filepath=str(path), set_frame_range=True)
        created = _created(before)
        set_scene_time(scene, usd_fps(created), None)
        return created
    if suffix in BVH_SUFFIXES:
        set_scene_time(scene, *bvh_timing(path))
        bpy.ops.import_anim.bvh(
            filepath=str(path), global_scale=BVH_SCALE, frame_start=1, use_fps_scale=False, update_scene_fps=False
        )
        created = _created(before)
        shift_keys(created, -1)  # Blender's BVH importer starts at frame 1 at the earliest
        return created
    raise ValueError(f"{path.name}: not a clip this script imports ({', '.join(SUFFIXES)})")


def _created(before: set[bpy.types.Object]) -> list[bpy.types.Object]:
    """The objects that are not in `before`."""
    return [obj for obj in bpy.data.objects if obj not in before]


def set_scene_time(scene: bpy.types.Scene, fps: float | None, frames: int | None) -> None:
    """Set the scene's frame rate (`fps`/`fps_base` hold a fractional rate exactly) and its
    range to frames 0 .. frames - 1; None leaves that part alone."""
    if fps is not None:
        whole = max(1, round(fps))
        scene.render.fps = whole
        scene.render.fps_base = whole / fps
    if frames is not None:
        scene.frame_start = 0
        scene.frame_end = max(frames - 1, 0)
        scene.frame_set(0)


def shift_keys(objects: list[bpy.types.Object], frames: float) -> None:
    """Move every key of the objects' actions by `frames`."""
    for obj in objects:
        action = obj.animation_data.action if obj.animation_data else None
        for curve in _fcurves(action) if action else []:
            for key in curve.keyframe_points:
                for point in (key.co, key.handle_left, key.handle_right):
                    point.x += frames
            curve.update()


def _fcurves(action: bpy.types.Action) -> list[bpy.types.FCurve]:
    """An action's F-curves, in layered actions (Blender 4.4 and later) or older ones."""
    if not hasattr(action, "layers"):
        return list(action.fcurves)
    return [
        curve for layer in action.layers for strip in layer.strips for bag in strip.channelbags for curve in bag.fcurves
    ]


def gltf_document(path: Path) -> dict:
    """The JSON of a .gltf file, or of a .glb file's first chunk."""
    data = path.read_bytes()
    if path.suffix.lower() == ".gltf":
        return json.loads(data)
    length, _ = GLB_CHUNK.unpack_from(data, GLB_HEADER.size)
    start = GLB_HEADER.size + GLB_CHUNK.size
    return json.loads(data[start : start + length])


def gltf_timing(path: Path) -> tuple[float | None, int | None]:
    """A glTF file's frame rate (quadpipe's `asset.extras.fps`) and its frame count (the last
    key time of its animations, times the rate); None where the file does not say."""
    document = gltf_document(path)
    fps = document.get("asset", {}).get("extras", {}).get("fps")
    accessors = document.get("accessors", [])
    ends = [
        accessors[sampler["input"]]["max"][0]
        for animation in document.get("animations", [])
        for sampler in animation["samplers"]
        if "max" in accessors[sampler["input"]]
    ]
    if fps is None or not ends:
        return fps, None
    return float(fps), round(max(ends) * float(fps)) + 1


def usd_fps(objects: list[bpy.types.Object]) -> float | None:
    """The frame rate quadpipe wrote on a USD stage's `/World`, which Blender's importer made one
    of `objects` (None: not a quadpipe file)."""
    for obj in objects:
        if USD_FPS_PROPERTY in obj:
            return float(obj[USD_FPS_PROPERTY])
    return None


def bvh_timing(path: Path) -> tuple[float | None, int | None]:
    """A BVH file's frame rate (1 / `Frame Time`, rounded) and frame count (`Frames`)."""
    text = path.read_text(encoding="utf-8", errors="replace")
    frames = re.search(r"^\s*Frames:\s*(\d+)", text, re.MULTILINE)
    frame_time = re.search(r"^\s*Frame Time:\s*([0-9.eE+-]+)", text, re.MULTILINE)
    seconds = float(frame_time.group(1)) if frame_time else 0.0
    fps = round(1.0 / seconds, BVH_FPS_DECIMALS) if seconds > 0 else None
    return fps, int(frames.group(1)) if frames else None


class QUADPIPE_OT_import_clip(bpy.types.Operator):
    """Import a quadpipe clip at its frame rate and frame range"""

    bl_idname = "quadpipe.import_clip"
    bl_label = "Import quadpipe clip"
    bl_options = {"REGISTER", "UNDO"}

    filepath: bpy.props.StringProperty(subtype="FILE_PATH")  # type: ignore[valid-type]
    filter_glob: bpy.props.StringProperty(  # type: ignore[valid-type]
        default=";".join(f"*{suffix}" for suffix in SUFFIXES), options={"HIDDEN"}
    )

    def execute(self, context: bpy.types.Context) -> set[str]:
        """Import the chosen file."""
        try:
            import_clip(self.filepath)
        except ValueError as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        return {"FINISHED"}

    def invoke(self, context: bpy.types.Context, event: bpy.types.Event) -> set[str]:
        """Open the file browser."""
        context.window_manager.fileselect_add(self)
        return {"RUNNING_MODAL"}


def _menu_entry(menu: bpy.types.Menu, context: bpy.types.Context) -> None:
    menu.layout.operator(QUADPIPE_OT_import_clip.bl_idname, text="quadpipe clip (.glb .usdc .bvh)")


def register() -> None:
    """Add File > Import > quadpipe clip."""
    bpy.utils.register_class(QUADPIPE_OT_import_clip)
    bpy.types.TOPBAR_MT_file_import.append(_menu_entry)


def unregister() -> None:
    """Remove File > Import > quadpipe clip."""
    bpy.types.TOPBAR_MT_file_import.remove(_menu_entry)
    bpy.utils.unregister_class(QUADPIPE_OT_import_clip)


def main(argv: list[str]) -> None:
    """Import the files named after `--`; without any, add the File > Import menu entry."""
    paths = argv[argv.index("--") + 1 :] if "--" in argv else []
    if not paths:
        register()
        return
    for path in paths:
        import_clip(path)
        scene = bpy.context.scene
        fps = scene.render.fps / scene.render.fps_base
        print(f"quadpipe: imported {path} at {fps:g} fps, frames {scene.frame_start}-{scene.frame_end}")


if __name__ == "__main__":
    main(sys.argv)
