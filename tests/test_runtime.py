"""The controller runtime: forces where the language says, determinism, and blow-ups caught."""

from __future__ import annotations

import json
import math

import mujoco
import numpy as np
import pytest

from quadpipe.core.errors import QuadpipeError
from quadpipe.sim.simulation import simulate
from tests.conftest import FIXTURES

RUNTIME = FIXTURES / "runtime"


def test_control_segments_inject_no_net_force():
    result = simulate("dog", "rigid", seconds=0.5)
    forces = result.runtime.last
    assert len(forces.forces) > 0
    net = forces.forces.sum(axis=0)
    weight = 30.0 * 9.81
    assert np.linalg.norm(net) < 1e-9 * weight
    assert np.abs(forces.forces).max() > 0.05 * weight  # and they are not all zero


def test_a_spring_bends_its_joint_toward_the_target():
    result = simulate("dog", str(RUNTIME / "bend_knee.yaml"), seconds=2.0)
    track = result.clip.animals[0]
    assert result.runtime.model.joint("dog/lh_knee").range[1] >= math.radians(40)
    # the knee's angle is the rotation of the tibia's body relative to the femur's
    femur = track.rotations[-1, track.roles.index("lh_hip")]
    tibia = track.rotations[-1, track.roles.index("lh_knee")]
    relative = _quat_multiply(_quat_conjugate(femur), tibia)
    angle = 2 * math.degrees(math.atan2(np.linalg.norm(relative[1:]), relative[0]))
    assert angle == pytest.approx(40, abs=6)


def test_a_pull_fades_in_and_moves_the_animal_toward_it():
    result = simulate("dog", str(RUNTIME / "side_pull.yaml"), seconds=4.0)
    pelvis = result.clip.animals[0].positions[:, 0]
    hp = result.clip.animals[0].pelvis_height
    assert abs(pelvis[30, 1] - pelvis[0, 1]) < 0.02 * hp  # nothing before 1 s
    assert pelvis[-1, 1] - pelvis[0, 1] > 0.2 * hp  # then it goes left


def test_same_inputs_give_the_same_clip():
    first = simulate("dog", "spine_walk", seconds=2.0).clip
    second = simulate("dog", "spine_walk", seconds=2.0).clip
    assert np.array_equal(first.animals[0].positions, second.animals[0].positions)
    assert np.array_equal(first.animals[0].rotations, second.animals[0].rotations)


def test_a_blow_up_stops_with_the_frame_and_the_controller_named():
    with pytest.raises(QuadpipeError) as caught:
        simulate("dog", str(RUNTIME / "explode.yaml"), seconds=2.0)
    issue = caught.value.issues[0]
    assert issue.code == "simulation-blew-up"
    assert "explode" in issue.message and "frame" in issue.message


def test_simulate_command_writes_the_clip_and_metrics(cli, tmp_path):
    clip_path = tmp_path / "run.npz"
    result = cli("simulate", "--animal", "dog", "--controller", "rigid", "--seconds", "1", "-o", str(clip_path))
    assert result.returncode == 0, result.stderr
    metrics = json.loads((tmp_path / "run.metrics.json").read_text())
    assert metrics["frames"] == 31
    assert metrics["animals"]["dog"]["fell"] is False
    from quadpipe.exporters.npz import load_clip

    assert load_clip(clip_path).animals[0].positions.shape == (31, 39, 3)


def test_simulate_command_blow_up_is_one_message_and_no_file(cli, tmp_path):
    clip_path = tmp_path / "run.npz"
    result = cli("simulate", "--controller", str(RUNTIME / "explode.yaml"), "--seconds", "1", "-o", str(clip_path))
    assert result.returncode == 1
    assert "error simulation-blew-up" in result.stderr and "Traceback" not in result.stderr
    assert list(tmp_path.iterdir()) == []


def _quat_conjugate(q: np.ndarray) -> np.ndarray:
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def _quat_multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    result = np.zeros(4)
    mujoco.mju_mulQuat(result, a, b)
    return result


def test_the_clip_carries_sensors_and_the_metrics_the_injected_force():
    pulled = simulate("dog", str(RUNTIME / "side_pull.yaml"), seconds=3.0)
    walking = simulate("dog", "spine_walk", seconds=2.0)
    frames = walking.clip.frame_count
    assert walking.clip.sensors["ground_normal:dog"].shape == (frames, 3)
    assert walking.clip.sensors["controller_force:dog"].shape == (frames, 3)
    up = walking.clip.sensors["ground_normal:dog"][-1]
    assert up == pytest.approx([0.0, 0.0, 1.0], abs=0.05)  # flat ground
    assert walking.metrics["animals"]["dog"]["net_force_max_bw"] < 1e-9  # couples only
    assert pulled.metrics["animals"]["dog"]["net_force_max_bw"] == pytest.approx(2.0, rel=0.01)  # the 2 bw pull
    assert walking.metrics["animals"]["dog"]["work_j"] > 0


def test_a_released_runtime_gives_the_model_its_compiled_damping_back():
    from quadpipe.sim.simulation import Simulation

    simulation = Simulation.build("dog", "walk")
    compiled = simulation.model.dof_damping.copy()
    for _ in range(20):
        simulation.step()
    assert np.abs(simulation.model.dof_damping - compiled).max() > 0  # the springs' damping is in the model
    simulation.runtime.release()
    assert np.array_equal(simulation.model.dof_damping, compiled)


def test_a_reset_or_a_new_controller_starts_from_the_compiled_model():
    from quadpipe.sim.simulation import Simulation

    simulation = Simulation.build("dog", "walk")
    first = simulation.record(0.5).animals[0].positions
    simulation.reset()
    assert simulation.time == 0.0
    again = simulation.record(0.5).animals[0].positions
    compiled, _ = simulation.compile_controller("walk")
    simulation.reset()
    simulation.use_controller(compiled)
    swapped = simulation.record(0.5).animals[0].positions
    assert np.array_equal(first, again) and np.array_equal(first, swapped)
    assert np.array_equal(first, simulate("dog", "walk", seconds=0.5).clip.animals[0].positions)
