"""Folding a lowered controller (`quadpipe.controllers.runtime.folding`) drops work, never a force.

Every shipped controller, folded and as lowered, is applied to the same dog state step after
step: their forces, joint torques and damping must be equal. And folding must keep doing its job:
the walk's tunables at 0 (`unload`, `landing_share`) and its terms multiplied by constants
0 or 1 leave far fewer instructions than lowering emits.
"""

from __future__ import annotations

import functools

import mujoco
import numpy as np
import pytest

from quadpipe.controllers.language.compiler import CompiledController
from quadpipe.controllers.runtime.folding import fold
from quadpipe.controllers.runtime.lowering import lower
from quadpipe.controllers.runtime.ops import COMP, COMPONENT_A, DIV, MUL, VEC, B, E
from quadpipe.controllers.runtime.runtime import ControllerRuntime
from quadpipe.core import configs
from quadpipe.sim.simulation import Simulation
from quadpipe.world import build_scene, load_scene
from tests.conftest import built_animal

STEPS = 150
"""Physics steps compared per controller (0.3 s on the dog: feet land, machines switch)."""

MIN_WALK_SAVING = 0.15
"""Share of the walk's lowered instructions that folding removes at least (it removed 17 %)."""


@functools.cache
def dog_world() -> Simulation:
    """The dog on flat ground, no controller."""
    return Simulation(build_scene(load_scene("flat"), built_animal("dog")))


def compiled(controller: str, **parameters: str) -> CompiledController:
    """`controller` compiled for the dog, with parameter overrides (once per session)."""
    return _compiled(controller, tuple(sorted(parameters.items())))


@functools.cache
def _compiled(controller: str, parameters: tuple[tuple[str, str], ...]) -> CompiledController:
    return dog_world().compile_controller(controller, dict(parameters))[0]


MOVING_TARGET = (
    "interp(t, [0 s, 0.1 s, 0.1 s, 0.3 s], [[1 HP, 0, 1 HP], [2 HP, 1 HP, 1 HP], [0, 1 HP, 1 HP], [1 HP, 0, 0]])"
)
"""A `point_target` target read from a table (`INTERP`: blocks of constant registers that
folding renumbers), with a jump at 0.1 s, moving through the steps compared."""


@pytest.mark.parametrize("controller", configs.available("controllers"))
def test_folded_program_applies_the_same_forces(controller: str) -> None:
    assert_same_forces(controller, compiled(controller))


def test_a_folded_table_reads_the_same_points() -> None:
    assert_same_forces("point_target with a table", compiled("point_target", target=MOVING_TARGET))


def assert_same_forces(controller: str, program: CompiledController) -> None:
    """`program`, folded and as lowered, applies the same forces to the dog step after step."""
    sim = dog_world()
    sim.use_controller(None)
    sim.reset()
    model, data = sim.model, sim.data
    folded = ControllerRuntime(program, model, sim.placements)
    lowered = ControllerRuntime(program, model, sim.placements, folded=False)
    assert len(folded.program.code) <= len(lowered.program.code)
    for step in range(STEPS):
        mujoco.mj_step1(model, data)
        applied = []
        for runtime in (lowered, folded):  # apply reads the state, writes only these three
            data.xfrc_applied[:] = 0.0
            data.qfrc_applied[:] = 0.0
            runtime.apply(model, data)
            applied.append((data.xfrc_applied.copy(), data.qfrc_applied.copy(), model.dof_damping.copy()))
        for before, after in zip(*applied):
            np.testing.assert_array_equal(after, before, err_msg=f"{controller}, step {step}")
        mujoco.mj_step2(model, data)
    assert folded.fault == lowered.fault
    folded.release()


def test_folding_removes_the_walks_dead_terms() -> None:
    walk = lower(compiled("walk"), dog_world().model.opt.gravity)
    folded = fold(walk)
    assert len(folded.code) <= (1 - MIN_WALK_SAVING) * len(walk.code)
    assert folded.registers < walk.registers
    unloading = fold(lower(compiled("walk", unload="0.5"), dog_world().model.opt.gravity))
    assert len(folded.code) < len(unloading.code), "a tunable at 0 still costs instructions"


def test_a_spring_at_zero_stiffness_and_damping_is_dropped() -> None:
    gravity = dog_world().model.opt.gravity
    walk = fold(lower(compiled("walk"), gravity))
    limp = fold(
        lower(compiled("walk", toe_stiffness="0 bw*HP/rad", spring_damping="0 bw*HP*natural_time/rad"), gravity)
    )
    assert len(limp.code) < len(walk.code)
    assert limp.slots == walk.slots, "every force slot stays (overlays and metrics read them)"


def test_a_component_read_by_arithmetic_costs_no_instruction() -> None:
    gravity = dog_world().model.opt.gravity
    walk, lowered = fold(lower(compiled("walk"), gravity)), lower(compiled("walk"), gravity)
    assert COMP in lowered.code[:, 0], "the walk reads components (the spring terms' heights)"
    assert COMP not in walk.code[:, 0], "every one is read by arithmetic, at its component"
    assert any(int(row[E]) >> COMPONENT_A for row in walk.code if row[0] < VEC)


def test_a_division_by_a_constant_power_of_two_is_a_product_by_its_reciprocal() -> None:
    program = fold(lower(compiled("auto_gait"), dog_world().model.opt.gravity), fused=False)
    divisors = [program.constants.get(int(row[B])) for row in program.code if row[0] == DIV]
    assert not [d for d in divisors if d is not None and (np.abs(np.frexp(d)[0]) == 0.5).all()]
    assert [d for d in divisors if d is not None], "a division by another constant stays (1 / d is not exact)"
    halves = [
        row for row in program.code if row[0] == MUL and (program.constants.get(int(row[B]), np.ones(1)) == 0.5).all()
    ]
    assert halves, "auto_gait's halvings (x / 2) are products by 0.5"
    dividends = np.array([1.0, -3.0, 0.1, 5e-324, 2.2e-308, 1.7e308, np.inf, -0.0])
    for power in (2.0, 0.5, -4.0, 2.0**-1022, 2.0**1023):
        with np.errstate(over="ignore"):  # 1.7e308 / 2**-1022 is inf both ways
            np.testing.assert_array_equal(dividends / power, dividends * (1.0 / power))


NEUTRAL_TUNABLES = {
    "contact_springs": "0.5",
    "front_trailing_straight": "0.5",
    "hind_trailing_straight": "0.5",
    "contact_share": "0.5",
    "hind_give": "5 deg",
    "front_toe_roll": "10 deg",
    "hind_toe_roll": "10 deg",
    "landing_speed": "0.3 / natural_time",
    "swing_retraction": "1",
    "front_loading_flex": "10 deg",
    "hind_loading_flex": "10 deg",
    "front_trailing_floor": "0.5",
    "hind_trailing_floor": "0.5",
    "front_loading_shortening": "0.05",
    "hind_loading_shortening": "0.05",
    "front_loading_shoulder": "1",
    "load_traction": "0.3",
    "front_fold_lead": "0.4",
    "hind_fold_lead": "0.4",
    "front_elbow_delay": "0.05",
    "front_carpus_delay": "0.11",
}
"""`locomotion` tunables whose default keeps the gaits as they were, each with a value that
acts: at their default (the base's own) they must cost the gaits that leave them there no
instruction."""

STRETCHED_REACH = "1.1"
"""`reach` as the walk sets it: at the base's 1 a trailing leg's straightening changes nothing."""


@pytest.mark.parametrize("tunable", sorted(NEUTRAL_TUNABLES))
def test_a_tunable_left_at_its_neutral_default_costs_nothing(tunable: str) -> None:
    gravity = dog_world().model.opt.gravity
    base = fold(lower(compiled("locomotion", reach=STRETCHED_REACH), gravity))
    acting = fold(lower(compiled("locomotion", reach=STRETCHED_REACH, **{tunable: NEUTRAL_TUNABLES[tunable]}), gravity))
    assert len(base.code) < len(acting.code), f"{tunable} at its default still costs instructions"
