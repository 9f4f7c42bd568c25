"""Skeleton importers (.xml, .ma, .bvh), role maps and role guessing.

Every fixture in tests/fixtures/skeletons/ is the same dog as reference.xml, written in
another format; each must assemble to the same bones. Bad inputs live in bad/ with their
expected messages in `GOLDEN` below.
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from quadpipe.anatomy.role_guess import guess_roles
from quadpipe.anatomy.role_names import name_side
from quadpipe.anatomy.rolemap import apply_role_map, load_role_map, resolve_roles, write_role_map
from quadpipe.anatomy.roles import ROLES
from quadpipe.anatomy.skeleton import RawSkeleton, Skeleton, assemble
from quadpipe.core.errors import QuadpipeError
from quadpipe.importers import load_skeleton, read_raw_skeleton, skeleton_readers, write_guessed_role_map
from quadpipe.importers.maya_ascii import read_skeleton as read_ma

FIXTURES = Path(__file__).parent / "fixtures" / "skeletons"
REFERENCE = FIXTURES / "reference.xml"
TOLERANCE_M = 1e-6
ROLE_MAP_SUFFIX = ".roles.yaml"

SKELETON_FIXTURES = sorted(p for p in FIXTURES.iterdir() if p.suffix in skeleton_readers())
GUESSED_FIXTURES = [FIXTURES / "reference.ma", FIXTURES / "reference.bvh"]


def role_map_for(path: Path) -> Path | None:
    """A fixture's own role map (`name.roles.yaml` beside `name.bvh`), if it has one."""
    candidate = path.with_name(path.stem + ROLE_MAP_SUFFIX)
    return candidate if candidate.exists() else None


@pytest.fixture(scope="module")
def reference() -> Skeleton:
    return load_skeleton(REFERENCE)


def assert_same_bones(skeleton: Skeleton, reference: Skeleton, *, axes: bool) -> None:
    assert list(skeleton.bones) == list(reference.bones)
    for role, bone in reference.bones.items():
        np.testing.assert_allclose(skeleton[role].start, bone.start, atol=TOLERANCE_M, err_msg=f"{role} start")
        np.testing.assert_allclose(skeleton[role].end, bone.end, atol=TOLERANCE_M, err_msg=f"{role} end")
        if axes:
            np.testing.assert_allclose(skeleton[role].axis, bone.axis, atol=TOLERANCE_M, err_msg=f"{role} axis")


def carries_axes(raw: RawSkeleton) -> bool:
    return all(joint.axis is not None for joint in raw.joints)


def message(error: QuadpipeError) -> str:
    """The error as the CLI prints it, with paths relative to the fixtures folder."""
    return str(error).replace(str(FIXTURES) + "/", "")


# -- every format gives the reference skeleton ---------------------------------------------


def test_every_registered_suffix_has_a_fixture() -> None:
    suffixes = {p.suffix for p in SKELETON_FIXTURES}
    assert set(skeleton_readers()) <= suffixes


@pytest.mark.parametrize("path", SKELETON_FIXTURES, ids=lambda p: p.name)
def test_fixture_assembles_to_the_reference(path: Path, reference: Skeleton) -> None:
    skeleton = load_skeleton(path, role_map_for(path))
    assert_same_bones(skeleton, reference, axes=carries_axes(read_raw_skeleton(path)))


def test_reference_is_a_plausible_dog(reference: Skeleton) -> None:
    assert reference.pelvis_height == pytest.approx(0.6556)
    assert reference["lh_knee"].axis[1] > 0.99  # the knee turns about the lateral axis


def test_maya_fixture_carries_axes_and_bvh_does_not() -> None:
    assert carries_axes(read_raw_skeleton(FIXTURES / "reference.ma"))
    assert all(joint.axis is None for joint in read_raw_skeleton(FIXTURES / "reference.bvh").joints)


# -- guessing ---------------------------------------------------------------------------


@pytest.mark.parametrize("path", GUESSED_FIXTURES, ids=lambda p: p.name)
def test_guessing_places_all_roles(path: Path, reference: Skeleton) -> None:
    raw = read_raw_skeleton(path)
    guess = guess_roles(raw)
    assert guess.missing == ()
    assert sorted(guess.roles.values()) == sorted(ROLES)
    assert_same_bones(assemble(raw, guess.roles), reference, axes=False)


def anonymous(raw: RawSkeleton) -> tuple[RawSkeleton, dict[str, str]]:
    """The skeleton with names that say nothing (`j07`), and the renaming."""
    names = {joint.name: f"j{index:02d}" for index, joint in enumerate(raw.joints)}
    joints = tuple(replace(j, name=names[j.name], parent=names.get(j.parent), role=None) for j in raw.joints)
    return replace(raw, joints=joints), names


@pytest.mark.parametrize("path", GUESSED_FIXTURES, ids=lambda p: p.name)
def test_guessing_without_names_uses_positions(path: Path) -> None:
    raw = read_raw_skeleton(path)
    named = guess_roles(raw)
    nameless, names = anonymous(raw)
    guess = guess_roles(nameless)
    assert guess.roles == {names[name]: role for name, role in named.roles.items()}
    assert any("side from its position" in note for note in guess.notes)


def test_guessing_recovers_the_roles_of_the_xml_file() -> None:
    raw = read_raw_skeleton(REFERENCE)
    stripped = replace(raw, joints=tuple(replace(j, role=None) for j in raw.joints))
    assert guess_roles(stripped).roles == {j.name: j.role for j in raw.joints}


def test_guessing_skips_extra_joints_evenly_and_warns(reference: Skeleton) -> None:
    raw = read_raw_skeleton(FIXTURES / "reference.bvh")
    joints = list(raw.joints)
    at = next(i for i, j in enumerate(joints) if j.name == "Bip01 Neck2")
    neck2 = joints[at]
    extra = replace(neck2, name="Bip01 Neck2b", parent="Bip01 Neck2")
    joints[at + 1] = replace(joints[at + 1], parent="Bip01 Neck2b")
    joints.insert(at + 1, extra)
    resolution = resolve_roles(replace(raw, joints=tuple(joints)))
    assert "Bip01 Neck2b" not in resolution.roles or "Bip01 Neck2" not in resolution.roles
    assert [w.code for w in resolution.warnings] == ["guessed-chain"]
    assert resolution.roles["Bip01 Head"] == "head"


@pytest.mark.parametrize(
    ("name", "side"),
    [
        ("L_Hip", "left"),
        ("R_Hip", "right"),
        ("l_hip", "left"),
        ("r_knee", "right"),
        ("LeftUpLeg", "left"),
        ("mixamorig:RightForeArm", "right"),
        ("hip.L", "left"),
        ("thigh.r", "right"),
        ("Thigh_L", "left"),
        ("shin_R", "right"),
        ("Bip01 L Thigh", "left"),
        ("Bip01 R Calf", "right"),
        ("|grp|LHand", "left"),
        ("lf_elbow", "left"),
        ("rh_knee", "right"),
        ("Pelvis", None),
        ("Spine1", None),
        ("Root", None),
        ("Leg", None),
        ("Rear", None),
        ("Bip01 Head", None),
    ],
)
def test_name_side(name: str, side: str | None) -> None:
    assert name_side(name) == side


# -- role maps ------------------------------------------------------------------------------


def test_guessed_role_map_round_trips(tmp_path: Path, reference: Skeleton) -> None:
    skeleton_path = FIXTURES / "reference.bvh"
    map_path = tmp_path / "dog.roles.yaml"
    guess = write_guessed_role_map(skeleton_path, map_path)
    assert guess.missing == ()
    assert "Bip01 L Thigh: lh_hip" in map_path.read_text()
    skeleton = load_skeleton(skeleton_path, map_path)
    assert_same_bones(skeleton, reference, axes=False)


def test_role_map_escapes_glob_characters(tmp_path: Path) -> None:
    raw = read_raw_skeleton(FIXTURES / "reference.bvh")

    def odd(name: str | None) -> str | None:
        return name.replace("Bip01", "Bip[01]*") if name else None

    raw = replace(raw, joints=tuple(replace(j, name=odd(j.name), parent=odd(j.parent)) for j in raw.joints))
    map_path = tmp_path / "escaped.roles.yaml"
    write_role_map(map_path, guess_roles(raw).roles)
    roles, warnings = apply_role_map(raw, load_role_map(map_path))
    assert warnings == ()
    assert roles["Bip[01]* L Thigh"] == "lh_hip"


def test_role_map_without_roles_sets_units_and_up_then_guesses(tmp_path: Path, reference: Skeleton) -> None:
    map_path = tmp_path / "zup.roles.yaml"
    map_path.write_text("units: mm\nup: z\n")
    skeleton = load_skeleton(FIXTURES / "reference_zup.bvh", map_path)
    assert_same_bones(skeleton, reference, axes=False)


def test_role_map_replaces_the_roles_of_the_file(tmp_path: Path) -> None:
    map_path = tmp_path / "swap.roles.yaml"
    lines = [f"  {role}: {role}" for role in ROLES if role not in ("tail2", "tail3")]
    map_path.write_text("roles:\n" + "\n".join(lines) + "\n  tail2: tail3\n  tail3: tail2\n")
    with pytest.raises(QuadpipeError) as caught:
        load_skeleton(REFERENCE, map_path)
    assert caught.value.issues[0].code == "wrong-parent"


def test_role_map_null_leaves_a_joint_unplaced_and_unused_patterns_warn(tmp_path: Path) -> None:
    map_path = tmp_path / "partial.roles.yaml"
    map_path.write_text('roles:\n  "bip01 pelvis": pelvis\n  Bip01: ~\n  "Bip01 Pelvsi": thorax\n')
    roles, warnings = apply_role_map(read_raw_skeleton(FIXTURES / "reference.bvh"), load_role_map(map_path))
    assert roles == {"Bip01 Pelvis": "pelvis"}
    assert [(w.code, w.where.line, w.severity) for w in warnings] == [("unused-pattern", 4, "warning")]
    assert "did you mean 'Bip01 Pelvis'" in (warnings[0].hint or "")


def test_exact_names_win_over_globs(tmp_path: Path) -> None:
    map_path = tmp_path / "glob.roles.yaml"
    map_path.write_text('roles:\n  "Bip01 L Toe0?": lh_hpha1\n  "bip01 l toe01": lh_hpha2\n')
    roles, warnings = apply_role_map(read_raw_skeleton(FIXTURES / "reference.bvh"), load_role_map(map_path))
    assert roles == {"Bip01 L Toe01": "lh_hpha2"}
    assert [(w.code, w.where.line) for w in warnings] == [("unused-pattern", 2)]


def test_two_patterns_giving_one_role_is_an_error(tmp_path: Path) -> None:
    map_path = tmp_path / "twice.roles.yaml"
    map_path.write_text("roles:\n  Bip01 L Thigh: lh_hip\n  Bip01 R Thigh: lh_hip\n")
    with pytest.raises(QuadpipeError) as caught:
        apply_role_map(read_raw_skeleton(FIXTURES / "reference.bvh"), load_role_map(map_path))
    issue = caught.value.issues[0]
    assert (issue.code, issue.where.line) == ("duplicate-role", 3)


# -- bad input: golden messages ---------------------------------------------------------------

GOLDEN: dict[tuple[str, str | None], str] = {
    ("bad/truncated.ma", None): """\
bad/truncated.ma:7:2: error ma-truncated: the file ends inside this 'setAttr' statement (no closing ';')
  hint: the file was cut short: save or export it again""",
    ("bad/bad_number.ma", None): """\
bad/bad_number.ma:5:33: error ma-bad-number: '65,56' is not a number
  hint: write a plain decimal number""",
    ("bad/bad_value.ma", None): """\
bad/bad_value.ma:5:32: error ma-bad-value: '.jo' takes 3 number(s), found 2
  hint: write it as setAttr ".jo" -type "double3" x y z;""",
    ("bad/unknown_parent.ma", None): """\
bad/unknown_parent.ma:7:33: error ma-unknown-parent: parent 'Pelvsi' is not a joint or transform created earlier in the file
  hint: did you mean 'Pelvis'?""",
    ("bad/unterminated_string.ma", None): """\
bad/unterminated_string.ma:4:21: error ma-unterminated-string: this string has no closing quote on its line
  hint: close the string with " (write a line break inside a string as \\n)""",
    ("bad/not_maya.ma", None): """\
bad/not_maya.ma:1:1: error ma-not-maya-ascii: the file does not start with '//Maya', so it is not a Maya ASCII file
  hint: export the scene from Maya as Maya ASCII (.ma); Maya itself refuses files without this header""",
    ("bad/reparented.ma", None): """\
bad/reparented.ma:7:11: error ma-unsupported-command: 'parent' moves 'Spine1' after it was created; this reader does not follow that
  hint: create the node under its parent with createNode -p (re-save the file from Maya)""",
    ("bad/bad_units.ma", None): """\
bad/bad_units.ma:3:16: error ma-bad-units: linear unit 'centimetre' is unknown
  hint: did you mean 'centimeter'? (valid: centimeter, cm, foot, ft, in, inch, kilometer, km, m, meter, mi, mile, millimeter, mm, yard, yd)""",
    ("bad/truncated.bvh", None): """\
bad/truncated.bvh:9: error bvh-truncated: the file ends inside joint 'Spine' (opened at line 6)
  hint: the file was cut short, or a '}' is missing""",
    ("bad/bad_number.bvh", None): """\
bad/bad_number.bvh:8:17: error bvh-bad-number: '9cm' is not a number (OFFSET of 'Spine')
  hint: write a plain decimal number""",
    ("bad/extra_brace.bvh", None): """\
bad/extra_brace.bvh:12:1: error bvh-unbalanced-braces: this '}' closes nothing
  hint: remove it, or find the '{' it should close""",
    ("bad/unclosed.bvh", None): """\
bad/unclosed.bvh:11:1: error bvh-unbalanced-braces: joint 'Hips' (opened at line 2) is not closed before MOTION
  hint: add the missing '}'""",
    ("bad/bad_channels.bvh", None): """\
bad/bad_channels.bvh:5:11: error bvh-bad-channels: CHANNELS says 6 but lists 5 channel(s)
  hint: the count must match the channel names on the same line""",
    ("bad/no_hierarchy.bvh", None): """\
bad/no_hierarchy.bvh:1:1: error bvh-missing-hierarchy: a BVH file starts with the word HIERARCHY
  hint: is this a BVH file? the skeleton must come first, before MOTION""",
    ("bad/short_leg.bvh", None): """\
bad/short_leg.bvh: error missing-roles: 1 of the 39 roles could not be guessed from the joints' names and layout: lf_fpha1
  hint: `quadpipe roles bad/short_leg.bvh -o roles.yaml` writes what was guessed; complete it and pass it with --roles roles.yaml
bad/short_leg.bvh: note guessed-roles: pelvis 'Bip01 Pelvis' and thorax 'Bip01 Spine3': the two joints where several chains meet
bad/short_leg.bvh: note guessed-roles: spine: 3 joint(s) from 'Bip01 Spine' for 3 role(s) spine0..spine2
bad/short_leg.bvh: note guessed-roles: left hind leg (side from its names): 6 joint(s) from 'Bip01 L Thigh' for 6 role(s) lh_hip..lh_hpha2
bad/short_leg.bvh: note guessed-roles: right hind leg (side from its names): 6 joint(s) from 'Bip01 R Thigh' for 6 role(s) rh_hip..rh_hpha2
bad/short_leg.bvh: note guessed-roles: tail: 4 joint(s) from 'Bip01 Tail' for 4 role(s) tail0..tail3
bad/short_leg.bvh: note guessed-roles: left front leg (side from its names): 5 joint(s) from 'Bip01 L Clavicle' for 6 role(s) lf_scapula..lf_fpha1; too short: lf_fpha1 not placed
bad/short_leg.bvh: note guessed-roles: right front leg (side from its names): 6 joint(s) from 'Bip01 R Clavicle' for 6 role(s) rf_scapula..rf_fpha1
bad/short_leg.bvh: note guessed-roles: neck and head: 6 joint(s) from 'Bip01 Neck' for 6 role(s) neck0..head""",
    ("reference.bvh", "bad/unknown_role.roles.yaml"): """\
bad/unknown_role.roles.yaml:4:18: error unknown-role: 'lh_femur' (for 'Bip01 L Thigh') is not a role of the reference hierarchy
  hint: bones are named after the joint at their proximal end: the femur is 'lh_hip'
bad/unknown_role.roles.yaml:5:18: error unknown-role: 'rh_hpha3' (for 'Bip01 R Toe01') is not a role of the reference hierarchy
  hint: did you mean 'rh_hpha2' or 'rh_hpha1' or 'rh_hpha0'?""",
    ("reference.bvh", "bad/ambiguous.roles.yaml"): """\
bad/ambiguous.roles.yaml:3:16: error ambiguous-pattern: 'Bip01 L *' gives role lh_hip to 12 joints: 'Bip01 L Clavicle', 'Bip01 L UpperArm', 'Bip01 L Forearm', 'Bip01 L Hand', 'Bip01 L Finger0' ...
  hint: make the pattern match one joint (write the full name)""",
    ("reference.bvh", "bad/bad_up.roles.yaml"): """\
bad/bad_up.roles.yaml:2:5: error invalid-value: up: up axis 'x' is unknown; use one of y, z""",
}


def test_every_bad_fixture_has_a_golden_message() -> None:
    used = {name for case in GOLDEN for name in case if name}
    assert {str(p.relative_to(FIXTURES)) for p in (FIXTURES / "bad").iterdir()} <= used


@pytest.mark.parametrize(("case", "expected"), GOLDEN.items(), ids=lambda v: v if isinstance(v, str) else "")
def test_bad_input_message(case: tuple[str, str | None], expected: str) -> None:
    skeleton, role_map = case
    with pytest.raises(QuadpipeError) as caught:
        load_skeleton(FIXTURES / skeleton, FIXTURES / role_map if role_map else None)
    assert message(caught.value) == expected


# -- Maya matrices, checked against hand-computed cases ------------------------------------


def read_maya(tmp_path: Path, body: str) -> dict[str, tuple[float, ...]]:
    """Joint name -> world position of a small .ma file."""
    path = tmp_path / "scene.ma"
    path.write_text("//Maya ASCII 2020 scene\n" + body)
    raw = read_ma(path)
    return {j.name: tuple(round(v, 9) + 0.0 for v in j.position) for j in raw.joints}


def test_group_transform_moves_its_joints(tmp_path: Path) -> None:
    positions = read_maya(
        tmp_path,
        """
createNode transform -n "grp";
    setAttr ".t" -type "double3" 10 0 0 ;
    setAttr ".r" -type "double3" 0 90 0 ;
createNode joint -n "a" -p "grp";
    setAttr ".t" -type "double3" 0 0 5 ;
""",
    )
    assert positions == {"a": (15.0, 0.0, 0.0)}


def test_joint_orient_turns_the_children_and_the_main_axis(tmp_path: Path) -> None:
    path = tmp_path / "orient.ma"
    path.write_text("""//Maya ASCII 2020 scene
createNode joint -n "a";
    setAttr ".jo" -type "double3" 0 0 90 ;
createNode joint -n "b" -p "a";
    setAttr ".t" -type "double3" 2 0 0 ;
createNode joint -n "c" -p "b";
    setAttr ".ra" -type "double3" 0 90 0 ;
""")
    joints = {j.name: j for j in read_ma(path).joints}
    np.testing.assert_allclose(joints["b"].position, (0, 2, 0), atol=1e-12)
    np.testing.assert_allclose(joints["a"].axis, (0, 0, 1), atol=1e-12)
    np.testing.assert_allclose(joints["c"].axis, (0, 1, 0), atol=1e-12)  # z -> x by ry 90, x -> y by jo z 90
    assert joints["b"].parent == "a"


@pytest.mark.parametrize(("order", "expected"), [(0, (1.0, 0.0, 0.0)), (4, (0.0, 0.0, 1.0))])
def test_rotate_order(tmp_path: Path, order: int, expected: tuple[float, ...]) -> None:
    positions = read_maya(
        tmp_path,
        f"""
createNode joint -n "a";
    setAttr ".r" -type "double3" 90 90 0 ;
    setAttr ".ro" {order};
createNode joint -n "b" -p "a";
    setAttr ".t" -type "double3" 0 1 0 ;
""",
    )
    assert positions["b"] == expected


@pytest.mark.parametrize(("connected", "expected"), [(True, (3.0, 0.0, 0.0)), (False, (4.0, 0.0, 0.0))])
def test_segment_scale_compensation(tmp_path: Path, connected: bool, expected: tuple[float, ...]) -> None:
    positions = read_maya(
        tmp_path,
        """
createNode joint -n "a";
    setAttr ".s" -type "double3" 2 2 2 ;
createNode joint -n "b" -p "a";
    setAttr ".t" -type "double3" 1 0 0 ;
createNode joint -n "c" -p "b";
    setAttr ".t" -type "double3" 1 0 0 ;
"""
        + ('connectAttr "a.s" "b.is";\n' if connected else ""),
    )
    assert positions["b"] == (2.0, 0.0, 0.0)
    assert positions["c"] == expected


def test_rotate_pivot_of_a_group(tmp_path: Path) -> None:
    positions = read_maya(
        tmp_path,
        """
createNode transform -n "grp";
    setAttr ".rp" -type "double3" 1 0 0 ;
    setAttr ".r" -type "double3" 0 0 90 ;
createNode joint -n "a" -p "grp";
""",
    )
    assert positions["a"] == (1.0, -1.0, 0.0)


def test_units(tmp_path: Path) -> None:
    path = tmp_path / "units.ma"
    path.write_text(f"""//Maya ASCII 2020 scene
currentUnit -l yard -a radian;
createNode joint -n "a";
    setAttr ".r" -type "double3" 0 0 {math.pi / 2} ;
createNode joint -n "b" -p "a";
    setAttr ".t" -type "double3" 1 0 0 ;
""")
    raw = read_ma(path)
    assert raw.units == "m"
    np.testing.assert_allclose(raw.joints[1].position, (0, 0.9144, 0), atol=1e-12)


def test_dag_paths_tell_apart_joints_with_the_same_name(tmp_path: Path) -> None:
    positions = read_maya(
        tmp_path,
        """
createNode joint -n "L";
    setAttr ".t" -type "double3" 1 0 0 ;
createNode joint -n "Hip" -p "L";
createNode joint -n "R";
    setAttr ".t" -type "double3" -1 0 0 ;
createNode joint -n "Hip" -p "R";
createNode joint -n "Knee" -p "R|Hip";
    setAttr ".t" -type "double3" 0 -5 0 ;
""",
    )
    assert positions["|L|Hip"] == (1.0, 0.0, 0.0)
    assert positions["Knee"] == (-1.0, -5.0, 0.0)


def test_ambiguous_parent_is_an_error(tmp_path: Path) -> None:
    path = tmp_path / "ambiguous.ma"
    path.write_text(
        '//Maya ASCII\ncreateNode joint -n "L";\ncreateNode joint -n "Hip" -p "L";\n'
        'createNode joint -n "R";\ncreateNode joint -n "Hip" -p "R";\n'
        'createNode joint -n "Knee" -p "Hip";\n'
    )
    with pytest.raises(QuadpipeError) as caught:
        read_ma(path)
    issue = caught.value.issues[0]
    assert (issue.code, issue.where.line, issue.where.column) == ("ma-ambiguous-name", 6, 31)


def test_bvh_offsets_accumulate_and_end_sites_end_their_joint(tmp_path: Path) -> None:
    path = tmp_path / "small.bvh"
    path.write_text(
        "HIERARCHY\nROOT Hips {\n OFFSET 1 2 3\n CHANNELS 6 Xposition Yposition Zposition "
        "Zrotation Xrotation Yrotation\n JOINT Left Up Leg\n {\n  OFFSET 0 1 0\n  End Site\n  {\n"
        "   OFFSET 0 0 2\n  }\n }\n}\nMOTION\nFrames: 0\n"
    )
    raw = read_raw_skeleton(path, units="cm")
    hips, leg = raw.joints
    assert (leg.name, leg.parent, leg.position, leg.end, leg.line) == ("Left Up Leg", "Hips", (1, 3, 3), (1, 3, 5), 5)
    assert hips.end is None and (raw.units, raw.up) == ("cm", "y") and not raw.warnings


def test_bvh_without_a_unit_spanning_few_units_is_read_in_metres_with_a_warning(tmp_path: Path) -> None:
    path = tmp_path / "small.bvh"
    path.write_text("HIERARCHY\nROOT Hips\n{\n OFFSET 0 0.6 0\n End Site\n {\n  OFFSET 0 -0.6 0\n }\n}\n")
    raw = read_raw_skeleton(path)
    assert raw.units == "m" and [w.code for w in raw.warnings] == ["bvh-units-guessed"]
    assert read_raw_skeleton(path, units="in").units == "in"
