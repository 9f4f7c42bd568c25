"""The runtime reads MuJoCo's contacts through views made once per data (`ControllerRuntime._contacts`).

They stay valid only because MuJoCo keeps its contacts at the start of the data's arena: if a
MuJoCo version moved them, these views would read stale memory and feet would touch nothing.
"""

from __future__ import annotations

import mujoco
import numpy as np

from quadpipe.sim.simulation import Simulation
from quadpipe.world import build_scene, load_scene
from tests.conftest import built_animal

STEPS = 200
"""Physics steps of the dog's walk checked (0.4 s: feet land and lift)."""


def test_contact_views_made_once_see_every_step_contacts() -> None:
    sim = Simulation(build_scene(load_scene("flat"), built_animal("dog")))
    sim.use_controller(sim.compile_controller("walk")[0])
    runtime = sim.runtime
    assert runtime is not None
    counts = set()
    for step in range(STEPS):
        if step == STEPS // 2:
            mujoco.mj_resetData(sim.model, sim.data)  # the arena is reset, the views kept
            mujoco.mj_forward(sim.model, sim.data)
        sim.step()
        geoms, frames = runtime._contacts
        ncon, contacts = sim.data.ncon, sim.data.contact
        counts.add(ncon)
        np.testing.assert_array_equal(geoms[:ncon], contacts.geom)
        np.testing.assert_array_equal(frames[:ncon], contacts.frame)
    assert len(counts) > 3, "the contacts changed as the feet landed and lifted"
    legs_down = runtime._arrays["contact"]
    assert legs_down.any(), "the kernel saw feet on the ground"
