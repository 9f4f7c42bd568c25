"""Run by tests/test_blender.py under Blender's Python (bpy from PyPI, .venv-blender):

    python blender_report.py SCRIPT_FOLDER CLIPS.json REPORT.json

imports each clip of CLIPS.json (`{clip path: [frame, ...]}`) into a fresh empty scene with the
shipped script (`quadpipe_import`, found in SCRIPT_FOLDER), all in this one Blender process, and
writes what Blender made of each as JSON, by path: the scene's frame rate and range,
every armature (its parent and its bones' world head positions at the clip's frames),
every mesh (its parent, its armature, how many of its vertices carry weight), and every other
mesh's parent chain, the frames it is shown on (not hidden, not scaled to 0) and its lowest
world height over those.
"""

from __future__ import annotations

import json
import sys

import bpy


def _chain(obj: bpy.types.Object) -> list[str]:
    """The object's ancestors' types, nearest first."""
    chain = []
    while obj.parent is not None:
        obj = obj.parent
        chain.append(obj.type)
    return chain


def _weighted_vertices(obj: bpy.types.Object, armature: bpy.types.Object) -> int:
    """How many vertices have some weight in a vertex group named after one of the armature's bones."""
    bones = {bone.name for bone in armature.data.bones}
    groups = {group.index for group in obj.vertex_groups if group.name in bones}
    return sum(1 for vertex in obj.data.vertices if sum(g.weight for g in vertex.groups if g.group in groups) > 0)


def _report(frames: list[int]) -> dict:
    scene = bpy.context.scene
    report: dict = {
        "fps": scene.render.fps / scene.render.fps_base,
        "frame_start": scene.frame_start,
        "frame_end": scene.frame_end,
        "armatures": {},
        "meshes": {},
        "others": {},
    }
    for obj in bpy.data.objects:
        if obj.type == "ARMATURE":
            report["armatures"][obj.name] = {"parents": _chain(obj), "heads": {}}
        elif obj.type == "MESH":
            modifiers = [m.object.name for m in obj.modifiers if m.type == "ARMATURE" and m.object is not None]
            report["meshes"][obj.name] = {
                "parents": _chain(obj),
                "parent": obj.parent.name if obj.parent else None,
                "armature": modifiers[0] if modifiers else None,
                "vertices": len(obj.data.vertices),
                "weighted": _weighted_vertices(obj, bpy.data.objects[modifiers[0]]) if modifiers else 0,
            }
    for frame in frames:
        scene.frame_set(frame)
        for name, entry in report["armatures"].items():
            armature = bpy.data.objects[name]
            entry["heads"][frame] = {bone.name: list(armature.matrix_world @ bone.head) for bone in armature.pose.bones}
    lowest: dict[str, float] = {}
    shown: dict[str, list[float]] = {}
    for frame in range(scene.frame_start, scene.frame_end + 1):
        scene.frame_set(frame)
        for obj in bpy.data.objects:
            if obj.type == "MESH" and not report["meshes"][obj.name]["armature"]:
                visible = not obj.hide_viewport and obj.matrix_world.to_scale().length > 0
                shown.setdefault(obj.name, []).append(1.0 if visible else 0.0)
                if visible:
                    z = obj.matrix_world.translation.z
                    lowest[obj.name] = min(lowest.get(obj.name, z), z)
    for name, frames_shown in shown.items():
        report["meshes"][name]["shown"] = frames_shown
        report["meshes"][name]["lowest_z"] = lowest.get(name)
    return report


def main(argv: list[str]) -> None:
    folder, jobs, output = argv
    sys.path.insert(0, folder)
    import quadpipe_import

    with open(jobs, encoding="utf-8") as stream:
        frames_by_clip: dict[str, list[int]] = json.load(stream)
    reports = {}
    for clip, frames in frames_by_clip.items():
        bpy.ops.wm.read_factory_settings(use_empty=True)
        quadpipe_import.import_clip(clip)
        reports[clip] = _report(frames)
    with open(output, "w", encoding="utf-8") as stream:
        json.dump(reports, stream)


if __name__ == "__main__":
    main(sys.argv[1:])
