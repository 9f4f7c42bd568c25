"""Physical sanity and run limits (#17): sane ranges, run lengths checked before anything is
built, plan overrides blamed on their line, MuJoCo kept quiet."""

from __future__ import annotations

import math

import pytest

from quadpipe.batch import expand_jobs, load_plan, run_job
from quadpipe.core import configs
from quadpipe.core.errors import Location, QuadpipeError
from quadpipe.core.limits import BODY_MASS_KG, MAX_FRAMES, MAX_SIMULATED_SECONDS, SCENE_EXTENT_HP, check_run
from tests.conftest import FIXTURES, built_animal


@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf, -5.0, 0.0, 1e308, 20_000.1])
def test_a_mass_that_is_no_animal_is_out_of_range_with_the_range_in_the_hint(value):
    with pytest.raises(QuadpipeError) as caught:
        BODY_MASS_KG.check(value, "mass_kg", where=Location("dog.yaml", 7, 10))
    issue = caught.value.issues[0]
    assert (issue.code, issue.where) == ("out-of-range", Location("dog.yaml", 7, 10))
    assert issue.message.startswith("mass_kg: ") and "0.001 to 20000 kg" in (issue.hint or "")


@pytest.mark.parametrize("value", [0.001, 0.002, 30.0, 6_000.0, 20_000.0])
def test_a_real_mass_passes_unchanged(value):
    assert BODY_MASS_KG.check(value, "mass_kg") == value


@pytest.mark.parametrize(
    ("seconds", "fps", "code"),
    [
        (math.inf, 30.0, "out-of-range"),
        (math.nan, 30.0, "out-of-range"),
        (-1.0, 30.0, "out-of-range"),
        (1e12, 30.0, "limit-exceeded"),
        (10.0, 0.0, "bad-fps"),
        (10.0, math.nan, "bad-fps"),
        (10.0, -30.0, "bad-fps"),
        (3_600.0, 1_000.0, "limit-exceeded"),
    ],
)
def test_a_run_out_of_its_limits_is_refused_with_its_code(seconds, fps, code):
    with pytest.raises(QuadpipeError) as caught:
        check_run(seconds, fps)
    assert caught.value.issues[0].code == code


def test_a_run_within_its_limits_counts_its_frames():
    assert check_run(10.0, 30.0) == 300
    assert check_run(0.0, 30.0) == 0


def test_run_limits_can_be_raised_in_the_environment(monkeypatch):
    monkeypatch.setenv("QUADPIPE_MAX_SECONDS", "7200")
    monkeypatch.setenv("QUADPIPE_MAX_FRAMES", "300000")
    assert (MAX_SIMULATED_SECONDS.value, MAX_FRAMES.value) == (7200, 300_000)
    assert check_run(5_000.0, 30.0) == 150_000


def test_simulate_refuses_a_run_too_long_before_building_anything(monkeypatch):
    from quadpipe.sim import simulation

    def must_not_build(*args, **kwargs):
        raise AssertionError("built a simulation for a run over its limits")

    monkeypatch.setattr(simulation.Simulation, "build", must_not_build)
    with pytest.raises(QuadpipeError, match="over the limit of 3600 seconds"):
        simulation.simulate("dog", "rigid", seconds=1e12)


def test_a_plan_parameter_that_does_not_fit_is_blamed_on_the_plan_line(tmp_path):
    plan_path = tmp_path / "plan.yaml"
    plan_path.write_text(
        f"animals: [dog]\ncontrollers: [spine_walk]\nseconds: 0.1\nformats: [npz]\noutput: {tmp_path}\n"
        "overrides:\n  - parameters:\n      stride_angle: 25 kg\n"
    )
    (job,) = expand_jobs(load_plan(plan_path))
    result = run_job(job)
    assert result.error is not None
    assert result.error.startswith(f"{plan_path}:8:21: error wrong-dimension: parameter 'stride_angle'")


def test_a_blow_up_leaves_no_mujoco_log_in_the_working_folder(tmp_path, monkeypatch):
    from quadpipe.sim.simulation import SimulationBlowUp, simulate

    monkeypatch.chdir(tmp_path)
    with pytest.raises(SimulationBlowUp):
        simulate("dog", str(FIXTURES / "runtime" / "explode.yaml"), seconds=1.0)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("animal", configs.available("animals"))
def test_a_scene_length_at_the_edge_of_the_extent_is_accepted_on_every_animal(animal, tmp_path):
    """1000 HP, written so, is in range whatever the animal's size (it came back 1000.0000000000001
    HP on the cat from metres)."""
    from quadpipe.world import build_scene, load_scene

    scene = tmp_path / "edge.yaml"
    scene.write_text(f"schema: 1\nname: edge\ngoals:\n  goal: [{SCENE_EXTENT_HP.high:g} HP, 0, 0]\n")
    assert build_scene(load_scene(str(scene)), built_animal(animal)).placements
