"""How exported scenes are laid out for an animator's tools: one root per animal and per prop,
terrain apart, props named as in the scene with materials, and props drawn only while they are
in the scene (a thrown box before its throw), never moved through the ground between keys.

Blender itself is exercised by tests/test_blender.py; these read the files directly.
"""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from quadpipe.exporters import export_clip
from quadpipe.exporters.npz import load_clip
from tests.clips import dog_clip, two_dog_clip
from tests.test_exporters import accessor, needs_node, read_gltf, run_node, usd_errors

ENTERS = 25
"""The frame from which the late prop is in the scene."""


def late_prop_clip():
    """The exporter tests' dog and box, the box out of the scene (parked far under the floor, as
    a thrown object waits) until frame ENTERS."""
    clip = dog_clip()
    (box,) = clip.props
    present = np.arange(clip.frame_count) >= ENTERS
    positions = box.positions.copy()
    positions[~present] = (0.0, 0.0, -30.0)
    late = dataclasses.replace(box, positions=positions, present=present)
    return dataclasses.replace(clip, props=[late])


@pytest.fixture(scope="module")
def late(tmp_path_factory):
    folder = tmp_path_factory.mktemp("late")
    clip = late_prop_clip()
    return clip, {suffix: export_clip(clip, folder / f"late{suffix}") for suffix in (".glb", ".usda", ".npz")}


def test_gltf_gives_each_animal_one_root_node_named_after_it(tmp_path):
    clip = two_dog_clip()
    document, _ = read_gltf(export_clip(clip, tmp_path / "two.glb"))
    nodes = document["nodes"]
    roots = [nodes[n]["name"] for n in document["scenes"][0]["nodes"]]
    names = [track.name for track in clip.animals]
    assert roots == [names[0], f"{names[0]}_body", names[1], f"{names[1]}_body", "terrain"]
    for name, skin in zip(names, document["skins"]):
        root = next(node for node in nodes if node["name"] == name)
        assert "mesh" not in root and "translation" not in root and "rotation" not in root
        assert root["children"] == [skin["joints"][0]]


def test_usd_holds_the_animals_as_skeletons_named_after_them_and_props_with_materials(tmp_path):
    from pxr import Usd, UsdGeom, UsdShade

    clip = two_dog_clip()
    stage = Usd.Stage.Open(str(export_clip(clip, tmp_path / "two.usda")))
    animals = stage.GetPrimAtPath("/World/animals")
    assert animals.GetTypeName() == "SkelRoot"
    assert [(p.GetName(), p.GetTypeName()) for p in animals.GetChildren()] == [
        (track.name, "Skeleton") for track in clip.animals
    ]
    for track in clip.animals:
        body = stage.GetPrimAtPath(f"/World/animals/{track.name}/{track.name}_body")
        assert body.IsA(UsdGeom.Mesh)
    clip = dog_clip()
    stage = Usd.Stage.Open(str(export_clip(clip, tmp_path / "dog.usda")))
    crate = stage.GetPrimAtPath("/World/props/crate")
    assert crate.IsA(UsdGeom.Mesh)
    material, _ = UsdShade.MaterialBindingAPI(crate).ComputeBoundMaterial()
    shader = material.ComputeSurfaceSource()[0]
    assert shader.GetIdAttr().Get() == "UsdPreviewSurface"
    colour = np.array(shader.GetInput("diffuseColor").Get())
    np.testing.assert_allclose(colour, clip.props[0].shape.rgba[:3], atol=1e-6)


def test_npz_keeps_when_a_prop_is_in_the_scene(late):
    clip, files = late
    np.testing.assert_array_equal(load_clip(files[".npz"]).props[0].present, clip.props[0].present)
    assert load_clip(export_clip(dog_clip(), files[".npz"].with_name("always.npz"))).props[0].present is None


def gltf_channel(document, binary, node: int, path: str):
    """(times, values, interpolation) of the channel moving `node`'s `path`."""
    (animation,) = document["animations"]
    channel = next(c for c in animation["channels"] if c["target"] == {"node": node, "path": path})
    sampler = animation["samplers"][channel["sampler"]]
    return (
        accessor(document, binary, sampler["input"]),
        accessor(document, binary, sampler["output"]),
        sampler["interpolation"],
    )


def test_gltf_hides_a_prop_until_it_enters_and_holds_it_there(late):
    clip, files = late
    document, binary = read_gltf(files[".glb"])
    node = next(i for i, n in enumerate(document["nodes"]) if n["name"] == "crate")
    assert document["nodes"][node]["scale"] == [0.0, 0.0, 0.0]
    times, scales, interpolation = gltf_channel(document, binary, node, "scale")
    assert interpolation == "STEP"
    np.testing.assert_allclose(times.ravel(), [0.0, ENTERS / clip.fps], rtol=1e-6)
    np.testing.assert_array_equal(scales, [[0, 0, 0], [1, 1, 1]])
    _, translations, _ = gltf_channel(document, binary, node, "translation")
    entry = translations[ENTERS]
    np.testing.assert_array_equal(translations[:ENTERS], np.tile(entry, (ENTERS, 1)))
    assert translations[:, 1].min() > 0.0, "the box goes under the ground"


def test_usd_hides_a_prop_until_it_enters_and_holds_it_there(late):
    from pxr import Usd, UsdGeom

    clip, files = late
    stage = Usd.Stage.Open(str(files[".usda"]))
    crate = UsdGeom.Mesh(stage.GetPrimAtPath("/World/props/crate"))
    visibility = [crate.ComputeVisibility(Usd.TimeCode(frame)) for frame in range(clip.frame_count)]
    assert visibility == [UsdGeom.Tokens.invisible] * ENTERS + [UsdGeom.Tokens.inherited] * (clip.frame_count - ENTERS)
    heights = []
    for frame in range(clip.frame_count):
        matrix = np.array(crate.ComputeLocalToWorldTransform(Usd.TimeCode(frame)))
        scale = np.linalg.norm(matrix[:3, :3], axis=1)
        np.testing.assert_allclose(scale, 1.0 if frame >= ENTERS else 0.0, atol=1e-6)
        heights.append(matrix[3, 2])
    assert min(heights) > 0.0, "the box goes under the ground"
    np.testing.assert_allclose(heights[:ENTERS], heights[ENTERS])


@needs_node
def test_khronos_validator_passes_a_late_prop(late):
    issues = run_node("validate_gltf.mjs", str(late[1][".glb"]))["issues"]
    assert (issues["numErrors"], issues["numWarnings"]) == (0, 0), json.dumps(issues["messages"], indent=1)


def test_usd_validation_passes_a_late_prop(late):
    assert usd_errors(late[1][".usda"]) == []


# --------------------------------------------------------------------------- every shipped scene

SCENE_CLIP_SECONDS = 0.5


def _shipped_scenes() -> list[str]:
    from quadpipe.core import configs

    return list(configs.available("scenes"))


@pytest.mark.slow
@needs_node
@pytest.mark.parametrize("scene", _shipped_scenes())
def test_every_shipped_scene_bakes_valid_gltf_and_usd(scene, tmp_path):
    """Terrain, props and crowds of every scene: the Khronos validator and UsdValidation pass."""
    from quadpipe.sim.simulation import simulate

    clip = simulate("dog", "spine_walk", seconds=SCENE_CLIP_SECONDS, scene=scene).clip
    glb = export_clip(clip, tmp_path / "scene.glb")
    issues = run_node("validate_gltf.mjs", str(glb))["issues"]
    assert (issues["numErrors"], issues["numWarnings"]) == (0, 0), json.dumps(issues["messages"], indent=1)
    assert usd_errors(export_clip(clip, tmp_path / "scene.usdc")) == []
