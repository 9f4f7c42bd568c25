"""Exporters, driven by the registry: every format is written from a real simulated clip, checked
by its ecosystem's own tools (the Khronos glTF validator, pxr.UsdValidation, three.js's
GLTFLoader, quadpipe's BVH importer), read back independently of the writer, and compared with
the clip frame by frame.

Clip poses are in quadpipe's frame (metres, +X forward, +Y left, +Z up). Position tolerances
are fractions of the animal's pelvis height HP.
"""

from __future__ import annotations

import importlib.util
import json
import os
import shutil
import struct
import subprocess
import zipfile
from pathlib import Path

import numpy as np
import pytest

from quadpipe.core.errors import QuadpipeError
from quadpipe.exporters import export_clip, supported_formats
from quadpipe.exporters.npz import load_clip
from tests.clips import BLOW_UP_FRAME, assert_clips_equal, blown_up_clip, dog_clip, two_dog_clip
from tests.conftest import REPO

FORMATS = [fmt.suffix for fmt in supported_formats()]
EXPECTED_FORMATS = {".bvh", ".glb", ".gltf", ".npz", ".usda", ".usdc", ".usdz"}
USD_FORMATS = [".usda", ".usdc", ".usdz"]
GLTF_FORMATS = [".glb", ".gltf"]

POSITION_TOLERANCE_HP = 1e-4
"""Read-back joint positions match the clip to 1e-4 pelvis heights."""

ROTATION_TOLERANCE = 1e-4
"""Read-back rotation matrices match the clip's to 1e-4 per entry."""

JS = REPO / "tests" / "js"
NODE = shutil.which("node")
needs_node = pytest.mark.skipif(
    NODE is None, reason="node is not installed: the glTF validator and three.js checks need Node.js 18+"
)

Y_UP = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
"""glTF/BVH axes from quadpipe's: x = left (+Y), y = up (+Z), z = forward (+X). Rows map
quadpipe vectors to y-up ones: v_yup = Y_UP @ v."""

CM = 0.01


# -- shared helpers (independent of the writers) ---------------------------------------------


def quat_matrix(w, x, y, z) -> np.ndarray:
    """Rotation matrices (..., 3, 3) of quaternions given by component arrays."""
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], axis=-1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], axis=-1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], axis=-1),
        ],
        axis=-2,
    )


def clip_matrices(rotations: np.ndarray) -> np.ndarray:
    """World rotation matrices of (..., 4) clip quaternions (w, x, y, z)."""
    q = rotations / np.linalg.norm(rotations, axis=-1, keepdims=True)
    return quat_matrix(q[..., 0], q[..., 1], q[..., 2], q[..., 3])


def tolerance(clip) -> float:
    return POSITION_TOLERANCE_HP * clip.animals[0].pelvis_height


def expected_skinned(track, frame: int, rest_points: np.ndarray, bones: np.ndarray) -> np.ndarray:
    """Where rest-pose points rigidly attached to `bones` lie at `frame` (quadpipe frame)."""
    matrices = clip_matrices(track.rotations[frame, bones])
    offsets = rest_points - track.rest_start[bones]
    return np.einsum("nij,nj->ni", matrices, offsets) + track.positions[frame, bones]


def folder_listing(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir())


@pytest.fixture(scope="module")
def clip():
    return dog_clip()


@pytest.fixture(scope="module")
def written(clip, tmp_path_factory) -> dict[str, Path]:
    """The dog clip exported once to every format: suffix -> file."""
    folder = tmp_path_factory.mktemp("exports")
    return {suffix: export_clip(clip, folder / f"dog{suffix}") for suffix in FORMATS}


@pytest.fixture(scope="module")
def bones_written(clip, tmp_path_factory) -> dict[str, Path]:
    """The dog clip with its bones' shapes (`look="bones"`, rigidly skinned), in glTF and USD."""
    folder = tmp_path_factory.mktemp("bones")
    return {suffix: export_clip(clip, folder / f"dog{suffix}", look="bones") for suffix in (".glb", ".usdc")}


# -- registry and bad input ------------------------------------------------------------------


def test_registry_lists_every_format_available_with_a_description():
    formats = {fmt.suffix: fmt for fmt in supported_formats()}
    assert set(formats) == EXPECTED_FORMATS
    for fmt in formats.values():
        assert fmt.available and fmt.install_hint is None, fmt
        assert len(fmt.description) > 20, fmt


@pytest.fixture
def without_pxr(monkeypatch):
    """Make usd-core look uninstalled, as on a machine without it."""
    real_find_spec = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util, "find_spec", lambda name, *a: None if name == "pxr" else real_find_spec(name, *a)
    )


def test_a_missing_optional_package_shows_only_when_its_format_is_used(without_pxr, clip, tmp_path):
    formats = {fmt.suffix: fmt for fmt in supported_formats()}
    for suffix in USD_FORMATS:
        assert not formats[suffix].available and formats[suffix].install_hint == "pip install usd-core"
    assert formats[".glb"].available
    export_clip(clip, tmp_path / "dog.glb")
    with pytest.raises(QuadpipeError) as error:
        export_clip(clip, tmp_path / "dog.usdz")
    assert error.value.issues[0].code == "format-unavailable"
    assert error.value.issues[0].hint == "pip install usd-core"
    with pytest.raises(QuadpipeError) as error:
        export_clip(clip, tmp_path / "dog.fbx")
    assert ".usda (pip install usd-core)" in error.value.issues[0].hint
    assert folder_listing(tmp_path) == ["dog.glb"]


@pytest.mark.parametrize("name", ["dog.fbx", "dog", "dog.glb.txt"])
def test_an_unknown_suffix_is_refused_listing_the_formats(clip, tmp_path, name):
    with pytest.raises(QuadpipeError) as error:
        export_clip(clip, tmp_path / name)
    issue = error.value.issues[0]
    assert issue.code == "unknown-format" and issue.where.file == str(tmp_path / name)
    assert all(suffix in issue.hint for suffix in EXPECTED_FORMATS)
    assert folder_listing(tmp_path) == []


@pytest.mark.parametrize("suffix", FORMATS)
def test_an_unwritable_path_is_refused_and_leaves_nothing(clip, tmp_path, suffix):
    (tmp_path / "a_file").write_text("not a folder")
    (tmp_path / f"folder{suffix}").mkdir()
    for target in (
        tmp_path / "missing" / f"dog{suffix}",
        tmp_path / "a_file" / f"dog{suffix}",
        tmp_path / f"folder{suffix}",
    ):
        with pytest.raises(QuadpipeError) as error:
            export_clip(clip, target)
        assert error.value.issues[0].code == "unwritable-output", target
        assert str(target.with_suffix("")) in error.value.format()  # a .gltf may name its .bin
    assert folder_listing(tmp_path) == ["a_file", f"folder{suffix}"]
    assert list((tmp_path / f"folder{suffix}").iterdir()) == []


@pytest.mark.parametrize("suffix", FORMATS)
def test_a_failure_while_writing_leaves_no_partial_file(clip, tmp_path, suffix, monkeypatch):
    existing = tmp_path / f"dog{suffix}"
    existing.write_bytes(b"previous export")

    def full_disk(*_):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "replace", full_disk)
    with pytest.raises(QuadpipeError) as error:
        export_clip(clip, existing)
    assert error.value.issues[0].code == "unwritable-output"
    assert "No space left on device" in error.value.issues[0].message
    assert folder_listing(tmp_path) == [existing.name]
    assert existing.read_bytes() == b"previous export"


@pytest.mark.parametrize("suffix", FORMATS)
def test_a_blown_up_clip_is_refused_and_nothing_is_written(tmp_path, suffix):
    with pytest.raises(QuadpipeError) as error:
        export_clip(blown_up_clip(), tmp_path / f"dog{suffix}")
    issue = error.value.issues[0]
    assert issue.code == "bad-clip" and "blew up" in issue.message and "allow_partial" in issue.hint
    assert folder_listing(tmp_path) == []


def test_nan_poses_are_refused_even_when_the_status_says_ok(tmp_path):
    broken = blown_up_clip()
    broken.metadata["status"] = "ok"
    with pytest.raises(QuadpipeError) as error:
        export_clip(broken, tmp_path / "dog.glb")
    assert error.value.issues[0].code == "bad-clip" and f"frame {BLOW_UP_FRAME}" in error.value.issues[0].message


def test_allow_partial_keeps_the_frames_before_the_blow_up(tmp_path):
    broken = blown_up_clip()
    exported = load_clip(export_clip(broken, tmp_path / "dog.npz", allow_partial=True))
    assert exported.frame_count == BLOW_UP_FRAME
    np.testing.assert_array_equal(exported.animals[0].positions, broken.animals[0].positions[:BLOW_UP_FRAME])
    assert exported.metadata["status"] == broken.metadata["status"]
    assert exported.metadata["exported_frames"] == f"{BLOW_UP_FRAME} of {broken.frame_count}"


@pytest.mark.parametrize("suffix", FORMATS)
def test_the_same_clip_gives_byte_identical_files(written, tmp_path, suffix):
    again = export_clip(dog_clip(), tmp_path / f"dog{suffix}")
    assert again.read_bytes() == written[suffix].read_bytes()
    if suffix == ".gltf":
        assert again.with_suffix(".bin").read_bytes() == written[suffix].with_suffix(".bin").read_bytes()
    if suffix in (".npz", ".usdz"):  # a zip records dates: they must not be the time of writing
        with zipfile.ZipFile(again) as archive:
            assert {info.date_time[0] for info in archive.infolist()} <= {1980, 2000}


# -- npz ---------------------------------------------------------------------------------------


def test_npz_loads_back_an_equal_clip(tmp_path):
    clip = dog_clip()
    clip.sensors["speed"] = np.linspace(0.0, 1.0, clip.frame_count)
    clip.sensors["contacts"] = clip.animals[0].foot_contacts.astype(np.int8)
    assert_clips_equal(load_clip(export_clip(clip, tmp_path / "dog.npz")), clip)
    two = two_dog_clip()
    assert_clips_equal(load_clip(export_clip(two, tmp_path / "two.npz")), two)


def test_npz_opens_with_plain_numpy(written, clip):
    with np.load(written[".npz"], allow_pickle=False) as archive:
        np.testing.assert_array_equal(archive["animal0.positions"], clip.animals[0].positions)
        assert json.loads(str(archive["header"][()]))["animals"][0]["roles"] == list(clip.animals[0].roles)


def test_npz_loader_rejects_other_files(written, tmp_path):
    with pytest.raises(QuadpipeError) as error:
        load_clip(written[".glb"])
    assert error.value.issues[0].code == "bad-clip-file"
    np.savez(tmp_path / "other.npz", header=np.array(json.dumps({"format": "something", "version": 1})))
    with pytest.raises(QuadpipeError) as error:
        load_clip(tmp_path / "other.npz")
    assert error.value.issues[0].code == "bad-clip-file" and "something" in error.value.issues[0].message
    with pytest.raises(QuadpipeError) as error:
        load_clip(tmp_path / "absent.npz")
    assert error.value.issues[0].code == "file-not-found"


# -- glTF ------------------------------------------------------------------------------------

GLTF_COMPONENTS = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16, 5125: np.uint32, 5126: np.float32}
GLTF_WIDTHS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}


def read_gltf(path: Path) -> tuple[dict, bytes]:
    """The JSON and binary buffer of a .glb, or of a .gltf and its .bin."""
    data = path.read_bytes()
    if path.suffix == ".gltf":
        document = json.loads(data)
        return document, (path.parent / document["buffers"][0]["uri"]).read_bytes()
    magic, version, length = struct.unpack_from("<III", data)
    assert (magic, version, length) == (0x46546C67, 2, len(data))
    json_length, json_kind = struct.unpack_from("<II", data, 12)
    bin_length, bin_kind = struct.unpack_from("<II", data, 20 + json_length)
    assert (json_kind, bin_kind) == (0x4E4F534A, 0x004E4942)
    return json.loads(data[20 : 20 + json_length]), data[28 + json_length : 28 + json_length + bin_length]


def accessor(document: dict, binary: bytes, index: int) -> np.ndarray:
    """An accessor's data as an (count, width) array (tightly packed views)."""
    acc = document["accessors"][index]
    view = document["bufferViews"][acc["bufferView"]]
    dtype = np.dtype(GLTF_COMPONENTS[acc["componentType"]])
    width = GLTF_WIDTHS[acc["type"]]
    start = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
    assert start % dtype.itemsize == 0 and "byteStride" not in view
    return np.frombuffer(binary, dtype, acc["count"] * width, start).reshape(acc["count"], width)


def node_matrices(document: dict, binary: bytes, frames: int) -> np.ndarray:
    """(frames, nodes, 4, 4) world matrices of every node, animation sampled at each key."""
    nodes = document["nodes"]
    trs = np.zeros((frames, len(nodes), 10))
    for index, node in enumerate(nodes):
        trs[:, index, :3] = node.get("translation", [0, 0, 0])
        trs[:, index, 3:7] = node.get("rotation", [0, 0, 0, 1])
        trs[:, index, 7:] = node.get("scale", [1, 1, 1])
    columns = {"translation": slice(0, 3), "rotation": slice(3, 7), "scale": slice(7, 10)}
    for animation in document.get("animations", []):
        for channel in animation["channels"]:
            sampler = animation["samplers"][channel["sampler"]]
            assert sampler["interpolation"] == "LINEAR"
            values = accessor(document, binary, sampler["output"])
            trs[:, channel["target"]["node"], columns[channel["target"]["path"]]] = values
    x, y, z, w = np.moveaxis(trs[..., 3:7], -1, 0)
    local = np.zeros((frames, len(nodes), 4, 4))
    local[..., :3, :3] = quat_matrix(w, x, y, z) * trs[..., None, 7:]
    local[..., :3, 3] = trs[..., :3]
    local[..., 3, 3] = 1.0
    parent = {child: index for index, node in enumerate(nodes) for child in node.get("children", [])}
    world = np.zeros_like(local)
    order = []
    pending = list(document["scenes"][document["scene"]]["nodes"])
    while pending:
        index = pending.pop(0)
        order.append(index)
        pending += nodes[index].get("children", [])
    for index in order:
        world[:, index] = local[:, index] if index not in parent else world[:, parent[index]] @ local[:, index]
    return world


@needs_node
def test_node_tools_are_installed():
    assert (JS / "node_modules" / "gltf-validator").is_dir() and (JS / "node_modules" / "three").is_dir(), (
        "the Node test tools are missing: run scripts/install_node_tools.sh (npm ci in tests/js)"
    )


def run_node(script: str, *args: str) -> dict:
    if not (JS / "node_modules").is_dir():
        pytest.fail("tests/js/node_modules is missing: run scripts/install_node_tools.sh")
    result = subprocess.run([NODE, str(JS / script), *args], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    return json.loads(result.stdout)


@needs_node
@pytest.mark.parametrize("suffix", GLTF_FORMATS)
def test_khronos_validator_finds_no_error_and_no_warning(written, suffix):
    issues = run_node("validate_gltf.mjs", str(written[suffix]))["issues"]
    assert (issues["numErrors"], issues["numWarnings"]) == (0, 0), json.dumps(issues["messages"], indent=1)


@needs_node
def test_khronos_validator_passes_a_two_animal_scene(tmp_path):
    issues = run_node("validate_gltf.mjs", str(export_clip(two_dog_clip(), tmp_path / "two.glb")))["issues"]
    assert (issues["numErrors"], issues["numWarnings"]) == (0, 0), json.dumps(issues["messages"], indent=1)


@pytest.mark.parametrize("suffix", GLTF_FORMATS)
def test_gltf_joints_follow_the_clip_on_every_frame(clip, written, suffix):
    document, binary = read_gltf(written[suffix])
    track = clip.animals[0]
    animation = document["animations"][0]
    times = accessor(document, binary, animation["samplers"][0]["input"])[:, 0]
    np.testing.assert_allclose(times, clip.times(), atol=1e-6)
    world = node_matrices(document, binary, clip.frame_count)
    skin = document["skins"][0]
    joints = world[:, skin["joints"]]
    assert [document["nodes"][j]["name"] for j in skin["joints"]] == list(track.roles)
    np.testing.assert_allclose(joints[..., :3, 3] @ Y_UP, track.positions, atol=tolerance(clip))
    # joints are turned along their bones at rest (quadpipe.clip.bind): the skinning transform,
    # joint world x inverse bind, turns as the clip's bone does
    inverse_bind = accessor(document, binary, skin["inverseBindMatrices"]).reshape(-1, 4, 4).transpose(0, 2, 1)
    np.testing.assert_allclose(
        Y_UP.T @ (joints @ inverse_bind)[..., :3, :3] @ Y_UP, clip_matrices(track.rotations), atol=ROTATION_TOLERANCE
    )
    prop = next(i for i, node in enumerate(document["nodes"]) if node["name"] == "crate")
    np.testing.assert_allclose(world[:, prop, :3, 3] @ Y_UP, clip.props[0].positions, atol=tolerance(clip))


def test_gltf_skinning_moves_each_vertex_with_its_bone(clip, bones_written):
    document, binary = read_gltf(bones_written[".glb"])
    track = clip.animals[0]
    skin = document["skins"][0]
    mesh_node = next(node for node in document["nodes"] if "skin" in node)
    attributes = document["meshes"][mesh_node["mesh"]]["primitives"][0]["attributes"]
    points = accessor(document, binary, attributes["POSITION"]).astype(float)
    joints = accessor(document, binary, attributes["JOINTS_0"])
    weights = accessor(document, binary, attributes["WEIGHTS_0"])
    np.testing.assert_array_equal(weights, np.tile([1.0, 0.0, 0.0, 0.0], (len(weights), 1)))
    inverse_bind = accessor(document, binary, skin["inverseBindMatrices"]).reshape(-1, 4, 4).transpose(0, 2, 1)
    world = node_matrices(document, binary, clip.frame_count)[:, skin["joints"]]
    bones = joints[:, 0].astype(int)
    homogeneous = np.concatenate([points, np.ones((len(points), 1))], axis=1)
    for frame in (0, clip.frame_count // 2, clip.frame_count - 1):
        skinned = np.einsum("nij,nj->ni", world[frame, bones] @ inverse_bind[bones], homogeneous)[:, :3]
        expected = expected_skinned(track, frame, points @ Y_UP, bones)
        np.testing.assert_allclose(skinned @ Y_UP, expected, atol=tolerance(clip))


def sign_flipped(clip):
    """The same motion with every other frame's quaternions negated (q and -q: the same rotation)."""
    for track in clip.animals + clip.props:
        track.rotations[1::2] *= -1.0
    return clip


def test_gltf_accessors_are_exact_and_rotations_continuous(tmp_path):
    document, binary = read_gltf(export_clip(sign_flipped(dog_clip()), tmp_path / "flipped.glb"))
    for index, acc in enumerate(document["accessors"]):
        view = document["bufferViews"][acc["bufferView"]]
        assert view.get("byteOffset", 0) % 4 == 0
        if "min" in acc:
            data = accessor(document, binary, index)
            assert acc["min"] == data.min(axis=0).tolist() and acc["max"] == data.max(axis=0).tolist()
    for animation in document["animations"]:
        for channel in animation["channels"]:
            if channel["target"]["path"] == "rotation":
                quats = accessor(document, binary, animation["samplers"][channel["sampler"]]["output"])
                assert (np.sum(quats[1:] * quats[:-1], axis=1) >= 0).all(), channel
    positions = [p["attributes"]["POSITION"] for mesh in document["meshes"] for p in mesh["primitives"]]
    assert all("min" in document["accessors"][p] for p in positions)


def test_gltf_names_joints_per_animal_when_there_are_several(tmp_path):
    document, _ = read_gltf(export_clip(two_dog_clip(), tmp_path / "two.glb"))
    names = [[document["nodes"][j]["name"] for j in skin["joints"]] for skin in document["skins"]]
    assert names[0][:2] == ["dog_pelvis", "dog_spine0"] and names[1][:2] == ["dog2_pelvis", "dog2_spine0"]


@needs_node
def test_threejs_plays_the_glb_like_the_clip(clip, bones_written):
    track = clip.animals[0]
    frames = [0, 17, 42, clip.frame_count - 1]
    result = run_node("three_pose.mjs", str(bones_written[".glb"]), *(repr(float(t)) for t in clip.times()[frames]))
    (skin,) = result["skins"]
    assert skin["bones"] == list(track.roles)
    bones = np.array(skin["bonePositions"]) @ Y_UP
    np.testing.assert_allclose(bones, track.positions[frames], atol=tolerance(clip))
    document, binary = read_gltf(bones_written[".glb"])
    mesh_node = next(node for node in document["nodes"] if "skin" in node)
    attributes = document["meshes"][mesh_node["mesh"]]["primitives"][0]["attributes"]
    sampled = np.array(skin["vertices"])
    rest = accessor(document, binary, attributes["POSITION"])[sampled].astype(float) @ Y_UP
    owners = accessor(document, binary, attributes["JOINTS_0"])[sampled, 0].astype(int)
    for k, frame in enumerate(frames):
        expected = expected_skinned(track, frame, rest, owners)
        np.testing.assert_allclose(np.array(skin["vertexPositions"][k]) @ Y_UP, expected, atol=tolerance(clip))
    (crate,) = result["nodes"]
    np.testing.assert_allclose(
        np.array(crate["positions"]) @ Y_UP, clip.props[0].positions[frames], atol=tolerance(clip)
    )


# -- USD -------------------------------------------------------------------------------------


def usd_errors(path: Path) -> list[str]:
    """Errors of every registered pxr.UsdValidation validator on the stage at `path`."""
    from pxr import Usd, UsdValidation

    registry = UsdValidation.ValidationRegistry()
    context = UsdValidation.ValidationContext(registry.GetOrLoadAllValidators())
    errors = context.Validate(Usd.Stage.Open(str(path)))
    return [
        f"{e.GetValidator().GetMetadata().name}: {e.GetMessage()}"
        for e in errors
        if e.GetType() == UsdValidation.ValidationErrorType.Error
    ]


def test_usd_validation_catches_a_broken_stage(tmp_path):
    from pxr import Usd

    stage = Usd.Stage.CreateNew(str(tmp_path / "bare.usda"))
    stage.DefinePrim("/thing", "Xform")
    stage.Save()
    assert any("defaultPrim" in error for error in usd_errors(tmp_path / "bare.usda"))


@pytest.mark.parametrize("suffix", USD_FORMATS)
def test_usd_validation_finds_no_error(written, suffix):
    assert usd_errors(written[suffix]) == []


def test_usd_validation_passes_a_two_animal_scene(tmp_path):
    assert usd_errors(export_clip(two_dog_clip(), tmp_path / "two.usda")) == []


@pytest.mark.parametrize("suffix", USD_FORMATS)
def test_usd_stage_metadata(clip, written, suffix):
    from pxr import Usd, UsdGeom

    stage = Usd.Stage.Open(str(written[suffix]))
    assert UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.z and UsdGeom.GetStageMetersPerUnit(stage) == 1.0
    assert stage.GetTimeCodesPerSecond() == stage.GetFramesPerSecond() == clip.fps
    assert (stage.GetStartTimeCode(), stage.GetEndTimeCode()) == (0, clip.frame_count - 1)
    assert stage.GetDefaultPrim().GetPath() == "/World"
    assert stage.GetPrimAtPath("/World/animals").GetTypeName() == "SkelRoot"
    assert stage.GetPrimAtPath("/World/animals/dog").GetTypeName() == "Skeleton"
    assert stage.GetPrimAtPath("/World").GetAttribute("userProperties:quadpipe:fps").Get() == clip.fps
    assert stage.GetRootLayer().customLayerData["quadpipe"]["status"] == "ok"


def skel_query(stage, root_path: str):
    from pxr import Usd, UsdSkel

    cache = UsdSkel.Cache()
    root = UsdSkel.Root(stage.GetPrimAtPath(root_path))
    cache.Populate(root, Usd.PrimDefaultPredicate)
    (binding,) = cache.ComputeSkelBindings(root, Usd.PrimDefaultPredicate)
    return cache.GetSkelQuery(binding.GetSkeleton()), binding


@pytest.mark.parametrize("suffix", USD_FORMATS)
def test_usd_joints_follow_the_clip_on_every_frame(clip, written, suffix):
    from pxr import Usd, UsdGeom

    stage = Usd.Stage.Open(str(written[suffix]))
    query, _ = skel_query(stage, "/World/animals")
    track = clip.animals[0]
    assert [str(j).split("/")[-1] for j in query.GetJointOrder()] == list(track.roles)
    bind = np.array(query.GetJointWorldBindTransforms())
    for frame in range(clip.frame_count):
        world = np.array(query.ComputeJointWorldTransforms(UsdGeom.XformCache(frame)))
        np.testing.assert_allclose(
            world[:, 3, :3], track.positions[frame], atol=tolerance(clip), err_msg=f"frame {frame}"
        )
        # Gf matrices act on row vectors: their upper 3x3 is the transposed rotation. Joints are
        # turned along their bones at rest (quadpipe.clip.bind): inverse bind x world turns as
        # the clip's bone does.
        skinning = np.linalg.inv(bind) @ world
        np.testing.assert_allclose(
            skinning[:, :3, :3].transpose(0, 2, 1), clip_matrices(track.rotations[frame]), atol=ROTATION_TOLERANCE
        )
        box = UsdGeom.Xformable(stage.GetPrimAtPath("/World/props/crate")).ComputeLocalToWorldTransform(
            Usd.TimeCode(frame)
        )
        np.testing.assert_allclose(np.array(box)[3, :3], clip.props[0].positions[frame], atol=tolerance(clip))


def test_usd_rigid_skinning_moves_each_mesh_with_its_bone(clip, bones_written):
    from pxr import Usd, UsdGeom

    stage = Usd.Stage.Open(str(bones_written[".usdc"]))
    query, binding = skel_query(stage, "/World/animals")
    track = clip.animals[0]
    targets = binding.GetSkinningTargets()
    assert len(targets) == len(track.roles)
    for frame in (0, clip.frame_count // 2, clip.frame_count - 1):
        transforms = query.ComputeSkinningTransforms(Usd.TimeCode(frame))
        for target in targets:
            assert target.IsRigidlyDeformed()
            rest = target.GetPrim().GetAttribute("points").Get()
            points = rest.__class__(rest)
            assert target.ComputeSkinnedPoints(transforms, points, Usd.TimeCode(frame))
            bone = track.roles.index(target.GetPrim().GetName())
            expected = expected_skinned(track, frame, np.array(rest, dtype=float), np.full(len(rest), bone))
            np.testing.assert_allclose(
                np.array(points), expected, atol=tolerance(clip), err_msg=str(target.GetPrim().GetPath())
            )
    assert UsdGeom.Mesh(stage.GetPrimAtPath("/World/terrain")).GetPointsAttr().Get() is not None


def test_usd_quaternions_are_stored_real_part_first(clip, written):
    """GfQuatf(real, imaginary): the root's animated rotation is the clip's pelvis rotation, after
    the root's bind rotation (which turns its joint along its bone, quadpipe.clip.bind)."""
    from pxr import Usd, UsdSkel

    from quadpipe.clip.kinematics import multiply

    stage = Usd.Stage.Open(str(written[".usda"]))
    animation = UsdSkel.Animation(stage.GetPrimAtPath("/World/animals/dog/animation"))
    frame = clip.frame_count - 1
    root = animation.GetRotationsAttr().Get(frame)[0]
    stored = np.array([root.GetReal(), *root.GetImaginary()])
    turn = UsdSkel.Skeleton(stage.GetPrimAtPath("/World/animals/dog")).GetBindTransformsAttr().Get()[0]
    bind = turn.ExtractRotationQuat()
    expected = multiply(clip.animals[0].rotations[frame, 0], np.array([bind.GetReal(), *bind.GetImaginary()]))
    np.testing.assert_allclose(stored * np.sign(stored @ expected), expected, atol=1e-6)


# -- BVH -------------------------------------------------------------------------------------


def parse_bvh_motion(path: Path) -> tuple[list[str], list[int], np.ndarray, np.ndarray, float]:
    """Joint names, parents, offsets (cm, y-up), frame values and frame time of a BVH file."""
    names: list[str] = []
    parents: list[int] = []
    offsets: dict[int, list[float]] = {}
    blocks: list[int | None] = []  # the joint whose { } block each open brace starts; None: an End Site
    opening: int | None = None
    lines = iter(path.read_text().splitlines())
    for line in lines:
        words = line.split()
        if words[0] in ("ROOT", "JOINT"):
            parents.append(next((b for b in reversed(blocks) if b is not None), -1))
            names.append(words[1])
            opening = len(names) - 1
        elif words[0] == "End":
            opening = None
        elif words[0] == "{":
            blocks.append(opening)
        elif words[0] == "}":
            blocks.pop()
        elif words[0] == "OFFSET" and blocks[-1] is not None:
            offsets[blocks[-1]] = [float(v) for v in words[1:]]
        elif words[0] == "MOTION":
            break
    frames = int(next(lines).split()[1])
    frame_time = float(next(lines).split()[2])
    values = np.array([[float(v) for v in next(lines).split()] for _ in range(frames)])
    return names, parents, np.array([offsets[i] for i in range(len(names))]), values, frame_time


def test_bvh_reads_back_as_the_rest_skeleton(clip, written):
    from quadpipe.importers import load_skeleton

    skeleton = load_skeleton(written[".bvh"])
    track = clip.animals[0]
    starts = np.array([skeleton[role].start for role in track.roles])
    ends = np.array([skeleton[role].end for role in track.roles])
    np.testing.assert_allclose(starts, track.rest_start, atol=tolerance(clip))
    np.testing.assert_allclose(ends, track.rest_end, atol=tolerance(clip))


def test_bvh_motion_reproduces_the_clip(clip, written):
    names, parents, offsets, values, frame_time = parse_bvh_motion(written[".bvh"])
    track = clip.animals[0]
    assert sorted(names) == sorted(track.roles) and frame_time == pytest.approx(1.0 / clip.fps)
    assert values.shape == (clip.frame_count, 3 + 3 * len(names))
    angles = np.radians(values[:, 3:].reshape(clip.frame_count, len(names), 3))
    c, s = np.cos(angles), np.sin(angles)
    one, zero = np.ones_like(c[..., 0]), np.zeros_like(c[..., 0])
    rz = np.stack(
        [
            np.stack([c[..., 0], -s[..., 0], zero], -1),
            np.stack([s[..., 0], c[..., 0], zero], -1),
            np.stack([zero, zero, one], -1),
        ],
        -2,
    )
    rx = np.stack(
        [
            np.stack([one, zero, zero], -1),
            np.stack([zero, c[..., 1], -s[..., 1]], -1),
            np.stack([zero, s[..., 1], c[..., 1]], -1),
        ],
        -2,
    )
    ry = np.stack(
        [
            np.stack([c[..., 2], zero, s[..., 2]], -1),
            np.stack([zero, one, zero], -1),
            np.stack([-s[..., 2], zero, c[..., 2]], -1),
        ],
        -2,
    )
    local = rz @ rx @ ry
    rotation = np.zeros_like(local)
    position = np.zeros((clip.frame_count, len(names), 3))
    for joint, parent in enumerate(parents):
        if parent < 0:
            rotation[:, joint], position[:, joint] = local[:, joint], values[:, :3]
        else:
            rotation[:, joint] = rotation[:, parent] @ local[:, joint]
            position[:, joint] = position[:, parent] + np.einsum("fij,j->fi", rotation[:, parent], offsets[joint])
    order = [names.index(role) for role in track.roles]
    np.testing.assert_allclose(position[:, order] * CM @ Y_UP, track.positions, atol=tolerance(clip))
    np.testing.assert_allclose(
        Y_UP.T @ rotation[:, order] @ Y_UP, clip_matrices(track.rotations), atol=ROTATION_TOLERANCE
    )
    assert np.abs(np.diff(values[:, 3:], axis=0)).max() < 180.0, "angles jump by a full turn"


def test_bvh_refuses_a_clip_with_two_animals(tmp_path):
    with pytest.raises(QuadpipeError) as error:
        export_clip(two_dog_clip(), tmp_path / "two.bvh")
    assert error.value.issues[0].code == "bvh-one-animal"
    assert folder_listing(tmp_path) == []


# -- meshes ----------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("kind", "size", "volume"),
    [
        ("box", (0.1, 0.2, 0.3), 8 * 0.1 * 0.2 * 0.3),
        ("capsule", (0.05, 0.2), np.pi * 0.05**2 * 0.4 + 4 / 3 * np.pi * 0.05**3),
        ("sphere", (0.3,), 4 / 3 * np.pi * 0.3**3),
    ],
)
def test_tessellated_solids_are_closed_and_face_outward(kind, size, volume):
    import trimesh

    from quadpipe.clip.meshes import shape_mesh
    from quadpipe.clip.model import Shape

    shape = Shape(kind, size, pos=(1.0, 2.0, 3.0), quat=(np.cos(0.3), 0.0, np.sin(0.3), 0.0))
    mesh = shape_mesh(shape)
    solid = trimesh.Trimesh(mesh.vertices, mesh.faces)  # merges the split vertices of flat faces
    assert solid.is_watertight and solid.is_winding_consistent
    assert solid.volume == pytest.approx(volume, rel=0.05)
    np.testing.assert_allclose(solid.center_mass, shape.pos, atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(mesh.normals, axis=1), 1.0)
    triangles = mesh.vertices[mesh.faces]
    winding_normals = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    assert (np.einsum("ij,ij->i", mesh.normals[mesh.faces].mean(axis=1), winding_normals) > 0).all()
    again = shape_mesh(shape)
    assert again.vertices.tobytes() == mesh.vertices.tobytes() and again.faces.tobytes() == mesh.faces.tobytes()


# --------------------------------------------------------------------------- every shipped controller and animal

SHIPPED_CLIP_SECONDS = 1.0


def _shipped_cases() -> list[tuple[str, str]]:
    from quadpipe.core import configs

    cases = [("dog", controller) for controller in configs.available("controllers")]
    return cases + [(animal, "spine_walk") for animal in configs.available("animals") if animal != "dog"]


@pytest.mark.slow
@needs_node
@pytest.mark.parametrize(("animal", "controller"), _shipped_cases())
def test_every_shipped_controller_and_animal_bakes_valid_gltf_and_usd(animal, controller, tmp_path):
    from quadpipe.sim.simulation import simulate

    clip = simulate(animal, controller, seconds=SHIPPED_CLIP_SECONDS).clip
    glb = export_clip(clip, tmp_path / "clip.glb")
    issues = run_node("validate_gltf.mjs", str(glb))["issues"]
    assert (issues["numErrors"], issues["numWarnings"]) == (0, 0), json.dumps(issues["messages"], indent=1)
    assert usd_errors(export_clip(clip, tmp_path / "clip.usdc")) == []
