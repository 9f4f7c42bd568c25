"""Production-style rigs (#14): every fixture of `tests/fixtures/rigs/` imports with no role map
or a short one, its roles are anatomically right, its HP matches the animal it was made from,
and it walks; bad rigs give one message listing every problem.

The fixtures and their truth (`rigs.yaml`) come from `tools/make_rigs.py`.
"""

from __future__ import annotations

import functools
import importlib.util
import math
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from quadpipe.anatomy.role_names import name_end, name_side
from quadpipe.anatomy.roles import LEGS, ROLES, leg_of
from quadpipe.anatomy.skeleton import Skeleton
from quadpipe.core.errors import QuadpipeError
from quadpipe.importers import load_skeleton, read_raw_skeleton
from tests.conftest import FIXTURES, REPO

RIGS = FIXTURES / "rigs"
MANIFEST: dict[str, dict] = yaml.safe_load((RIGS / "rigs.yaml").read_text(encoding="utf-8"))
MAX_ROLE_MAP_LINES = 10
HP_TOLERANCE = 0.10
"""Measured HP within 10 % of the source animal's."""

WALK_SECONDS = 10.0


def rig_param(name: str) -> object:
    """A manifest entry as a test parameter; rigs that need #14 item 2 (role chains) are strict xfails."""
    needs = MANIFEST[name].get("needs")
    marks = (
        [pytest.mark.xfail(strict=True, raises=QuadpipeError, reason=f"needs {needs}: role chains")] if needs else []
    )
    return pytest.param(name, marks=marks, id=name)


ALL_RIGS = [rig_param(name) for name in MANIFEST]


def role_map(name: str) -> Path | None:
    entry = MANIFEST[name]
    return RIGS / entry["roles"] if "roles" in entry else None


@functools.cache
def rig_skeleton(name: str) -> Skeleton:
    return load_skeleton(RIGS / name, role_map(name), rest_frame=MANIFEST[name].get("rest_frame"))


def test_every_rig_file_is_in_the_manifest() -> None:
    files = {p.name for p in RIGS.iterdir() if p.suffix in (".ma", ".bvh")}
    assert files == set(MANIFEST) and len(files) >= 6


def test_the_generator_writes_the_fixtures_byte_for_byte(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    spec = importlib.util.spec_from_file_location("make_rigs", REPO / "tools" / "make_rigs.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    monkeypatch.setitem(sys.modules, "make_rigs", module)
    spec.loader.exec_module(module)
    module.main(tmp_path)
    written = sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*") if p.is_file())
    assert written == sorted(p.relative_to(RIGS) for p in RIGS.rglob("*") if p.is_file())
    for relative in written:
        assert (tmp_path / relative).read_bytes() == (RIGS / relative).read_bytes(), relative


@pytest.mark.parametrize("name", [n for n in MANIFEST if "roles" in MANIFEST[n]])
def test_role_maps_are_short(name: str) -> None:
    path = role_map(name)
    assert path is not None and len(path.read_text(encoding="utf-8").splitlines()) <= MAX_ROLE_MAP_LINES


@pytest.mark.parametrize("name", ALL_RIGS)
def test_rig_assembles_with_anatomically_right_roles(name: str) -> None:
    skeleton = rig_skeleton(name)
    assert list(skeleton.bones) == list(ROLES)
    pelvis = skeleton["pelvis"].start
    for role, bone in skeleton.bones.items():
        leg = leg_of(role)
        if leg is None:
            continue
        lateral = float(np.mean([bone.start[1], bone.end[1]]) - pelvis[1])
        assert (lateral > 0) == (leg[0] == "l"), f"{role} ({bone.name}) is on the wrong side"
        assert name_side(bone.name) in (None, "left" if leg[0] == "l" else "right"), f"{role} is {bone.name}"
        assert name_end(bone.name) in (None, "fore" if leg.endswith("f") else "hind"), f"{role} is {bone.name}"
    for side in "lr":
        assert skeleton[f"{side}f_scapula"].start[0] > skeleton[f"{side}h_hip"].start[0], "fore legs ahead of hind"
    for leg in LEGS:
        assert skeleton.bones[f"{leg}_{'fpha1' if leg.endswith('f') else 'hpha2'}"].end[2] < pelvis[2], "feet below"
    assert skeleton["head"].start[0] > skeleton["thorax"].start[0]


@pytest.mark.parametrize("name", ALL_RIGS)
def test_rig_pelvis_height_matches_its_animal(name: str) -> None:
    truth = MANIFEST[name]["hp_cm"] / 100.0
    assert abs(rig_skeleton(name).pelvis_height - truth) <= HP_TOLERANCE * truth


@pytest.mark.slow
@pytest.mark.parametrize("name", ALL_RIGS)
def test_rig_walks_10_s_without_falling(name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    from quadpipe.animals import library
    from quadpipe.sim.simulation import simulate

    entry = MANIFEST[name]
    mass = yaml.safe_load((REPO / "configs" / "animals" / f"{entry['animal']}.yaml").read_text())["mass_kg"]
    animal = library.animal_from_files(
        RIGS / name, library.default_limits_path(), role_map(name), mass, entry.get("rest_frame")
    )
    monkeypatch.setattr(library, "load_animal", lambda _source: animal)  # simulate takes the rig (#14 item 5)
    figures = simulate(animal.name, "walk", seconds=WALK_SECONDS).metrics["animals"][animal.name]
    assert not figures["fell"] and figures["forward_hp"] > 5.0


# -- what each rig shows ---------------------------------------------------------------------


def test_maya_constraints_and_connections_place_their_joints() -> None:
    raw = read_raw_skeleton(RIGS / "wolf_cog.ma")
    truth = {j.role: j.position for j in read_raw_skeleton(REPO / "configs" / "skeletons" / "dog.xml").joints}
    joints = {j.name: j for j in raw.joints}
    for name, role in (("Head", "head"), ("Tail1", "tail0"), ("L_Hip", "lh_hip")):
        np.testing.assert_allclose(joints[name].position, truth[role], atol=1e-3, err_msg=name)
    np.testing.assert_allclose(joints["Head"].axis, (1, 0, 0), atol=1e-6)
    [warning] = raw.warnings
    assert warning.code == "ma-driven-joints" and "L_Knee.rx (from L_Knee_rotateX.o)" in warning.message


def test_value_less_set_attr_lines_keep_the_value(tmp_path: Path) -> None:
    path = tmp_path / "flags.ma"
    path.write_text(
        "//Maya ASCII 2022 scene\ncurrentUnit -l centimeter -a degree;\n"
        'createNode joint -n "A";\n\tsetAttr ".t" -type "double3" 1 2 3 ;\n\tsetAttr -l on ".tx";\n'
        '\tsetAttr -av ".t";\n\tsetAttr -k off -cb on ".ty";\n\tsetAttr -l on -k off ".jo";\n'
        'createNode joint -n "B" -p "A";\n\tsetAttr ".t" -type "double3"\n\t\t 0 5\n\t\t 0 ;\n'
    )
    positions = [j.position for j in read_raw_skeleton(path).joints]
    assert positions == [(1, 2, 3), (1, 7, 3)]


def test_the_cog_root_and_the_biped_root_are_not_spine_bones() -> None:
    wolf, lion = rig_skeleton("wolf_cog.ma"), rig_skeleton("biped_lion.bvh")
    assert (wolf["pelvis"].name, wolf["spine0"].name) == ("Pelvis", "Spine1")
    assert (lion["pelvis"].name, lion["spine0"].name, lion["lh_hip"].name) == (
        "Bip01 Spine",
        "Bip01 Spine1",
        "Bip01 L Thigh",
    )


def test_mocap_arm_is_the_fore_leg_on_its_own_side() -> None:
    skeleton = rig_skeleton("mocap_dog.bvh")
    assert [skeleton[r].name for r in ("lf_shoulder", "rf_shoulder", "lh_hip", "rh_hip")] == [
        "LeftArm",
        "RightArm",
        "LeftUpLeg",
        "RightUpLeg",
    ]


def test_extra_bones_stay_out_of_the_roles_and_are_named() -> None:
    skeleton = rig_skeleton("elephant_extras.ma")
    assert skeleton["head"].name == "Head"
    [unplaced] = [w for w in skeleton.warnings if w.code == "unplaced-joints"]
    assert unplaced.message.startswith("13 joint(s) have no role")  # 9 extra bones and their 4 end joints
    assert all(name in unplaced.message for name in ("Trunk1", "Trunk4", "Jaw", "L_Ear1", "L_Ear2"))


def test_a_mocap_zero_pose_does_not_stand_and_the_message_names_rest_frame(cli) -> None:
    with pytest.raises(QuadpipeError) as caught:
        load_skeleton(RIGS / "mocap_dog.bvh")
    [issue] = [i for i in caught.value.issues if i.severity == "error"]
    assert issue.code == "rest-pose-not-standing" and "--rest-frame" in (issue.hint or "")
    assert all(f"{leg} (" in issue.message for leg in LEGS)
    result = cli("inspect", str(RIGS / "mocap_dog.bvh"))
    assert result.returncode == 1 and "rest-pose-not-standing" in result.stderr and "Traceback" not in result.stderr
    assert cli("inspect", str(RIGS / "mocap_dog.bvh"), "--rest-frame", "1").returncode == 0


def test_rest_frame_errors() -> None:
    with pytest.raises(QuadpipeError) as caught:
        load_skeleton(RIGS / "mocap_dog.bvh", rest_frame=3)
    assert caught.value.issues[0].code == "rest-frame-out-of-range" and "3 frame(s)" in caught.value.issues[0].message
    with pytest.raises(QuadpipeError) as caught:
        load_skeleton(RIGS / "wolf_cog.ma", rest_frame=0)
    assert caught.value.issues[0].code == "no-motion"
    with pytest.raises(QuadpipeError) as caught:
        load_skeleton(RIGS / "bad" / "cut_motion.bvh", rest_frame=1)
    [issue] = caught.value.issues
    assert issue.code == "bvh-bad-motion" and issue.where is not None and issue.where.line is not None


@pytest.mark.parametrize(
    ("order", "expected"),
    [
        # Rz(90) Rx(90) (0 1 0) = Rz(90) (0 0 1) = (0 0 1)
        ("Zrotation Xrotation Yrotation", (0.0, 0.0, 1.0)),
        # Rx(90) Rz(90) (0 1 0) = Rx(90) (-1 0 0) = (-1 0 0)
        ("Xrotation Zrotation Yrotation", (-1.0, 0.0, 0.0)),
    ],
)
def test_bvh_rest_frame_turns_by_the_channel_order(tmp_path: Path, order: str, expected: tuple[float, ...]) -> None:
    path = tmp_path / "order.bvh"
    path.write_text(
        "HIERARCHY\nROOT Root\n{\n OFFSET 0 0 0\n CHANNELS 6 Xposition Yposition Zposition "
        f"{order}\n JOINT Child\n {{\n  OFFSET 0 1 0\n  CHANNELS 3 Zrotation Yrotation Xrotation\n"
        "  End Site\n  {\n   OFFSET 0 1 0\n  }\n }\n}\nMOTION\nFrames: 1\nFrame Time: 0.04\n"
        "0 0 0 90 90 0 0 0 0\n"
    )
    child = read_raw_skeleton(path, rest_frame=0, units="cm").joints[1]
    np.testing.assert_allclose(child.position, expected, atol=1e-9)


def test_a_bad_rig_gives_every_problem_in_one_message(cli) -> None:
    result = cli("roles", str(RIGS / "bad" / "mirrored_tailless.bvh"))
    assert result.returncode == 1 and "Traceback" not in result.stderr
    errors = [line for line in result.stderr.splitlines() if " error " in line]
    assert [line.split(" error ")[1].split(":")[0] for line in errors] == [
        "missing-roles",
        "implausible-roles",
        "implausible-roles",
    ]
    assert "tail0, tail1, tail2, tail3" in errors[0]
    assert all(line.split(":")[1].isdigit() for line in errors[1:]), "the leg problems say their line"


def test_roles_exits_0_on_a_guess_that_passes(cli) -> None:
    result = cli("roles", str(RIGS / "horse_frontback.bvh"))
    assert result.returncode == 0, result.stderr


def test_junk_end_sites_are_flagged_and_hp_is_measured_to_the_toes(tmp_path: Path) -> None:
    text = (RIGS / "horse_frontback.bvh").read_text(encoding="utf-8")
    joint = text.index("JOINT BackLeftHoof")
    site = text.index("OFFSET", text.index("End Site", joint))
    line_end = text.index("\n", site)
    path = tmp_path / "junk.bvh"
    path.write_text(text[:site] + "OFFSET 0 60 0" + text[line_end:], encoding="utf-8")
    skeleton = load_skeleton(path)
    [warning] = [w for w in skeleton.warnings if w.code == "junk-end-sites"]
    assert "BackLeftHoof (points up from a foot)" in warning.message
    truth = MANIFEST["horse_frontback.bvh"]["hp_cm"] / 100.0
    assert math.isclose(skeleton.pelvis_height, truth, rel_tol=0.01)
