"""The command line as a user meets it: outputs, and golden messages for bad input.

Each bad-input case is a fixture in tests/fixtures/bad_input/ with its expected stderr in
`<case>.expected`, compared exactly: one clear message, exit code 1, no traceback.
"""

from __future__ import annotations

import json

import mujoco
import pytest

from quadpipe.core import configs
from tests.conftest import FIXTURES, REPO, invoke_cli

BAD = FIXTURES / "bad_input"
DOG_XML = "../../../configs/skeletons/dog.xml"

BAD_INPUT_CASES = {
    "unknown_role": ["inspect", "unknown_role.xml"],
    "cycle": ["inspect", "cycle.xml"],
    "zero_length": ["inspect", "zero_length.xml"],
    "malformed": ["inspect", "malformed.xml"],
    "missing_row": ["inspect", DOG_XML, "--limits", "missing_row.tsv"],
    "bad_number": ["inspect", DOG_XML, "--limits", "bad_number.tsv"],
    "bad_key": ["inspect", "bad_key.yaml"],
    "unknown_animal": ["inspect", "doge"],
    "unknown_format": ["convert", "skeleton.obj", "-o", "out.xml"],
    "unwritable_output": ["convert", "dog", "-o", "no/such/folder/dog.xml"],
}


@pytest.mark.parametrize("case", sorted(BAD_INPUT_CASES))
def test_bad_input_gives_its_golden_message(case, cli):
    result = cli(*BAD_INPUT_CASES[case], cwd=BAD)
    expected = (BAD / f"{case}.expected").read_text()
    assert result.returncode == 1
    assert result.stderr == expected
    assert "Traceback" not in result.stderr + result.stdout


def test_debug_shows_the_traceback(cli):
    result = cli("--debug", "inspect", "doge")
    assert result.returncode != 0
    assert "Traceback" in result.stderr and "QuadpipeError" in result.stderr


def test_animals_lists_every_animal_with_its_size():
    result = invoke_cli("animals", "--format", "json")
    assert result.returncode == 0, result.stderr
    rows = {row["name"]: row for row in json.loads(result.stdout)}
    assert set(rows) == set(configs.available("animals"))
    assert rows["dog"]["hp_cm"] == 65.56 and rows["dog"]["bones"] == 39
    assert rows["rat"]["timestep_s"] == pytest.approx(1 / 2040)  # 1/120 s in 17 substeps


def test_inspect_reports_bones_masses_and_limits():
    result = invoke_cli("inspect", "dog", "--format", "json")
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    bones = {bone["role"]: bone for bone in report["bones"]}
    assert len(bones) == 39
    assert bones["lh_knee"]["limits_deg"] == [0.0, 85.0, 0.0, 0.0]
    assert sum(bone["mass_kg"] for bone in bones.values()) == pytest.approx(report["animal"]["mass_kg"], rel=1e-3)


def test_convert_writes_mjcf_that_mujoco_loads(tmp_path):
    target = tmp_path / "dog.xml"
    result = invoke_cli("convert", "dog", "-o", str(target))
    assert result.returncode == 0, result.stderr
    model = mujoco.MjModel.from_xml_path(str(target))
    assert model.body("dog/pelvis").id > 0 and model.geom("floor").id >= 0
    # MuJoCo writes the step with 6 significant digits (0.00208333)
    assert model.opt.timestep == pytest.approx(1 / 480, rel=1e-5) and model.opt.iterations == 32


def test_convert_from_a_bare_skeleton_file(tmp_path):
    target = tmp_path / "model.xml"
    result = invoke_cli(
        "convert", str(REPO / "configs" / "skeletons" / "horse.xml"), "--mass", "500", "-o", str(target)
    )
    assert result.returncode == 0, result.stderr
    model = mujoco.MjModel.from_xml_path(str(target))
    assert model.body_subtreemass[0] == pytest.approx(500)


def test_a_failed_convert_leaves_no_file(cli, tmp_path):
    target = tmp_path / "dog.xml"
    result = cli("convert", "doge", "-o", str(target))
    assert result.returncode == 1
    assert list(tmp_path.iterdir()) == []


def test_help_of_every_command_has_an_example():
    """In process: the help text is what is checked, not the process around it."""
    import typer.main

    from quadpipe.cli import app

    for name in typer.main.get_group(app).commands:
        result = invoke_cli(name, "--help")
        assert result.returncode == 0, (name, result.stderr)
        assert "Example:" in result.stdout, name


def test_roles_guesses_a_bvh_and_writes_a_role_map_that_loads(tmp_path):
    source = FIXTURES / "skeletons" / "reference.bvh"
    role_map = tmp_path / "roles.yaml"
    result = invoke_cli("roles", str(source), "-o", str(role_map))
    assert result.returncode == 0, result.stderr
    assert "39 joints placed, 0 roles missing" in result.stdout
    inspected = invoke_cli("inspect", str(source), "--roles", str(role_map), "--format", "json")
    assert inspected.returncode == 0, inspected.stderr
    bones = {bone["role"]: bone["name"] for bone in json.loads(inspected.stdout)["bones"]}
    assert bones["lh_hip"] == "Bip01 L Thigh" and bones["pelvis"] == "Bip01 Pelvis"


def test_a_plain_simulate_walks_the_dog_and_analyze_recognises_it_and_draws_its_footfalls(tmp_path):
    """No `-c`: every command's default controller is `walk`, the shipped walk."""
    clip = tmp_path / "walk.npz"
    assert invoke_cli("simulate", "-s", "6", "-o", str(clip)).returncode == 0
    report, diagram = tmp_path / "report.json", tmp_path / "footfalls.png"
    result = invoke_cli("analyze", str(clip), "-o", str(report), "--diagram", str(diagram))
    assert result.returncode == 0, result.stderr
    gait = json.loads(report.read_text())["animals"]["dog"]["gait"]
    assert gait["name"] == "walk"
    assert diagram.stat().st_size > 1000


def test_preview_without_a_display_says_so(cli, monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    result = cli("preview", "--controller", "rigid")
    assert result.returncode == 1
    assert "error no-display" in result.stderr and "Traceback" not in result.stderr
