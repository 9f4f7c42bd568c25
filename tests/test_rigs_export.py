"""Bring your own rig (#14): a rig with fewer bones than the 39 roles, and extra bones, is an
animal, walks, and bakes back onto its own joints.

The rig is tests/fixtures/rigs_out/dog_short.bvh (made by tools/make_rig_fixtures.py from the
built-in dog): 2 spine, 2 neck and 2 tail bones, 3-bone legs without scapulae or toes, and a
jaw and two ears. It is baked once, through the command line, to BVH, glTF, USD and npz; the
npz keeps the 39 roles, so the rig files are checked against the simulation itself. The same
rig as Maya saves it (`dog_short.ma`, end joints included) and as a z-up tool in millimetres
saves it (`dog_short_zup_mm.bvh`) are baked too, shorter.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from quadpipe.anatomy.rig import chain_shares
from quadpipe.anatomy.skeleton import UNIT_TO_METRES
from quadpipe.clip.retarget import on_rig
from quadpipe.exporters.npz import load_clip
from quadpipe.importers import load_skeleton, read_raw_skeleton
from tests.conftest import FIXTURES, REPO
from tests.test_exporters import needs_node, node_matrices, read_gltf, run_node, usd_errors

RIGS = FIXTURES / "rigs_out"
RIG = RIGS / "dog_short.bvh"
ROLE_MAP = RIGS / "dog_short_roles.yaml"
ZUP_RIG = RIGS / "dog_short_zup_mm.bvh"
ZUP_ROLE_MAP = RIGS / "dog_short_zup_mm_roles.yaml"

POSITION_TOLERANCE_HP = 1e-4
"""Joint positions read back from a baked file match the simulation to 1e-4 pelvis heights."""

WALK_SECONDS = 10.0
MIN_WALK_HP = 5.0
"""The walk controller takes the dog 15 HP in 10 s; a rig that stumbles along gets less than 5."""

EXTRAS = {"Jaw", "Ear_L", "Ear_R"}
SYNTHESISED = {f"{leg}_{bone}" for leg in ("lf", "rf") for bone in ("scapula", "fpha0", "fpha1")} | {
    f"{leg}_hpha{i}" for leg in ("lh", "rh") for i in range(3)
}
Y_UP = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
"""BVH and glTF axes from quadpipe's (rows: v_yup = Y_UP @ v)."""


def rig_hierarchy(path: Path) -> list[tuple[str, str | None]]:
    """(name, parent) of every joint of a skeleton file, as quadpipe's importer reads it."""
    return [(joint.name, joint.parent) for joint in read_raw_skeleton(path).joints]


@pytest.fixture(scope="module")
def baked(tmp_path_factory) -> dict[str, Path]:
    """The rig walked for 10 s and baked to every format, through the command line."""
    from tests.conftest import run_cli

    folder = tmp_path_factory.mktemp("rig")
    outputs = {suffix: folder / f"rig{suffix}" for suffix in (".bvh", ".glb", ".usda", ".npz")}
    args = ["bake", "-a", str(RIG), "--roles", str(ROLE_MAP), "-c", "walk", "-s", str(WALK_SECONDS)]
    result = run_cli(*args, *(arg for path in outputs.values() for arg in ("-o", str(path))), cwd=folder)
    assert result.returncode == 0, result.stderr
    (folder / "stdout.txt").write_text(result.stdout + result.stderr)
    return {**outputs, "log": folder / "stdout.txt", "metrics": folder / "rig.metrics.json"}


@pytest.fixture(scope="module")
def simulated(baked):
    """The simulation's own track of the 39 roles (the npz) and that track put on the rig."""
    track = load_clip(baked[".npz"]).animals[0]
    track.rig = load_skeleton(RIG, ROLE_MAP).rig
    return track, on_rig(track)


# -- importing ----------------------------------------------------------------------------------


def test_the_fixtures_are_what_the_generator_makes(tmp_path):
    from tools.make_rig_fixtures import main

    main(tmp_path)
    for path in RIGS.iterdir():
        assert (tmp_path / path.name).read_bytes() == path.read_bytes(), (
            f"rerun tools/make_rig_fixtures.py ({path.name})"
        )


def test_the_role_map_is_at_most_ten_lines():
    assert len(ROLE_MAP.read_text().splitlines()) <= 10


def test_the_rig_imports_with_chains_synthesised_roles_and_extras():
    skeleton = load_skeleton(RIG, ROLE_MAP)
    dog = load_skeleton(REPO / "configs" / "skeletons" / "dog.xml")
    rig = skeleton.rig
    assert rig is not None and len(skeleton.bones) == 39
    assert [(j.name, j.parent) for j in rig.joints] == rig_hierarchy(RIG)
    assert set(rig.extras) == EXTRAS
    assert set(rig.synthesised) == SYNTHESISED
    carried = {joint.name: joint.roles for joint in rig.joints}
    assert carried["Spine1"] == ("spine0", "spine1") and carried["Spine2"] == ("spine2",)
    assert carried["Neck1"] == ("neck0", "neck1") and carried["Neck2"] == ("neck2", "neck3", "neck4")
    assert carried["L_UpperArm"] == ("lf_shoulder",) and carried["R_Thigh"] == ("rh_hip",)
    # the split bones keep the rig's joints where they were, and the rig stands as high as the dog
    assert skeleton["spine2"].start == pytest.approx(dog["spine2"].start)
    assert skeleton["lf_wrist"].start == pytest.approx(dog["lf_wrist"].start)
    assert skeleton.pelvis_height == pytest.approx(dog.pelvis_height)
    # synthesised scapulae sit above and behind the shoulder; toes lie on the ground, forward
    scapula, shoulder = skeleton["lf_scapula"], skeleton["lf_shoulder"]
    assert scapula.start[2] > shoulder.start[2] and scapula.start[0] < shoulder.start[0]
    toe = skeleton["rh_hpha2"]
    assert toe.end[0] > skeleton["rh_ankle"].end[0] and toe.end[2] == pytest.approx(skeleton.ground_height)


@pytest.mark.parametrize(
    ("lengths", "count", "shares"),
    [([2.0, 1.0], 3, [2, 1]), ([1.0, 1.0], 5, [3, 2]), ([1.0, 3.0, 1.0], 3, [1, 1, 1]), ([1.0, 1.0], 1, [1])],
)
def test_a_chain_gives_its_longest_bones_the_extra_roles(lengths, count, shares):
    assert chain_shares(lengths, count) == shares


def test_a_built_in_skeleton_has_no_rig_to_write_back():
    assert load_skeleton(REPO / "configs" / "skeletons" / "dog.xml").rig is None


# -- simulating -----------------------------------------------------------------------------


def test_the_rig_walks_ten_seconds_without_falling(baked):
    figures = json.loads(baked["metrics"].read_text())["animals"]["dog_short"]
    assert not figures["fell"]
    assert figures["distance_hp"] > MIN_WALK_HP


def test_the_mass_rule_and_the_mass_used_are_printed(baked):
    log = baked["log"].read_text()
    assert "default-mass" in log and "Alexander et al. 1979" in log
    assert "dog_short: 24 joints (3 extra), HP 65.6 cm, mass 67.6 kg" in log


def test_a_given_mass_is_used(cli, tmp_path):
    args = ("simulate", "-a", str(RIG), "--roles", str(ROLE_MAP), "--mass", "25", "-s", "0.1", "-o", "r.npz")
    result = cli(*args, cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    assert "mass 25 kg" in result.stdout and "default-mass" not in result.stderr
    assert load_clip(tmp_path / "r.npz").animals[0].mass_kg == pytest.approx(25.0)


def test_a_skeleton_file_is_an_animal_of_simulate(cli, tmp_path):
    """`-a rig.bvh` no longer answers "did you mean": the reference BVH's roles are guessed."""
    result = cli(
        "simulate", "-a", str(FIXTURES / "skeletons" / "reference.bvh"), "-s", "0.1", "-o", "r.npz", cwd=tmp_path
    )
    assert result.returncode == 0, result.stderr
    assert "did you mean" not in result.stderr and "mass" in result.stdout


def test_roles_and_mass_are_refused_for_an_animal_name(cli, tmp_path):
    result = cli("simulate", "-a", "dog", "--mass", "25", "-s", "0.1", "-o", "r.npz", cwd=tmp_path)
    assert result.returncode == 1 and "unused-option" in result.stderr and "Traceback" not in result.stderr


# -- baking onto the rig --------------------------------------------------------------------


def bvh_world_positions(path: Path) -> tuple[list[str], list[int], np.ndarray]:
    """Names, parents and (F, J, 3) world joint positions (cm, y up) of a BVH file's motion,
    with each joint's own channel list (positions and rotations in any order)."""
    names, parents, offsets, channels = [], [], [], []
    stack: list[int | None] = []
    opening: int | None = None
    lines = iter(path.read_text().splitlines())
    for line in lines:
        words = line.split()
        if words[0] in ("ROOT", "JOINT"):
            parents.append(next((b for b in reversed(stack) if b is not None), -1))
            names.append(" ".join(words[1:]))
            opening = len(names) - 1
        elif words[0] == "End":
            opening = None
        elif words[0] == "{":
            stack.append(opening)
        elif words[0] == "}":
            stack.pop()
        elif words[0] == "OFFSET" and stack[-1] is not None:
            offsets.append([float(v) for v in words[1:]])
        elif words[0] == "CHANNELS":
            channels.append(words[2:])
        elif words[0] == "MOTION":
            break
    frames = int(next(lines).split()[1])
    next(lines)
    values = np.array([[float(v) for v in next(lines).split()] for _ in range(frames)])
    world_rotation = np.zeros((frames, len(names), 3, 3))
    world_position = np.zeros((frames, len(names), 3))
    column = 0
    for joint, parent in enumerate(parents):
        local = np.tile(np.eye(3), (frames, 1, 1))
        translation = np.tile(offsets[joint], (frames, 1))
        for channel in channels[joint]:
            axis = "XYZ".index(channel[0])
            value = values[:, column]
            column += 1
            if channel.endswith("position"):
                translation[:, axis] = value
                continue
            c, s = np.cos(np.radians(value)), np.sin(np.radians(value))
            turn = np.tile(np.eye(3), (frames, 1, 1))
            i, j = (axis + 1) % 3, (axis + 2) % 3
            turn[:, i, i], turn[:, i, j], turn[:, j, i], turn[:, j, j] = c, -s, s, c
            local = local @ turn
        if parent < 0:
            world_rotation[:, joint], world_position[:, joint] = local, translation
        else:
            world_rotation[:, joint] = world_rotation[:, parent] @ local
            world_position[:, joint] = world_position[:, parent] + np.einsum(
                "fij,fj->fi", world_rotation[:, parent], translation
            )
    return names, parents, world_position


def expected_positions(track, rig_file: Path = RIG) -> np.ndarray:
    """(F, J, 3) where each rig joint should be: a mapped joint at its first role's simulated
    joint; an extra bone rigidly on its parent's bone at its rest offset (read from `rig_file`,
    in the units and axes its binding says)."""
    rig = track.rig
    role = {name: index for index, name in enumerate(track.roles)}
    names = [joint.name for joint in rig.joints]
    raw = {joint.name: joint for joint in read_raw_skeleton(rig_file).joints}
    scale = UNIT_TO_METRES[rig.units]
    at_rest = {name: rig.axes @ np.array(raw[name].position) * scale for name in names}
    positions = np.zeros((track.positions.shape[0], len(names), 3))
    drive: dict[str, str] = {}
    for index, joint in enumerate(rig.joints):
        drive[joint.name] = joint.roles[0] if joint.roles else drive[joint.parent]
        bone = role[drive[joint.name]]
        if joint.roles:
            positions[:, index] = track.positions[:, bone]
            continue
        anchor = joint.parent
        offset = at_rest[joint.name] - at_rest[anchor]
        q = track.rotations[:, bone] / np.linalg.norm(track.rotations[:, bone], axis=-1, keepdims=True)
        w, v = q[:, :1], q[:, 1:]
        turned = offset + 2 * np.cross(v, np.cross(v, offset) + w * offset)
        positions[:, index] = positions[:, names.index(anchor)] + turned
    return positions


def test_the_bvh_is_the_rigs_own_skeleton_and_follows_the_simulation(baked, simulated):
    roles_track, _ = simulated
    assert rig_hierarchy(baked[".bvh"]) == rig_hierarchy(RIG)
    names, _, world = bvh_world_positions(baked[".bvh"])
    expected = expected_positions(roles_track)
    assert names == [joint.name for joint in roles_track.rig.joints]
    error = np.abs(world * 0.01 @ Y_UP - expected).max() / roles_track.pelvis_height
    assert error < POSITION_TOLERANCE_HP, f"{error:.2e} HP"


def test_the_bvh_reads_back_with_the_rigs_rest_pose(baked):
    source, written = read_raw_skeleton(RIG), read_raw_skeleton(baked[".bvh"])
    shift = np.array(written.joints[0].position) - np.array(source.joints[0].position)  # placed on the floor
    hp = load_skeleton(RIG, ROLE_MAP).pelvis_height * 100.0
    for before, after in zip(source.joints, written.joints):
        assert np.abs(np.array(after.position) - before.position - shift).max() < POSITION_TOLERANCE_HP * hp


def test_the_gltf_is_the_rigs_own_skeleton_and_follows_the_simulation(baked, simulated):
    roles_track, on_the_rig = simulated
    document, binary = read_gltf(baked[".glb"])
    names = list(on_the_rig.roles)
    nodes = {node["name"]: index for index, node in enumerate(document["nodes"])}
    assert set(names) <= set(nodes)
    children = {
        document["nodes"][i]["name"]: [document["nodes"][c]["name"] for c in document["nodes"][i].get("children", [])]
        for i in nodes.values()
    }
    for name, parent in rig_hierarchy(RIG):
        if parent is not None:
            assert name in children[parent]
    world = node_matrices(document, binary, on_the_rig.positions.shape[0])
    joints = [nodes[name] for name in names]
    error = np.abs(world[:, joints][..., :3, 3] @ Y_UP - expected_positions(roles_track)).max()
    assert error / roles_track.pelvis_height < POSITION_TOLERANCE_HP


@needs_node
def test_the_rig_gltf_passes_the_khronos_validator(baked):
    issues = run_node("validate_gltf.mjs", str(baked[".glb"]))["issues"]
    assert (issues["numErrors"], issues["numWarnings"]) == (0, 0), json.dumps(issues["messages"], indent=1)


def test_the_usd_is_the_rigs_own_skeleton_and_validates(baked):
    from pxr import Usd, UsdSkel

    stage = Usd.Stage.Open(str(baked[".usda"]))
    skeleton = next(UsdSkel.Skeleton(p) for p in stage.Traverse() if p.IsA(UsdSkel.Skeleton))
    paths = [str(token) for token in skeleton.GetJointsAttr().Get()]
    expected = {name: parent for name, parent in rig_hierarchy(RIG)}
    assert {path.split("/")[-1] for path in paths} == set(expected)
    for path in paths:
        parts = path.split("/")
        assert expected[parts[-1]] == (parts[-2] if len(parts) > 1 else None)
    assert usd_errors(baked[".usda"]) == []


def test_skeleton_roles_keeps_the_39_roles(cli, tmp_path):
    args = ("bake", "-a", str(RIG), "--roles", str(ROLE_MAP), "-c", "rigid", "-s", "0.1", "--skeleton", "roles")
    result = cli(*args, "-o", "roles.bvh", cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    names = [name for name, _ in rig_hierarchy(tmp_path / "roles.bvh")]
    assert len(names) == 39 and "lf_scapula" in names and "Jaw" not in names


def test_a_rig_in_other_units_and_axes_is_written_in_them(cli, tmp_path):
    """The z-up millimetre rig comes back z-up in millimetres, following the simulation."""
    result = cli(
        "bake",
        "-a",
        str(ZUP_RIG),
        "--roles",
        str(ZUP_ROLE_MAP),
        "-c",
        "rigid",
        "-s",
        "0.5",
        "-o",
        "zup.bvh",
        "-o",
        "zup.npz",
        cwd=tmp_path,
    )
    assert result.returncode == 0, result.stderr
    track = load_clip(tmp_path / "zup.npz").animals[0]
    track.rig = load_skeleton(ZUP_RIG, ZUP_ROLE_MAP).rig
    assert track.rig.units == "mm"
    np.testing.assert_allclose(track.rig.axes, [[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]], atol=1e-12)
    source, written = read_raw_skeleton(ZUP_RIG), read_raw_skeleton(tmp_path / "zup.bvh")
    shift = np.array(written.joints[0].position) - source.joints[0].position
    assert shift[:2] == pytest.approx([0.0, 0.0]) and shift[2] > 0.0  # lifted onto the floor, along +Z
    for before, after in zip(source.joints, written.joints):
        np.testing.assert_allclose(np.array(after.position) - before.position, shift, atol=1e-3)  # mm
    _, _, world = bvh_world_positions(tmp_path / "zup.bvh")
    body = world * UNIT_TO_METRES["mm"] @ track.rig.axes.T
    error = np.abs(body - expected_positions(track, ZUP_RIG)).max() / track.pelvis_height
    assert error < POSITION_TOLERANCE_HP, f"{error:.2e} HP"


def test_a_rig_with_spaces_in_its_names_bakes_to_valid_usd(cli, tmp_path):
    """A Biped-style rig (`Bip01 L Thigh`): USD joint paths are made valid, jointNames keep the names."""
    from pxr import Usd, UsdSkel

    rig = FIXTURES / "skeletons" / "reference.bvh"
    result = cli("bake", "-a", str(rig), "-c", "rigid", "-s", "0.1", "--look", "bones", "-o", "ref.usda", cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    stage = Usd.Stage.Open(str(tmp_path / "ref.usda"))
    skeleton = next(UsdSkel.Skeleton(p) for p in stage.Traverse() if p.IsA(UsdSkel.Skeleton))
    assert list(skeleton.GetJointNamesAttr().Get()) == [name for name, _ in rig_hierarchy(rig)]
    assert usd_errors(tmp_path / "ref.usda") == []


# -- bind poses that point along the bones (built-in animals too) ---------------------------


@pytest.fixture(scope="module")
def dog_files(tmp_path_factory) -> dict[str, Path]:
    from quadpipe.exporters import export_clip
    from tests.clips import dog_clip

    folder = tmp_path_factory.mktemp("bind")
    return {suffix: export_clip(dog_clip(), folder / f"dog{suffix}", look="bones") for suffix in (".glb", ".usda")}


def bone_directions(track) -> np.ndarray:
    """(B, 3) unit vectors from each joint to its bone's end, quadpipe's frame."""
    directions = track.rest_end - track.rest_start
    return directions / np.linalg.norm(directions, axis=-1, keepdims=True)


def test_gltf_joints_point_along_their_bones_at_rest(dog_files):
    track = dog_clip_track()
    document, binary = read_gltf(dog_files[".glb"])
    skin = document["skins"][0]
    inverse_bind = accessor_matrices(document, binary, skin["inverseBindMatrices"])
    bind = np.linalg.inv(inverse_bind)
    np.testing.assert_allclose(bind[:, :3, 1] @ Y_UP, bone_directions(track), atol=1e-6)  # local +Y
    document.pop("animations")  # the nodes' own transforms are the bind pose Blender builds bones from
    rest = node_matrices(document, binary, 1)[0, skin["joints"]]
    np.testing.assert_allclose(rest, bind, atol=1e-6)


def test_usd_joints_point_along_their_bones_at_rest(dog_files):
    from pxr import Usd, UsdSkel

    track = dog_clip_track()
    stage = Usd.Stage.Open(str(dog_files[".usda"]))
    skeleton = UsdSkel.Skeleton(stage.GetPrimAtPath("/World/animals/dog"))
    bind = np.array(skeleton.GetBindTransformsAttr().Get())  # row vectors: row 1 is the image of +Y
    np.testing.assert_allclose(bind[:, 1, :3], bone_directions(track), atol=1e-6)
    rest = np.array(skeleton.GetRestTransformsAttr().Get())
    world = np.zeros_like(rest)
    for joint, parent in enumerate(track.parents):
        world[joint] = rest[joint] if parent < 0 else rest[joint] @ world[parent]
    np.testing.assert_allclose(world, bind, atol=1e-6)


def dog_clip_track():
    from tests.clips import dog_clip

    return dog_clip().animals[0]


def accessor_matrices(document: dict, binary: bytes, index: int) -> np.ndarray:
    """(N, 4, 4) matrices of a MAT4 accessor (glTF stores them column-major)."""
    from tests.test_exporters import accessor

    return accessor(document, binary, index).reshape(-1, 4, 4).transpose(0, 2, 1).astype(float)


def test_every_misplaced_role_is_reported_at_once(tmp_path):
    from quadpipe.core.errors import QuadpipeError

    swapped = tmp_path / "swapped_roles.yaml"
    swapped.write_text(ROLE_MAP.read_text().replace("[hip, knee, ankle]", "[knee, hip, ankle]"))
    with pytest.raises(QuadpipeError) as caught:
        load_skeleton(RIG, swapped)
    wrong = [issue for issue in caught.value.issues if issue.code == "wrong-parent"]
    assert len(wrong) == len(caught.value.issues) == 6  # hip, knee and ankle of both hind legs
    assert {issue.message.split("(role ")[1].split(")")[0] for issue in wrong} >= {"lh_hip", "rh_knee"}


def test_the_maya_rig_is_an_animal_and_bakes_onto_its_own_joints(cli, tmp_path):
    """`-a dog_short.ma`: the same rig as Maya saves it, end joints included, baked to BVH and glTF."""
    rig = RIGS / "dog_short.ma"
    result = cli(
        "bake",
        "-a",
        str(rig),
        "--roles",
        str(ROLE_MAP),
        "--mass",
        "30",
        "-c",
        "walk",
        "-s",
        "1",
        "-o",
        "ma.bvh",
        "-o",
        "ma.glb",
        cwd=tmp_path,
    )
    assert result.returncode == 0, result.stderr
    assert "dog_short: 33 joints (12 extra), HP 65.6 cm, mass 30 kg" in result.stdout
    assert rig_hierarchy(tmp_path / "ma.bvh") == rig_hierarchy(rig)  # end joints included
    document, _ = read_gltf(tmp_path / "ma.glb")
    assert {name for name, _ in rig_hierarchy(rig)} <= {node["name"] for node in document["nodes"]}
