"""Natural variation (`--variation`, `quadpipe.controllers.runtime.variation`): seeded strides
that are not all alike, the same clip for the same seed, the gait kept.

The dog walks 20 s at 120 fps (a frame is 1 % of its 0.87 s stride) toward a goal far ahead;
the first `SETTLE_S` are left out of the stride figures.
"""

from __future__ import annotations

import functools

import numpy as np
import pytest

from quadpipe.analysis import analyze_clip
from quadpipe.anatomy.roles import ROLES
from quadpipe.controllers.language.load import load_controller
from quadpipe.controllers.runtime.variation import (
    MAX_VARIATION,
    SIDE_BIAS_SHARE,
    StrideClock,
    Variation,
    check_variation,
)
from quadpipe.core import configs
from quadpipe.core.errors import QuadpipeError
from quadpipe.exporters.npz import npz_bytes
from quadpipe.sim.simulation import Result, simulate

WALK_SECONDS = 20.0
FPS = 120.0
SETTLE_S = 2.0
FAR_GOAL = "[1000 HP, 0, 0]"
AMOUNT = 0.03
SEED = 2

CV_BAND = (0.01, 0.06)
"""Stride-time coefficient of variation asked 0.03: measured over 19 strides."""

STEADY_CV = 0.008
"""Without variation: frame quantisation alone (a frame is 1 % of a stride)."""

PHASE_TOLERANCE = 0.05
STEP_TIME_ASYMMETRY = (0.01, 0.08)
STEP_LENGTH_ASYMMETRY = (0.005, 0.05)
STEADY_ASYMMETRY = 0.005
"""Relative left-right differences of step times and lengths: with variation, and without."""


@functools.cache
def walk(amount: float, seed: int = 0, seconds: float = WALK_SECONDS) -> Result:
    """The dog's walk, with `amount` of variation (0: none)."""
    variation = Variation(amount, seed) if amount else None
    return simulate("dog", "walk", seconds=seconds, parameters={"goal": FAR_GOAL}, fps=FPS, variation=variation)


def stride_times(result: Result) -> np.ndarray:
    """Durations of the whole strides after settling (left hind touchdown to the next), seconds."""
    frames = np.array(analyze_clip(result.clip).animals[0].stride_frames)
    return np.diff(frames[frames >= SETTLE_S * FPS]) / FPS


def asymmetries(result: Result) -> tuple[float, float]:
    """(left - right) / mean of the hind steps' times and lengths after settling: a left step
    from a right hind touchdown to the next left one, its length the pelvis's travel."""
    report = analyze_clip(result.clip).animals[0]
    pelvis = result.clip.animals[0].positions[:, ROLES.index("pelvis"), :2]
    touchdowns = {
        leg: np.array([f.touchdown_frame for f in report.legs[leg].footfalls if f.touchdown_frame is not None])
        for leg in ("lh", "rh")
    }

    def steps(start: str, end: str) -> tuple[float, float]:
        pairs = [
            (first, touchdowns[end][touchdowns[end] > first][0])
            for first in touchdowns[start][touchdowns[start] >= SETTLE_S * FPS]
            if (touchdowns[end] > first).any()
        ]
        times = [(last - first) / FPS for first, last in pairs]
        lengths = [np.linalg.norm(pelvis[last] - pelvis[first]) for first, last in pairs]
        return float(np.mean(times)), float(np.mean(lengths))

    (left_time, left_length), (right_time, right_length) = steps("rh", "lh"), steps("lh", "rh")
    return (
        (left_time - right_time) / ((left_time + right_time) / 2),
        (left_length - right_length) / ((left_length + right_length) / 2),
    )


def test_the_same_seed_gives_the_same_clip_bytes_and_another_seed_another_clip():
    first = walk(AMOUNT, 5, 3.0).clip
    again = simulate("dog", "walk", seconds=3.0, parameters={"goal": FAR_GOAL}, fps=FPS, variation=Variation(AMOUNT, 5))
    assert npz_bytes(again.clip) == npz_bytes(first)
    other = walk(AMOUNT, 6, 3.0).clip
    assert npz_bytes(other) != npz_bytes(first)
    assert np.abs(other.animals[0].positions - first.animals[0].positions).max() > 1e-3


def test_the_clip_says_its_variation_and_seed():
    assert walk(AMOUNT, 5, 3.0).clip.metadata.items() >= {"variation": "0.03", "seed": "5"}.items()
    assert "variation" not in walk(0.0).clip.metadata


def test_stride_times_vary_as_asked_and_not_at_all_without():
    varied, steady = stride_times(walk(AMOUNT, SEED)), stride_times(walk(0.0))
    assert len(varied) >= 15 and len(steady) >= 15
    assert CV_BAND[0] <= varied.std() / varied.mean() <= CV_BAND[1]
    assert steady.std() / steady.mean() <= STEADY_CV
    assert varied.mean() == pytest.approx(steady.mean(), rel=0.02)


def test_a_varied_walk_goes_20_s_without_falling_and_keeps_its_footfall_phases():
    result = walk(AMOUNT, SEED)
    assert not result.metrics["animals"]["dog"]["fell"]
    tunables = load_controller("walk").tunables
    legs = analyze_clip(result.clip).animals[0].legs
    for leg in ("lf", "rh", "rf"):
        wanted = float(tunables[f"phase_{leg}"].value)
        measured = legs[leg].phase
        assert measured is not None
        assert abs((measured - wanted + 0.5) % 1 - 0.5) <= PHASE_TOLERANCE, (leg, measured, wanted)


def test_left_and_right_steps_differ_a_little_the_way_the_seeds_bias_says():
    bias = StrideClock(Variation(AMOUNT, SEED), 1, 1).bias[0]
    times, lengths = asymmetries(walk(AMOUNT, SEED))
    # the first half of a stride (left hind down to right hind down: a right step) runs at 1 + bias
    assert np.sign(times) == np.sign(bias) and STEP_TIME_ASYMMETRY[0] <= abs(times) <= STEP_TIME_ASYMMETRY[1]
    assert STEP_LENGTH_ASYMMETRY[0] <= abs(lengths) <= STEP_LENGTH_ASYMMETRY[1]
    steady_times, steady_lengths = asymmetries(walk(0.0))
    assert abs(steady_times) <= STEADY_ASYMMETRY and abs(steady_lengths) <= STEADY_ASYMMETRY


def _has_cycle(controller: str) -> bool:
    return any(element.type == "cycle" for element in load_controller(controller).elements.values())


@pytest.mark.parametrize("controller", [name for name in configs.available("controllers") if _has_cycle(name)])
def test_every_controller_with_a_clock_varies_without_editing_its_file(controller):
    def clip_bytes(variation: Variation | None) -> bytes:
        return npz_bytes(simulate("dog", controller, seconds=1.0, variation=variation).clip)

    assert clip_bytes(Variation(AMOUNT, 1)) != clip_bytes(None)


def test_a_clock_draws_a_factor_per_stride_around_one_and_a_fixed_bias_per_animal():
    clock = StrideClock(Variation(0.05, 3), cycles=2, animals=3)
    first_halves = [np.full((2, 3), stride + 0.25) for stride in range(1000)]  # 1000 strides: more than drawn at first
    factors = np.stack([clock.rates(phase) for phase in first_halves], axis=-1) / (1 + clock.bias[:, None])
    assert factors.std() == pytest.approx(0.05, rel=0.1) and factors.mean() == pytest.approx(1.0, abs=0.005)
    assert not np.allclose(factors[0, 0], factors[0, 1]) and not np.allclose(factors[0, 0], factors[1, 0])
    np.testing.assert_allclose(np.abs(clock.bias), SIDE_BIAS_SHARE * 0.05)
    second_half = clock.rates(first_halves[7] + 0.5) / clock.rates(first_halves[7])
    np.testing.assert_allclose(second_half, np.broadcast_to((1 - clock.bias) / (1 + clock.bias), (2, 3)))


@pytest.mark.parametrize(("amount", "seed"), [(MAX_VARIATION * 1.5, 0), (-0.01, 0), (float("nan"), 0), (0.03, -1)])
def test_a_variation_out_of_range_is_refused(amount, seed):
    with pytest.raises(QuadpipeError) as raised:
        check_variation(amount, seed)
    assert raised.value.issues[0].code == "bad-variation"


def test_the_command_line_names_the_option_it_refuses(cli, tmp_path):
    result = cli("simulate", "-c", "walk", "-s", "1", "-o", str(tmp_path / "x.npz"), "--variation", "0.5")
    assert result.returncode == 1
    assert "bad-variation: --variation: 0.5" in result.stderr and not (tmp_path / "x.npz").exists()


def test_a_batch_plan_carries_its_variation_to_every_job_and_its_files(tmp_path):
    from quadpipe.batch.jobs import expand_jobs, run_job
    from quadpipe.batch.plan import load_plan
    from quadpipe.exporters.npz import load_clip

    path = tmp_path / "plan.yaml"
    path.write_text(
        f"animals: [dog]\ncontrollers: [walk]\nseconds: 1\nformats: [npz]\noutput: {tmp_path}\nvariation: 0.03\nseed: 4\n"
    )
    (job,) = expand_jobs(load_plan(path))
    assert (job.variation, job.seed) == (0.03, 4)
    run_job(job)
    assert load_clip(job.outputs[0]).metadata.items() >= {"variation": "0.03", "seed": "4"}.items()


def test_a_batch_plan_refuses_a_variation_out_of_range_where_it_is_written(tmp_path):
    from quadpipe.batch.plan import load_plan, plan_from

    path = tmp_path / "plan.yaml"
    path.write_text("animals: [dog]\ncontrollers: [walk]\nvariation: 0.5\n")
    with pytest.raises(QuadpipeError) as raised:
        load_plan(path)
    assert raised.value.issues[0].where is not None and raised.value.issues[0].where.line == 3
    with pytest.raises(QuadpipeError):
        plan_from(None, animals=["dog"], controllers=["walk"], seed=-1)
