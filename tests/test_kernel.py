"""The controller kernel computes what the language means.

The reference meaning of an expression is the numpy evaluator of `expressions.py` (which
also folds every constant); the kernel must give the same numbers for every function and
operator, with scalars and vectors mixed, through a real runtime. A crowd's animals are
each driven as they would be alone.
"""

from __future__ import annotations

import math
from pathlib import Path

import mujoco
import numpy as np
import pytest
import yaml

from quadpipe.controllers.language.compiler import compile_controller
from quadpipe.controllers.language.load import load_controller
from quadpipe.controllers.runtime.runtime import ControllerRuntime
from quadpipe.core import configs
from quadpipe.quantities.expressions import FUNCTIONS, HEADING_FRAME_KEY
from quadpipe.quantities.units import scale_for_animals
from quadpipe.sim.simulation import simulate
from quadpipe.world import build_scene, load_scene
from tests.conftest import built_animal

PROBES: dict[str, str] = {
    "sin": "sin(t / 1 s)",
    "cos": "cos(t / 1 s) - 0.5",
    "tan": "tan(t / 4 s)",
    "asin": "asin(t / 2 s - 1) / 1 rad",
    "acos": "acos(0.8 - t / 2 s) / 1 rad",
    "atan": "atan(t / 1 s - 1) / 1 rad",
    "atan2": "atan2(t - 1 s, 0.5 s) / 1 rad",
    "sqrt": "sqrt(t / 1 s - 0.5)",
    "exp": "exp(-t / 1 s)",
    "log": "log(t / 1 s)",
    "abs": "abs(t - 1 s) / 1 s",
    "sign": "sign(t - 1 s)",
    "min": "min(t / 1 s, 1, 2 - t / 1 s)",
    "max": "max(t / 1 s, 1)",
    "clamp": "clamp(t / 1 s, 0.5, 1.2)",
    "wrap": "wrap(0.25 - t / 1 s)",
    "leg_sweep": "leg_sweep(wrap(t / 1 s), 0.6)",
    "leg_lift": "leg_lift(wrap(t / 1 s), 0.6)",
    "step": "step(1 s, t)",
    "smoothstep": "smoothstep(0.5 s, 2 s, t) + smoothstep(1 s, 1 s, t)",
    "mix": "mix(1, 3, t / 2 s) + dot(mix([1, 0, 0], [0, 2, 0], t / 1 s), [1, 1, 0])",
    "norm": "norm([t / 1 s, 1, 2])",
    "normalize": "dot(normalize([t / 1 s - 1, 1, 0]), [1, 0, 0]) + norm(normalize([0, 0, 0]))",
    "dot": "dot([t / 1 s, 1, 2], [3, t / 1 s, -1])",
    "cross": "cross([t / 1 s, 1, 0], [0, 1, t / 1 s]).x + cross([1, t / 1 s, 0], [0, 0, 1]).y",
    "angle": "angle([1, 0, 0], [1, t / 1 s, 0]) / 1 rad",
    "horizontal": "norm(horizontal([1, 2, t / 1 s]))",
    "heading": "heading([t / 1 s, 1, 0]).x + heading([0, 0, t / 1 s]).z",
    "froude_speed": "froude_speed(t / 1 s) / 1 m/s",
    "phase": "phase(clock)",
    "contact": "1 if contact(lf) else 0",
    "operators": "(t / 1 s) ^ 2 - t / 1 s * 3 + 1 / (t / 1 s - 1) + (-(t / 1 s))",
    "comparisons": "(1 if 0.5 s < t <= 1.5 s else 0) + (1 if t > 1 s and not t >= 2 s or t < 0.2 s else 0)",
    "components": "[t / 1 s, 2, 3].x * [t / 1 s, 2, 3].y - [1, 2, t / 1 s].z",
    "sensor": "dot(tilt, [0, 0, 1]) / 1 m/s^2",
    "interp": "interp(t, [0.5 s, 1 s, 1 s, 2 s], [0, 2, -1, 3]) + interp(t, [0 s, 2 s], [[1 HP, 0, 0], [0, 3 HP, 0]]).y / 1 m",
}
"""One probe per function of the language (and per operator kind): a plain number that
depends on the simulation (`t`, a cycle, a contact, a sensor), so it is not folded."""

SPECIAL = {"phase", "contact"}
"""Functions whose argument is a name: probed by reading the state they name."""

TIMES_S = (0.15, 0.7, 1.05, 1.6, 2.4)
"""Probe times: on both sides of every edge, branch and wrap the probes have."""


def probe_controller(folder: Path) -> Path:
    """A controller with one probe per entry of PROBES: a 1 N pull scaled by it."""
    elements = [
        {"type": "cycle", "name": "clock", "sites": {"pelvis.mid": 0}, "period": "0.8 s", "strength": "0 N"},
        {"type": "sensor", "name": "tilt", "kind": "balance", "at": "thorax.mid", "smoothing": "0.05 s"},
        {"type": "sensor", "name": "hip_height", "kind": "height", "at": "pelvis.mid"},
        {"type": "sensor", "name": "ground", "kind": "contact_normal"},
        {"type": "sensor", "name": "hip_velocity", "kind": "velocity", "at": "pelvis.mid"},
    ]
    for name, text in PROBES.items():
        elements.append({
            "type": "pull", "name": f"probe_{name}", "at": "pelvis.mid", "direction": {"vector": [0, 0, 1], "frame": "world"},
            "strength": f"({text}) * 1 N",
        })  # fmt: skip
    path = folder / "probes.yaml"
    path.write_text(yaml.safe_dump({"schema": 1, "name": "probes", "elements": elements}, sort_keys=False))
    return path


def reference_env(runtime: ControllerRuntime, data: mujoco.MjData) -> dict[str, np.ndarray]:
    """The env the numpy evaluator reads, from the runtime's own state after its step."""
    phase_row = runtime.program.cycles.index("clock")
    contacts = runtime._arrays["contact"][:, 0] > 0.5
    return {
        "t": np.full(runtime.n, data.time),
        HEADING_FRAME_KEY: runtime.heading_frames(data),
        "phase:clock": runtime._arrays["phase"][phase_row] % 1.0,
        "contact:lf": contacts,
        "sensor:tilt": runtime.sensor_values(data)["tilt"],
    }


def test_every_function_of_the_language_is_probed() -> None:
    assert set(FUNCTIONS) <= set(PROBES)


def test_the_kernel_computes_every_function_as_the_reference_does(tmp_path: Path) -> None:
    built = built_animal("dog")
    setup = build_scene(load_scene("flat"), built)
    model, compiled = (
        setup.spec.compile(),
        compile_controller(load_controller(str(probe_controller(tmp_path))), scale_for_animals([built.animal])),
    )
    data = mujoco.MjData(model)
    runtime = ControllerRuntime(compiled, model, setup.placements)
    pulls = [index for index, (_, kind) in enumerate(runtime.program.slots) if kind == "pull"]
    assert len(pulls) == len(PROBES)
    checked = 0
    while data.time < max(TIMES_S) + model.opt.timestep / 2:
        mujoco.mj_step1(model, data)
        data.xfrc_applied[:] = 0.0
        runtime.apply(model, data)
        if any(abs(data.time - time) < model.opt.timestep / 2 for time in TIMES_S):
            env = reference_env(runtime, data)
            for slot, name in zip(pulls, PROBES):
                expected = compiled.elements[f"probe_{name}"].value("strength")(env)[0]
                got = runtime.last.forces[slot, 2]
                assert got == pytest.approx(expected, rel=1e-12, abs=1e-12), (
                    f"{name} at t = {data.time:.3f} s: {PROBES[name]}"
                )
            checked += 1
        data.xfrc_applied[:] = 0.0  # the probes only measure: the dog stays a passive ragdoll
        mujoco.mj_step2(model, data)
    assert checked == len(TIMES_S)


FAR_GOAL = {"goal": "[100000 HP, 0, 0]"}
"""Straight ahead of each animal, so far that where it starts makes no difference."""


RAMP_DEG = 10.0
RAMP_START_HP = -6.0


def ramp_scene(folder: Path) -> Path:
    """A 10 degree ramp rising along +x, under the animal from the start."""
    path = folder / "ramp.yaml"
    terrain = [
        {
            "type": "slope",
            "start": f"{RAMP_START_HP} HP",
            "angle": f"{RAMP_DEG} deg",
            "length": "12 HP",
            "top": "2 HP",
            "width": "8 HP",
        }
    ]
    path.write_text(yaml.safe_dump({"schema": 1, "name": "ramp", "terrain": terrain}, sort_keys=False))
    return path


def test_sensors_measure_what_they_say(tmp_path: Path) -> None:
    built = built_animal("dog")
    setup = build_scene(load_scene(str(ramp_scene(tmp_path))), built)
    model, compiled = (
        setup.spec.compile(),
        compile_controller(load_controller(str(probe_controller(tmp_path))), scale_for_animals([built.animal])),
    )
    data = mujoco.MjData(model)
    runtime = ControllerRuntime(compiled, model, setup.placements)
    while True:  # a passive dog falls onto the ramp: until its feet touch it
        mujoco.mj_step1(model, data)
        runtime.apply(model, data)
        if runtime._arrays["contact"].any() or data.time > 1.0:
            break
        data.xfrc_applied[:] = 0.0
        mujoco.mj_step2(model, data)
    sensors, hip = runtime.sensor_values(data), runtime.point(data, "pelvis.mid")
    slope = math.tan(math.radians(RAMP_DEG))
    ground_below = (hip[:, 0] - RAMP_START_HP * built.animal.pelvis_height) * slope
    assert runtime._arrays["contact"].any(), "a foot on the ramp"
    assert sensors["hip_height"] == pytest.approx(hip[:, 2] - ground_below, abs=1e-6)
    np.testing.assert_allclose(
        sensors["ground"], [[-math.sin(math.radians(RAMP_DEG)), 0.0, math.cos(math.radians(RAMP_DEG))]], atol=1e-6
    )
    np.testing.assert_allclose(sensors["hip_velocity"], runtime.point_velocity(data, "pelvis.mid"), atol=1e-12)


def pair_scene(folder: Path) -> Path:
    """A dog, and a pig 6 HP behind it on the same line (animals do not collide with each other)."""
    path = folder / "pair.yaml"
    animals = [{"name": "a", "species": "dog", "at": [0, 0]}, {"name": "b", "species": "pig", "at": ["-6 HP", 0]}]
    path.write_text(yaml.safe_dump({"schema": 1, "name": "pair", "animals": animals}, sort_keys=False))
    return path


def test_animals_of_a_crowd_are_each_driven_as_when_alone(tmp_path: Path) -> None:
    pair = simulate("dog", "spine_walk", seconds=2.0, scene=str(pair_scene(tmp_path)), parameters=FAR_GOAL).clip
    for track, species in zip(pair.animals, ("dog", "pig")):
        alone = simulate(species, "spine_walk", seconds=2.0, parameters=FAR_GOAL).clip.animals[0]
        together = track.positions - track.positions[0, 0]
        np.testing.assert_allclose(together, alone.positions - alone.positions[0, 0], atol=1e-6 * track.pelvis_height)


HEIGHT_POINTS = ("lf.top", "rh.top", "pelvis.mid", "thorax.end", "lf_fpha0.end")
"""Where the height probe measures: high and low, front and back, a toe."""

PROPS = [
    {"name": "crate", "type": "box", "at": ["3 HP", 0, "0.3 HP"], "size": ["1 HP", "1 HP", "0.6 HP"], "mass": "1 bm"},
    {"name": "ball", "type": "sphere", "at": ["5 HP", 0, "0.4 HP"], "size": ["0.4 HP"], "mass": "0.1 bm"},
    {"name": "log", "type": "capsule", "at": ["7 HP", 0, "0.25 HP"], "size": ["0.25 HP", "2 HP"], "mass": "0.2 bm",
     "euler": ["90 deg", 0, 0]},
]  # fmt: skip
"""Props the dog is carried over in `props.yaml`, one of each shape."""

SWEEP_HP = [(x, 0.0) for x in np.arange(-2.0, 14.0, 0.37)] + [(0.0, -3.0), (9.0, -3.0)]
"""Where the animals are carried (HP along +x, HP up or down): over every terrain feature and
prop, and under the floor (where there is nothing below)."""


def height_probe(folder: Path) -> Path:
    """A controller with one unsmoothed `height` sensor per HEIGHT_POINTS entry, and nothing else."""
    elements = [
        {"type": "sensor", "name": f"height_{index}", "kind": "height", "at": point}
        for index, point in enumerate(HEIGHT_POINTS)
    ]
    path = folder / "heights.yaml"
    path.write_text(yaml.safe_dump({"schema": 1, "name": "heights", "elements": elements}, sort_keys=False))
    return path


def props_scene(folder: Path) -> Path:
    path = folder / "props.yaml"
    path.write_text(yaml.safe_dump({"schema": 1, "name": "props", "props": PROPS}, sort_keys=False))
    return path


def ray_down(model: mujoco.MjModel, data: mujoco.MjData, point: np.ndarray) -> tuple[float, int]:
    """What a `height` sensor means: the distance down to the first world geom (the point's z
    over nothing), and that geom (-1: none), by MuJoCo's ray cast called from Python."""
    geom = np.zeros(1, dtype=np.int32)
    world_only = np.array([1, 0, 0, 0, 0, 0], dtype=np.uint8)
    distance = mujoco.mj_ray(model, data, point, np.array([0.0, 0.0, -1.0]), world_only, 1, -1, geom)
    return (distance if distance >= 0 else float(point[2])), int(geom[0])


@pytest.mark.parametrize("scene", [*configs.available("scenes"), "props"])
def test_height_sensors_measure_the_ground_below_as_a_ray_cast_does(tmp_path: Path, scene: str) -> None:
    """Carried over every terrain and prop, each `height` sensor reads what `mj_ray` says."""
    built = built_animal("dog")
    setup = build_scene(load_scene(str(props_scene(tmp_path)) if scene == "props" else scene), built)
    model = setup.spec.compile()
    data = mujoco.MjData(model)
    compiled = compile_controller(
        load_controller(str(height_probe(tmp_path))), scale_for_animals([p.built.animal for p in setup.placements])
    )
    runtime = ControllerRuntime(compiled, model, setup.placements)
    roots = [model.jnt_qposadr[model.body_jntadr[model.body(f"{p.name}/pelvis").rootid]] for p in setup.placements]
    start = data.qpos.copy()
    hp = built.animal.pelvis_height
    hit: set[int] = set()
    for dx, dz in SWEEP_HP:
        data.qpos[:] = start
        data.qpos[roots] += dx * hp
        data.qpos[np.add(roots, 2)] += dz * hp
        mujoco.mj_forward(model, data)
        runtime.apply(model, data)
        sensors = runtime.sensor_values(data)
        for index in range(len(HEIGHT_POINTS)):
            at = runtime.point(data, compiled.elements[f"height_{index}"].spec.at)
            expected, geoms = zip(*(ray_down(model, data, p) for p in at))
            np.testing.assert_allclose(sensors[f"height_{index}"], expected, rtol=0, atol=1e-9 * hp)
            hit.update(geoms)
    assert -1 in hit, "some points have nothing below them"
    terrain = [g for g in range(model.ngeom) if model.geom_bodyid[g] == 0 and model.geom_group[g] == 0]
    if scene == "props":
        hit_bodies = {model.body(model.geom_bodyid[g]).name for g in hit if g >= 0}
        assert {prop["name"] for prop in PROPS} <= hit_bodies, f"the sweep passes over every prop: hit {hit_bodies}"
    elif len(terrain) > 1:
        assert len(hit & set(terrain)) > 1, "the sweep passes over the terrain's features, not the floor alone"


def test_a_flat_floor_is_read_without_a_ray_and_exactly_as_a_ray_reads_it() -> None:
    """On a floor of horizontal planes through z = 0 (`runtime.flat_ground`) the kernel answers a
    `height` sensor with the point's own z instead of casting a ray: MuJoCo's ray gives that
    very number, bit for bit, above the floor, below it and past a finite plane's edge."""
    from quadpipe.controllers.runtime.runtime import flat_ground

    built = built_animal("dog")
    hp = built.animal.pelvis_height
    flat = build_scene(load_scene("flat"), built).spec.compile()
    assert flat_ground(flat)
    assert not any(flat_ground(build_scene(load_scene(s), built).spec.compile()) for s in ("hill", "stairs", "throws"))
    data = mujoco.MjData(flat)
    mujoco.mj_forward(flat, data)
    for x, y, z in ((0.3, -0.2, 0.7), (1e3, 2e3, 0.01), (0.0, 0.0, -0.05), (5.0, 5.0, 0.0), (-7.1, 0.4, 3.3)):
        point = np.array([x, y, z]) * hp
        assert ray_down(flat, data, point)[0] == point[2]
