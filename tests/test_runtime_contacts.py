"""The runtime reads MuJoCo's contacts through views made once per data (`ControllerRuntime._contacts`).

They stay valid only because MuJoCo keeps its contacts at the start of the data's arena: if a
MuJoCo version moved them, these views would read stale memory and feet would touch nothing.
The kernel reads the data's `time` and `ncon` itself, at the addresses `views.data_field` found.
"""

from __future__ import annotations

import ctypes

import mujoco
import numpy as np
import pytest

from quadpipe.controllers.runtime.views import _probe_field, data_field
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


def test_data_fields_are_the_data_time_and_contact_count() -> None:
    sim = Simulation(build_scene(load_scene("flat"), built_animal("dog")))
    time_at, ncon_at = data_field(sim.data, "time", np.float64), data_field(sim.data, "ncon", np.int32)
    seen = set()
    for _ in range(STEPS):
        sim.step()
        before = (sim.data.time, sim.data.ncon)
        assert (ctypes.c_double.from_address(time_at).value, ctypes.c_int32.from_address(ncon_at).value) == before
        assert _probe_field(sim.data, "ncon", np.int32) == ncon_at, "found again at the same place"
        assert (sim.data.time, sim.data.ncon) == before, "the probes put the values back"
        seen.add(before[1])
    assert len(seen) > 1, "the dog's contacts came and went"
    with pytest.raises(ValueError, match="maxuse_con"):
        _probe_field(sim.data, "maxuse_con", np.int32)  # a field before the searched part of the struct
