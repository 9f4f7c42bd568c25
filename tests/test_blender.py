"""Clips imported into Blender with the shipped script, as an animator would.

Blender runs as `bpy` from PyPI in its own environment, `.venv-blender` (Python 3.11, installed
by scripts/install_blender.sh, which scripts/install.sh calls). Three short clips are baked once
(a dog walking, the crowd scene's ten dogs, the throws scene until its first box has flown),
written as .glb and .usdc (and .gltf and .bvh for the walk, .usdz for the throws), written out by `quadpipe blender-script` and
imported, each into a fresh scene, by one Blender process (tests/blender_report.py), which
reports what Blender made of them.
"""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import numpy as np
import pytest

from quadpipe.clip.kinematics import to_y_up
from quadpipe.exporters import blender_script, export_clip
from tests.conftest import REPO, cached_simulation
from tests.test_exporters import needs_node, run_node, usd_errors

BLENDER_PYTHON = REPO / ".venv-blender" / "bin" / "python"
REPORTER = REPO / "tests" / "blender_report.py"

CLIPS = {
    "walk": ("dog", "spine_walk", 2.0, "flat"),
    "crowd": ("dog", "spine_walk", 1.0, "crowd"),
    "throws": ("dog", "spine_walk", 3.6, "throws"),
}
"""Name -> (animal, controller, seconds, scene). The throws clip ends after its first throw (3 s)."""

FORMATS = {"walk": (".glb", ".gltf", ".usdc", ".bvh"), "crowd": (".glb", ".usdc"), "throws": (".glb", ".usdc", ".usdz")}
USD_SUFFIXES = (".usdc", ".usdz")
GLTF_SUFFIXES = (".glb", ".gltf")
FILES = [(name, suffix) for name, suffixes in FORMATS.items() for suffix in suffixes]

HEAD_TOLERANCE_HP = 1e-4
"""Blender's bone heads must match the clip's joints within this, in pelvis heights."""

GROUND_TOLERANCE_HP = 1e-4
"""A prop's origin is never below the ground (z = 0) by more than this while it is shown."""

BLENDER_TIMEOUT_S = 240


@pytest.fixture(scope="module")
def clips():
    return {
        name: cached_simulation(animal, controller, seconds, scene).clip
        for name, (animal, controller, seconds, scene) in CLIPS.items()
    }


@pytest.fixture(scope="module")
def files(clips, tmp_path_factory) -> dict[tuple[str, str], Path]:
    folder = tmp_path_factory.mktemp("blender")
    return {(name, suffix): export_clip(clips[name], folder / f"{name}{suffix}") for name, suffix in FILES}


def frames_checked(clip) -> list[int]:
    """The three frames whose bone heads are compared: first, middle, last."""
    return [0, clip.frame_count // 2, clip.frame_count - 1]


@pytest.fixture(scope="module")
def reports(clips, files, tmp_path_factory) -> dict[tuple[str, str], dict]:
    """What Blender made of every file (one Blender process imports them all, each into a fresh scene)."""
    if not BLENDER_PYTHON.exists():
        pytest.fail(
            f"Blender's Python ({BLENDER_PYTHON}) is missing: run scripts/install.sh (it runs scripts/install_blender.sh)"
        )
    folder = tmp_path_factory.mktemp("script")
    (folder / "quadpipe_import.py").write_text(blender_script(), encoding="utf-8")
    lengths = {clip.frame_count for clip in clips.values()}
    assert len(lengths) == len(clips), "the clips' lengths must differ, so each is checked at its own frames"
    jobs, out = folder / "clips.json", folder / "report.json"
    jobs.write_text(json.dumps({str(path): frames_checked(clips[name]) for (name, _), path in files.items()}))
    result = subprocess.run(
        [str(BLENDER_PYTHON), str(REPORTER), str(folder), str(jobs), str(out)],
        capture_output=True,
        text=True,
        timeout=BLENDER_TIMEOUT_S,
    )
    assert result.returncode == 0, result.stdout[-2000:] + result.stderr[-4000:]
    by_path = json.loads(out.read_text(encoding="utf-8"))
    return {key: by_path[str(path)] for key, path in files.items()}


def test_the_cli_writes_the_shipped_script(cli, tmp_path):
    result = cli("blender-script", "-o", str(tmp_path / "quadpipe_import.py"))
    assert result.returncode == 0, result.stderr
    assert (tmp_path / "quadpipe_import.py").read_text(encoding="utf-8") == blender_script()
    refused = cli("blender-script", "-o", str(tmp_path / "quadpipe_import.txt"))
    assert refused.returncode == 1 and "wrong-suffix" in refused.stderr
    assert not (tmp_path / "quadpipe_import.txt").exists()


def test_the_script_runs_from_the_command_line(files, tmp_path):
    if not BLENDER_PYTHON.exists():
        pytest.fail(f"Blender's Python ({BLENDER_PYTHON}) is missing: run scripts/install.sh")
    script = tmp_path / "quadpipe_import.py"
    script.write_text(blender_script(), encoding="utf-8")
    result = subprocess.run(
        [str(BLENDER_PYTHON), str(script), "--", str(files["walk", ".bvh"])],
        capture_output=True,
        text=True,
        timeout=BLENDER_TIMEOUT_S,
    )
    assert result.returncode == 0, result.stderr[-4000:]
    assert "at 30 fps, frames 0-60" in result.stdout


MENU_CHECK = """
import json, sys
import bpy
import quadpipe_import
quadpipe_import.register()
entries = [draw.__name__ for draw in bpy.types.TOPBAR_MT_file_import._dyn_ui_initialize()]
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.quadpipe.import_clip(filepath=sys.argv[1])
scene = bpy.context.scene
print(json.dumps([entries, scene.render.fps / scene.render.fps_base, scene.frame_start, scene.frame_end]))
"""
"""Run in Blender: register the script as Text Editor's Run Script does, then use its File > Import entry."""


def test_the_import_menu_entry_imports_a_clip(clips, files, tmp_path):
    if not BLENDER_PYTHON.exists():
        pytest.fail(f"Blender's Python ({BLENDER_PYTHON}) is missing: run scripts/install.sh")
    (tmp_path / "quadpipe_import.py").write_text(blender_script(), encoding="utf-8")
    result = subprocess.run(
        [str(BLENDER_PYTHON), "-c", MENU_CHECK, str(files["crowd", ".usdc"])],
        capture_output=True,
        text=True,
        timeout=BLENDER_TIMEOUT_S,
        cwd=tmp_path,
    )
    assert result.returncode == 0, result.stderr[-4000:]
    entries, fps, start, end = json.loads(result.stdout.strip().splitlines()[-1])
    assert "_menu_entry" in entries
    assert (fps, start, end) == (clips["crowd"].fps, 0, clips["crowd"].frame_count - 1)


@pytest.mark.parametrize(("name", "suffix"), FILES)
def test_the_scene_takes_the_clips_fps_and_frame_range(clips, reports, name, suffix):
    report, clip = reports[name, suffix], clips[name]
    assert report["fps"] == pytest.approx(clip.fps, rel=1e-9)
    assert (report["frame_start"], report["frame_end"]) == (0, clip.frame_count - 1)


@pytest.mark.parametrize(("name", "suffix"), [f for f in FILES if f[1] != ".bvh"])
def test_one_armature_per_animal_named_after_it_with_its_skinned_body(clips, reports, name, suffix):
    report, clip = reports[name, suffix], clips[name]
    assert sorted(report["armatures"]) == sorted(track.name for track in clip.animals)
    assert all("ARMATURE" not in entry["parents"] for entry in report["armatures"].values())
    bodies = {mesh: entry for mesh, entry in report["meshes"].items() if entry["armature"]}
    assert sorted(entry["armature"] for entry in bodies.values()) == sorted(report["armatures"])
    for mesh, entry in bodies.items():
        assert entry["parent"] == entry["armature"], f"{mesh} is not parented to its armature"
        assert entry["weighted"] == entry["vertices"] > 0, (
            f"{mesh}: {entry['weighted']} of {entry['vertices']} vertices weighted"
        )


@pytest.mark.parametrize(("name", "suffix"), [f for f in FILES if f[1] != ".bvh"])
def test_props_and_terrain_stand_apart_from_the_armatures_and_show_only_in_the_scene(clips, reports, name, suffix):
    report, clip = reports[name, suffix], clips[name]
    hp = min(track.pelvis_height for track in clip.animals)
    loose = {mesh: entry for mesh, entry in report["meshes"].items() if not entry["armature"]}
    assert sorted(loose) == sorted([prop.name for prop in clip.props] + ["terrain"]), (
        "meshes other than props and terrain"
    )
    for prop in clip.props:
        entry = loose[prop.name]
        assert "ARMATURE" not in entry["parents"], f"{prop.name} is under an armature"
        assert entry["shown"] == prop.presence().astype(float).tolist(), f"{prop.name} shown on the wrong frames"
        if prop.presence().any():
            assert entry["lowest_z"] >= -GROUND_TOLERANCE_HP * hp, f"{prop.name} goes through the ground"
    for mesh, entry in loose.items():
        assert "ARMATURE" not in entry["parents"], f"{mesh} is under an armature"


def test_the_throws_clip_has_a_box_entering_the_scene(clips):
    """The recording marks a thrown box absent until its throw, so the checks above see one enter."""
    presence = {prop.name: prop.presence() for prop in clips["throws"].props}
    assert presence["ball"].all()
    assert not presence["thrown0"][0] and presence["thrown0"][-1]
    assert not presence["thrown1"].any()


def blender_frame(points: np.ndarray, suffix: str) -> np.ndarray:
    """quadpipe points as Blender places them: USD as they are (z up), glTF and BVH converted
    from their y-up frame by Blender's importers ((x, y, z) -> (x, -z, y))."""
    if suffix in USD_SUFFIXES:
        return points
    y_up = to_y_up(points)
    return np.stack([y_up[..., 0], -y_up[..., 2], y_up[..., 1]], axis=-1)


def bone_name(clip, track, role: str, suffix: str) -> str:
    """The Blender bone of a role: glTF names joints `<animal>_<role>` when a clip holds several animals."""
    return f"{track.name}_{role}" if suffix in GLTF_SUFFIXES and len(clip.animals) > 1 else role


@pytest.mark.parametrize(("name", "suffix"), FILES)
def test_bone_heads_follow_the_clip(clips, reports, name, suffix):
    report, clip = reports[name, suffix], clips[name]
    armatures = (
        report["armatures"] if suffix != ".bvh" else {clip.animals[0].name: next(iter(report["armatures"].values()))}
    )
    worst = 0.0
    for track in clip.animals:
        heads = armatures[track.name]["heads"]
        for frame in frames_checked(clip):
            got = np.array([heads[str(frame)][bone_name(clip, track, role, suffix)] for role in track.roles])
            error = (
                np.linalg.norm(got - blender_frame(track.positions[frame], suffix), axis=-1).max() / track.pelvis_height
            )
            worst = max(worst, float(error))
    assert worst < HEAD_TOLERANCE_HP, f"a bone head is {worst:.2e} HP from the clip"


def test_animals_come_in_scene_order(clips, files):
    """Root nodes (glTF) and skeletons (USD) list the animals in the scene's order."""
    from pxr import Usd

    from tests.test_exporters import read_gltf

    names = [track.name for track in clips["crowd"].animals]
    assert names == [f"dog{k}" for k in range(1, 11)]
    document, _ = read_gltf(files["crowd", ".glb"])
    roots = [document["nodes"][n]["name"] for n in document["scenes"][0]["nodes"]]
    assert [r for r in roots if r in names] == names
    stage = Usd.Stage.Open(str(files["crowd", ".usdc"]))
    assert [prim.GetName() for prim in stage.GetPrimAtPath("/World/animals").GetChildren()] == names


@needs_node
@pytest.mark.parametrize("name", sorted(CLIPS))
def test_khronos_validator_passes_the_scenes(files, name):
    issues = run_node("validate_gltf.mjs", str(files[name, ".glb"]))["issues"]
    assert (issues["numErrors"], issues["numWarnings"]) == (0, 0), json.dumps(issues["messages"], indent=1)


@pytest.mark.parametrize("name", sorted(CLIPS))
def test_usd_validation_passes_the_scenes(files, name):
    assert usd_errors(files[name, ".usdc"]) == []
