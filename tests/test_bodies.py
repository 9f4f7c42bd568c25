"""Body meshes (quadpipe.bodies), for every built-in animal: closed, as big as the animal's mass,
smoothly skinned, deterministic; and what the exporters and the renderer make of them.

Volumes are compared with mass / 1000 kg m^-3 (an animal is about as dense as water).
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np
import pytest

from quadpipe.bodies import INFLUENCES, body_mesh, dress
from quadpipe.clip.model import AnimalTrack
from quadpipe.core import configs
from quadpipe.exporters import export_clip
from tests.clips import dog_clip
from tests.test_exporters import accessor, needs_node, node_matrices, read_gltf, run_node, skel_query, usd_errors

ANIMALS = configs.available("animals")

DENSITY_KG_M3 = 1000.0
VOLUME_TOLERANCE = 0.40
"""A body's volume is within 40 % of its mass / density."""

TRIANGLES = (2_000, 30_000)
"""Sane triangle counts for a body: enough for the silhouette, light for an engine."""

SKINNING_TOLERANCE_HP = 1e-4
"""Skinned vertices read back from a file match the clip's skinning to 1e-4 pelvis heights."""


@functools.cache
def rest_track(animal: str) -> AnimalTrack:
    """The animal in its rest pose, as a simulation records it (one frame)."""
    from quadpipe.sim.simulation import simulate

    return simulate(animal, "rigid", seconds=0.0).clip.animals[0]


@pytest.mark.parametrize("animal", ANIMALS)
def test_every_body_is_closed_and_about_as_big_as_the_animal(animal):
    import trimesh

    track = rest_track(animal)
    body = body_mesh(track)
    solid = trimesh.Trimesh(body.vertices, body.faces, process=False)
    assert solid.is_watertight and solid.is_winding_consistent
    assert solid.volume > 0, "faces point inward"
    expected = track.mass_kg / DENSITY_KG_M3
    assert abs(solid.volume / expected - 1.0) <= VOLUME_TOLERANCE, f"{solid.volume:.4g} m3 for {expected:.4g} m3"
    assert TRIANGLES[0] <= len(body.faces) <= TRIANGLES[1]
    np.testing.assert_allclose(np.linalg.norm(body.normals, axis=1), 1.0, atol=1e-6)
    outward = np.einsum("ij,ij->i", solid.face_normals, body.normals[body.faces].mean(axis=1))
    assert (outward > 0).mean() > 0.99


@pytest.mark.parametrize("animal", ANIMALS)
def test_every_vertex_is_weighted_to_at_most_four_bones(animal):
    track = rest_track(animal)
    body = body_mesh(track)
    assert body.joints.shape == body.weights.shape == (len(body.vertices), INFLUENCES)
    assert (body.weights >= 0).all() and (body.weights[:, 0] > 0).all()
    np.testing.assert_allclose(body.weights.sum(axis=1), 1.0, atol=1e-9)
    assert ((body.joints >= 0) & (body.joints < len(track.roles))).all()


LEGS_INSIDE_THE_BARREL = pytest.mark.xfail(
    strict=True,
    reason="the thesis rat is too short for its 300 g: its legs lie inside the barrel (docs/bodies.md, Volumes)",
)


@pytest.mark.parametrize(
    "animal", [pytest.param(a, marks=LEGS_INSIDE_THE_BARREL) if a == "rat" else a for a in ANIMALS]
)
def test_every_limb_moves_skin(animal):
    track = rest_track(animal)
    body = body_mesh(track)
    used = np.unique(body.joints[body.weights > 0])
    for role in ("pelvis", "head", "lf_elbow", "rh_knee", "tail3", "neck2"):
        assert track.roles.index(role) in used, f"no vertex follows {role}"


def test_skin_blends_at_joints_and_follows_its_own_bone_mid_bone():
    track = rest_track("dog")
    body = body_mesh(track)
    elbow = track.roles.index("lf_elbow")
    start, end = track.rest_start[elbow], track.rest_end[elbow]
    axis = end - start
    t = (body.vertices - start) @ axis / (axis @ axis)
    across = np.linalg.norm(body.vertices - (start + t[:, None] * axis), axis=1)
    on_leg = across < 0.1 * track.pelvis_height
    own = np.where(body.joints == elbow, body.weights, 0.0).sum(axis=1)
    mid_bone = on_leg & (np.abs(t - 0.5) < 0.1)
    at_joint = on_leg & (np.abs(t) < 0.05)
    assert mid_bone.sum() > 10 and at_joint.sum() > 10
    assert (own[mid_bone] > 0.8).all(), "mid-forearm skin does not follow the forearm"
    assert ((own[at_joint] > 0.1) & (own[at_joint] < 0.9)).mean() > 0.5, "no blending at the elbow"


def test_bodies_are_deterministic(monkeypatch):
    import quadpipe.bodies

    track = rest_track("cat")
    first = body_mesh(track)
    # Made again without the cache, which keeps the other animals' bodies for the tests after this one.
    monkeypatch.setattr(quadpipe.bodies, "_body_mesh", quadpipe.bodies._body_mesh.__wrapped__)
    again = body_mesh(track)
    for name in ("vertices", "normals", "faces", "joints", "weights", "colors"):
        assert getattr(first, name).tobytes() == getattr(again, name).tobytes(), name


def test_dress_keeps_a_body_that_came_with_the_rig_and_bones_removes_it():
    clip = dog_clip()
    given = body_mesh(rest_track("cat"))
    own = dataclasses.replace(clip, animals=[dataclasses.replace(clip.animals[0], body=given)])
    assert dress(own, "body").animals[0].body is given
    assert dress(own, "bones").animals[0].body is None
    assert dress(clip, "body").animals[0].body is not None


# -- in files --------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def clip():
    return dog_clip()


@pytest.fixture(scope="module")
def files(clip, tmp_path_factory):
    folder = tmp_path_factory.mktemp("bodies")
    return {
        suffix: export_clip(clip, folder / f"dog{suffix}") for suffix in (".glb", ".gltf", ".usda", ".usdc", ".usdz")
    }


@needs_node
@pytest.mark.parametrize("suffix", [".glb", ".gltf"])
def test_khronos_validator_passes_the_body(files, suffix):
    issues = run_node("validate_gltf.mjs", str(files[suffix]))["issues"]
    assert (issues["numErrors"], issues["numWarnings"]) == (0, 0), issues["messages"]


@pytest.mark.parametrize("suffix", [".usda", ".usdc", ".usdz"])
def test_usd_validation_passes_the_body(files, suffix):
    assert usd_errors(files[suffix]) == []


def linear_blend(track: AnimalTrack, frame: int, points: np.ndarray, joints: np.ndarray, weights: np.ndarray):
    """Where rest points go at `frame` under linear blend skinning of the clip's bones (quadpipe frame)."""
    from tests.test_exporters import clip_matrices

    result = np.zeros_like(points)
    for k in range(joints.shape[1]):
        bones = joints[:, k]
        moved = np.einsum("nij,nj->ni", clip_matrices(track.rotations[frame, bones]), points - track.rest_start[bones])
        result += weights[:, k, None] * (moved + track.positions[frame, bones])
    return result


def test_gltf_body_skins_like_the_clip(clip, files):
    from tests.test_exporters import Y_UP

    document, binary = read_gltf(files[".glb"])
    node = next(node for node in document["nodes"] if "skin" in node)
    attributes = document["meshes"][node["mesh"]]["primitives"][0]["attributes"]
    points = accessor(document, binary, attributes["POSITION"]).astype(float)
    joints = accessor(document, binary, attributes["JOINTS_0"]).astype(int)
    weights = accessor(document, binary, attributes["WEIGHTS_0"]).astype(float)
    assert (weights[:, 1] > 0).any(), "rigid skinning: the body must blend bones"
    skin = document["skins"][node["skin"]]
    inverse_bind = accessor(document, binary, skin["inverseBindMatrices"]).reshape(-1, 4, 4).transpose(0, 2, 1)
    world = node_matrices(document, binary, clip.frame_count)[:, skin["joints"]]
    homogeneous = np.concatenate([points, np.ones((len(points), 1))], axis=1)
    track = clip.animals[0]
    for frame in (0, clip.frame_count - 1):
        skinning = world[frame] @ inverse_bind
        skinned = np.einsum("nkij,nj,nk->ni", skinning[joints], homogeneous, weights)[:, :3]
        expected = linear_blend(track, frame, points @ Y_UP, joints, weights)
        np.testing.assert_allclose(skinned @ Y_UP, expected, atol=SKINNING_TOLERANCE_HP * track.pelvis_height)


def test_usd_body_is_one_mesh_skinned_with_four_weights_per_point(clip, files):
    from pxr import Usd, UsdGeom, UsdSkel, Vt

    stage = Usd.Stage.Open(str(files[".usdc"]))
    prim = stage.GetPrimAtPath("/World/animals/dog/dog_body")
    assert prim.IsA(UsdGeom.Mesh) and not stage.GetPrimAtPath("/World/animals/dog/meshes")
    binding = UsdSkel.BindingAPI(prim)
    indices, weights = binding.GetJointIndicesPrimvar(), binding.GetJointWeightsPrimvar()
    assert indices.GetInterpolation() == UsdGeom.Tokens.vertex and indices.GetElementSize() == INFLUENCES
    points = np.array(UsdGeom.Mesh(prim).GetPointsAttr().Get())
    values = np.array(weights.Get()).reshape(len(points), INFLUENCES)
    np.testing.assert_allclose(values.sum(axis=1), 1.0, atol=1e-6)
    skeleton, binding = skel_query(stage, "/World/animals")
    (target,) = binding.GetSkinningTargets()
    assert not target.IsRigidlyDeformed() and target.GetNumInfluencesPerComponent() == INFLUENCES
    joints = np.array(indices.Get()).reshape(len(points), INFLUENCES)
    track = clip.animals[0]
    for frame in (0, clip.frame_count - 1):
        transforms = skeleton.ComputeSkinningTransforms(Usd.TimeCode(frame))
        skinned = Vt.Vec3fArray(UsdGeom.Mesh(prim).GetPointsAttr().Get())
        assert target.ComputeSkinnedPoints(transforms, skinned, Usd.TimeCode(frame))
        expected = linear_blend(track, frame, points.astype(float), joints, values)
        np.testing.assert_allclose(np.array(skinned), expected, atol=SKINNING_TOLERANCE_HP * track.pelvis_height)


def test_bones_look_writes_the_bone_meshes(clip, tmp_path):
    from pxr import Usd

    stage = Usd.Stage.Open(str(export_clip(clip, tmp_path / "bones.usda", look="bones")))
    assert stage.GetPrimAtPath("/World/animals/dog/meshes/pelvis") and not stage.GetPrimAtPath(
        "/World/animals/dog/dog_body"
    )
    document, binary = read_gltf(export_clip(clip, tmp_path / "bones.glb", look="bones"))
    node = next(node for node in document["nodes"] if "skin" in node)
    weights = accessor(document, binary, document["meshes"][node["mesh"]]["primitives"][0]["attributes"]["WEIGHTS_0"])
    np.testing.assert_array_equal(weights, np.tile([1.0, 0.0, 0.0, 0.0], (len(weights), 1)))


# -- rendered --------------------------------------------------------------------------------


def test_render_draws_the_body_by_default_and_the_bones_on_request(clip):
    from quadpipe.render import ClipRenderer

    pictures = {}
    for look in ("body", "bones"):
        with ClipRenderer(clip, width=160, height=120, overlays=[], look=look) as renderer:
            pictures[look] = renderer.render(0).astype(int)
    coat = np.array([0.80, 0.62, 0.36]) * 255

    def animal_pixels(picture):
        return (np.abs(picture - coat).sum(axis=-1) < 90).sum()

    assert animal_pixels(pictures["body"]) > 3 * animal_pixels(pictures["bones"])
