"""Scenes: loading with located errors, terrain geometry, throws, goals, several animals, scaling."""

from __future__ import annotations

import json
import math
import re
import warnings
from pathlib import Path

import mujoco
import numpy as np
import pytest

from quadpipe.controllers.language import compile_quantity
from quadpipe.core import configs
from quadpipe.core.errors import QuadpipeError
from quadpipe.quantities.fields import POINT
from quadpipe.quantities.units import STANDARD_GRAVITY, Scale
from quadpipe.world import SceneSetup, available_scenes, build_scene, load_scene, scene_json_schema
from quadpipe.world.placement import ground_height
from quadpipe.world.schema import SCHEMA_PATH, json_schema_text, write_schema
from quadpipe.world.throws import PARK_DEPTH_HP, ThrowEvent, flight_time
from tests.conftest import REPO, built_animal

SCENES = available_scenes()
SHIPPED = REPO / "configs" / "scenes"
SETTLE_STEPS = 60
"""Physics steps run on every shipped scene (half a second for the dog)."""


def write_scene(folder: Path, body: str, name: str = "scene.yaml") -> Path:
    """A scene file with the header every scene needs, then `body`."""
    path = folder / name
    path.write_text(f"schema: 1\nname: test\n{body}", encoding="utf-8")
    return path


def build(path_or_name: str | Path, animal: str = "dog") -> tuple[SceneSetup, mujoco.MjModel, mujoco.MjData]:
    setup = build_scene(load_scene(path_or_name), built_animal(animal))
    model = setup.spec.compile()
    return setup, model, mujoco.MjData(model)


def surface_height(model: mujoco.MjModel, x: float, y: float = 0.0) -> float:
    """Height of the static world under (x, y)."""
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    height = ground_height(model, data, x, y, 1000.0)
    assert height is not None
    return height


def error_text(path: Path) -> str:
    with pytest.raises(QuadpipeError) as caught:
        load_scene(path)
    return str(caught.value)


# --------------------------------------------------------------------------- shipped scenes


def test_the_scene_library_has_the_expected_scenes() -> None:
    assert set(SCENES) >= {"flat", "hill", "slope", "stairs", "steep_stairs", "throws", "crowd", "robustness"}


@pytest.mark.parametrize("name", SCENES)
def test_every_shipped_scene_builds_with_a_dog_and_steps_without_a_warning(name: str) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        setup, model, data = build(name)
    events = setup.events(model)
    for _ in range(SETTLE_STEPS):
        for event in events:
            event(model, data)
        mujoco.mj_step(model, data)
    assert [warning.number for warning in data.warning] == [0] * len(data.warning)
    assert np.isfinite(data.qpos).all()
    assert model.opt.timestep == pytest.approx(min(p.built.timestep for p in setup.placements))
    assert model.opt.iterations == 32


@pytest.mark.parametrize("name", SCENES)
def test_shipped_scenes_point_editors_at_the_schema_and_match_their_file_name(name: str) -> None:
    path = SHIPPED / f"{name}.yaml"
    assert (
        path.read_text(encoding="utf-8").splitlines()[0]
        == "# yaml-language-server: $schema=../../schemas/scene.schema.json"
    )
    assert load_scene(name).name == name


def test_committed_json_schema_is_up_to_date() -> None:
    committed = (REPO / SCHEMA_PATH).read_text(encoding="utf-8")
    assert committed == json_schema_text(), "run: python -m quadpipe.world.generate"


def test_json_schema_accepts_shipped_scenes_and_rejects_unknown_keys() -> None:
    jsonschema = pytest.importorskip("jsonschema")
    import yaml

    validator = jsonschema.Draft202012Validator(scene_json_schema())
    for name in SCENES:
        assert list(validator.iter_errors(yaml.safe_load((SHIPPED / f"{name}.yaml").read_text()))) == [], name
    assert list(validator.iter_errors({"schema": 1, "name": "x", "terain": []}))


def test_every_key_of_the_format_has_a_description() -> None:
    def walk(node: object) -> None:
        if isinstance(node, dict):
            for key, prop in node.get("properties", {}).items():
                assert prop.get("description"), key
            for value in node.values():
                walk(value)
        elif isinstance(node, list):
            for value in node:
                walk(value)

    walk(scene_json_schema())


# --------------------------------------------------------------------------- terrain


def test_hill_has_its_angle_its_height_on_the_plateau_and_ends_on_the_ground() -> None:
    setup, model, _ = build("hill")
    hp = setup.placements[0].built.animal.pelvis_height
    start, height, top, angle = 4 * hp, 0.5 * hp, 3 * hp, math.radians(12)
    run = height / math.tan(angle)
    up_slope = (surface_height(model, start + 0.7 * run) - surface_height(model, start + 0.3 * run)) / (0.4 * run)
    down_slope = (
        surface_height(model, start + run + top + 0.7 * run) - surface_height(model, start + run + top + 0.3 * run)
    ) / (0.4 * run)
    assert up_slope == pytest.approx(math.tan(angle), rel=1e-6)
    assert down_slope == pytest.approx(-math.tan(angle), rel=1e-6)
    assert surface_height(model, start + run + top / 2) == pytest.approx(height)
    assert surface_height(model, start - 0.1 * hp) == pytest.approx(0.0, abs=1e-9)
    assert surface_height(model, start + 2 * run + top + 0.1 * hp) == pytest.approx(0.0, abs=1e-9)
    assert surface_height(model, start + run / 2, y=3.9 * hp) > 0
    assert surface_height(model, start + run / 2, y=4.1 * hp) == pytest.approx(0.0, abs=1e-9)


def test_slope_rises_length_times_tan_angle_then_stays_flat() -> None:
    setup, model, _ = build("slope")
    hp = setup.placements[0].built.animal.pelvis_height
    rise = 12 * hp * math.tan(math.radians(10))
    assert surface_height(model, 3 * hp + 6 * hp) == pytest.approx(rise / 2)
    assert surface_height(model, 3 * hp + 12 * hp + 4 * hp) == pytest.approx(rise)


@pytest.mark.parametrize(
    ("name", "rise", "depth", "steps", "up"), [("stairs", 0.1, 0.6, 5, True), ("steep_stairs", 0.35, 0.5, 6, False)]
)
def test_stairs_have_their_steps(name: str, rise: float, depth: float, steps: int, up: bool) -> None:
    setup, model, _ = build(name)
    hp = setup.placements[0].built.animal.pelvis_height
    assert setup.scene.file.terrain[0].steps == steps
    x0 = (4 if name == "stairs" else 2) * hp
    for k in range(1, steps + 1):
        expected = (k if up else steps - k) * rise * hp
        assert surface_height(model, x0 + (k - 0.5) * depth * hp) == pytest.approx(expected, abs=1e-9), k
    landing_x = x0 + (steps * depth + 1) * hp if up else x0 - 1 * hp
    assert surface_height(model, landing_x, y=2 * hp) == pytest.approx(steps * rise * hp)


def test_an_animal_starting_on_terrain_is_lifted_onto_it() -> None:
    setup, model, _ = build("steep_stairs")
    flat_setup, flat_model, _ = build("flat")
    landing = 6 * 0.35 * setup.placements[0].built.animal.pelvis_height
    assert model.body("dog/pelvis").pos[2] - flat_model.body("dog/pelvis").pos[2] == pytest.approx(landing)


def test_a_box_item_is_placed_sized_and_turned(tmp_path: Path) -> None:
    path = write_scene(
        tmp_path,
        "terrain:\n  - {type: box, at: [5 HP, 1 HP, 0.5 HP], size: [2 HP, 1 HP, 1 HP], euler: [0, 0, 90 deg]}\n",
    )
    setup, model, _ = build(path)
    hp = setup.placements[0].built.animal.pelvis_height
    geom = model.geom("terrain0_box")
    assert geom.pos == pytest.approx([5 * hp, hp, 0.5 * hp])
    assert geom.size == pytest.approx([hp, 0.5 * hp, 0.5 * hp])
    assert geom.quat == pytest.approx([math.cos(math.pi / 4), 0, 0, math.sin(math.pi / 4)])


def test_ground_friction_goes_to_floor_terrain_and_bones_and_none_removes_the_floor(tmp_path: Path) -> None:
    slippery = write_scene(
        tmp_path, "ground: {friction: 0.3}\nterrain:\n  - {type: hill, start: 4 HP, angle: 10 deg, height: 0.5 HP}\n"
    )
    _, model, _ = build(slippery)
    assert model.geom("floor").friction[0] == pytest.approx(0.3)
    assert model.geom("terrain0_hill_up").friction[0] == pytest.approx(0.3)
    assert model.geom("dog/lf_fpha1").friction[0] == pytest.approx(0.3)
    nothing = write_scene(tmp_path, "ground: none\n", "none.yaml")
    _, model, _ = build(nothing)
    assert "floor" not in [model.geom(i).name for i in range(model.ngeom)]


# --------------------------------------------------------------------------- scaling


def test_the_hill_built_for_the_rat_is_the_dogs_hill_scaled_by_the_pelvis_height_ratio() -> None:
    dog_setup, dog, _ = build("hill", "dog")
    rat_setup, rat, _ = build("hill", "rat")
    ratio = rat_setup.placements[0].built.animal.pelvis_height / dog_setup.placements[0].built.animal.pelvis_height
    terrain = [i for i in range(dog.ngeom) if dog.geom(i).name.startswith("terrain")]
    assert len(terrain) == 3
    for i in terrain:
        name = dog.geom(i).name
        assert rat.geom(name).pos == pytest.approx(dog.geom(name).pos * ratio)
        assert rat.geom(name).size == pytest.approx(dog.geom(name).size * ratio)
        assert rat.geom(name).quat == pytest.approx(dog.geom(name).quat)
    dog_goal = compile_quantity(dog_setup.goal_parameters["goal"], Scale.of(1.0, 1.0), POINT).constant[0]
    rat_goal = compile_quantity(rat_setup.goal_parameters["goal"], Scale.of(1.0, 1.0), POINT).constant[0]
    assert rat_goal == pytest.approx(dog_goal * ratio)


# --------------------------------------------------------------------------- animals


def test_crowd_places_ten_named_dogs_in_a_grid() -> None:
    setup, model, _ = build("crowd", "rat")
    names = [p.name for p in setup.placements]
    assert names == [f"dog{k}" for k in range(1, 11)]
    assert {p.built.animal.name for p in setup.placements} == {"dog"}
    hp = setup.placements[0].built.animal.pelvis_height
    assert setup.placements[0].xy == pytest.approx((0.0, 2.4 * hp))
    assert setup.placements[6].xy == pytest.approx((-3 * hp, 2.4 * hp - 1.2 * hp))
    assert model.body("dog10/pelvis").pos[:2] == pytest.approx([-3 * hp, 2.4 * hp - 4 * 1.2 * hp])


def test_entries_without_species_take_the_given_animal_and_face_their_heading(tmp_path: Path) -> None:
    path = write_scene(
        tmp_path, "animals:\n  - {name: a, at: [0, 0]}\n  - {name: b, species: rat, at: [0, 3 HP], heading: 90 deg}\n"
    )
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        setup, model, _ = build(path, "cat")
    assert model.opt.timestep == pytest.approx(built_animal("rat").timestep)
    assert [p.built.animal.name for p in setup.placements] == ["cat", "rat"]
    assert setup.headings == pytest.approx([0.0, math.pi / 2])
    cat_hp = setup.placements[0].built.animal.pelvis_height
    assert setup.placements[1].xy == pytest.approx((0.0, 3 * cat_hp))
    assert model.body("b/pelvis").quat == pytest.approx([math.cos(math.pi / 4), 0, 0, math.sin(math.pi / 4)])


def test_the_wrong_number_of_animals_is_an_error(tmp_path: Path) -> None:
    path = write_scene(tmp_path, "animals:\n  - {name: a}\n  - {name: b}\n  - {name: c}\n")
    with pytest.raises(QuadpipeError, match="animal-count"):
        build_scene(load_scene(path), [built_animal("dog"), built_animal("cat")])


# --------------------------------------------------------------------------- throws


THROW_AT = 0.1


def throw_scene(tmp_path: Path, heading: str = "0 deg", source: str = "left") -> Path:
    return write_scene(
        tmp_path,
        f"animals:\n  - {{name: dog, heading: {heading}}}\n"
        f"throws:\n  - {{at: {THROW_AT} s, shape: box, size: [0.2 HP, 0.2 HP, 0.2 HP], mass: 0.1 bm, "
        f"from: {source}, speed: 4 m/s, target: pelvis, distance: 1 HP}}\n",
    )


def launch_now(model: mujoco.MjModel, data: mujoco.MjData, event: ThrowEvent) -> np.ndarray:
    """Stop the animal, set the clock to the throw time and run the event; returns the target point."""
    data.qvel[:] = 0.0
    mujoco.mj_forward(model, data)
    data.time = THROW_AT
    target = data.xpos[model.body("dog/pelvis").id].copy()
    event(model, data)
    return target


@pytest.mark.parametrize(
    ("heading", "source", "side"),
    [
        ("0 deg", "left", [0, 1, 0]),
        ("90 deg", "left", [-1, 0, 0]),
        ("0 deg", "front", [1, 0, 0]),
        ("0 deg", "[0, -1, 1]", [0, -math.sqrt(0.5), math.sqrt(0.5)]),
    ],
)
def test_a_throw_appears_beside_its_target_with_the_aimed_velocity(
    tmp_path: Path, heading: str, source: str, side: list[float]
) -> None:
    setup, model, data = build(throw_scene(tmp_path, heading, source))
    (event,) = setup.events(model)
    plan = setup.throws[0]
    hp = setup.placements[0].built.animal.pelvis_height
    target = launch_now(model, data, event)
    body = model.body(plan.body)
    qpos = model.jnt_qposadr[body.jntadr[0]]
    qvel = model.jnt_dofadr[body.jntadr[0]]
    position, velocity = data.qpos[qpos : qpos + 3], data.qvel[qvel : qvel + 3]
    side = np.array(side, dtype=float)
    assert position == pytest.approx(target + hp * side)
    flight = plan.flight_time
    expected_velocity = -hp * side / flight + np.array([0, 0, STANDARD_GRAVITY * flight / 2])
    assert velocity == pytest.approx(expected_velocity, rel=1e-3)
    arrival = velocity + np.array(model.opt.gravity) * flight
    assert np.linalg.norm(arrival) == pytest.approx(4.0, rel=1e-3)
    assert model.geom_contype[body.geomadr[0]] == 1 and model.body_gravcomp[body.id] == 0


def test_a_throw_leads_a_moving_target_by_its_horizontal_velocity(tmp_path: Path) -> None:
    setup, model, data = build(throw_scene(tmp_path))
    (event,) = setup.events(model)
    root = model.jnt_dofadr[model.body("dog/pelvis").jntadr[0]]
    data.qvel[root : root + 3] = [1.0, 0.5, 2.0]  # toward the throw's side (left): its start is not moved out
    mujoco.mj_forward(model, data)
    data.time = THROW_AT
    target = data.xpos[model.body("dog/pelvis").id].copy()
    event(model, data)
    plan = setup.throws[0]
    hp = setup.placements[0].built.animal.pelvis_height
    position = data.qpos[model.jnt_qposadr[model.body(plan.body).jntadr[0]] :][:3]
    assert position == pytest.approx(target + plan.flight_time * np.array([1.0, 0.5, 0.0]) + [0, hp, 0])


def test_a_thrown_object_flies_to_the_target_point_at_the_requested_speed(tmp_path: Path) -> None:
    setup, model, data = build(throw_scene(tmp_path))
    (event,) = setup.events(model)
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
    target = launch_now(model, data, event)
    body = model.body(setup.throws[0].body).id
    while data.time < THROW_AT + setup.throws[0].flight_time - 1e-9:
        mujoco.mj_step(model, data)
    hp = setup.placements[0].built.animal.pelvis_height
    assert np.linalg.norm(data.xpos[body] - target) < 0.02 * hp
    speed = np.linalg.norm(data.qvel[model.jnt_dofadr[model.body_jntadr[body]] :][:3])
    assert speed == pytest.approx(4.0, rel=0.01)


def test_a_thrown_object_is_parked_without_collisions_until_its_time_then_thrown_by_stepping(tmp_path: Path) -> None:
    setup, model, data = build(throw_scene(tmp_path))
    (event,) = setup.events(model)
    body = model.body(setup.throws[0].body)
    parked = model.body_pos[body.id].copy()
    hp = setup.placements[0].built.animal.pelvis_height
    assert parked[2] == pytest.approx(-PARK_DEPTH_HP * hp)
    while data.time < THROW_AT - model.opt.timestep / 2:
        event(model, data)
        mujoco.mj_step(model, data)
    assert data.xpos[body.id] == pytest.approx(parked)
    assert model.geom_contype[body.geomadr[0]] == 0 and model.body_contype[body.id] == 0
    event(model, data)
    mujoco.mj_step(model, data)
    pelvis = data.xpos[model.body("dog/pelvis").id]
    assert np.linalg.norm(data.xpos[body.id] - pelvis - [0, hp, 0]) < 0.1 * hp
    assert model.body_contype[body.id] == 1
    data.time = 0.0
    event(model, data)
    assert data.qpos[model.jnt_qposadr[body.jntadr[0]] + 2] == pytest.approx(parked[2])
    assert model.body_contype[body.id] == 0


ANIMALS = configs.available("animals")
SIDES = ("front", "back", "left", "right")


def touches_the_animal_at_launch(model: mujoco.MjModel, data: mujoco.MjData, body: int) -> bool:
    """Whether a thrown body, just launched, already touches one of the animal's bones (a body
    that is neither itself nor fixed to the world)."""
    mujoco.mj_forward(model, data)
    for contact in data.contact[: data.ncon]:
        pair = (int(model.geom_bodyid[contact.geom1]), int(model.geom_bodyid[contact.geom2]))
        if body in pair and any(other != body and model.body_rootid[other] != 0 for other in pair):
            return True
    return False


@pytest.mark.parametrize("animal", ANIMALS)
def test_a_default_throw_starts_clear_of_the_animal_from_every_side(tmp_path: Path, animal: str) -> None:
    """The slowest throw of the robustness series, from the front, behind and either side at
    the thorax: it appears outside the animal (a throw from the front used to appear inside
    the dog's head and stop there)."""
    throws = "".join(
        f"  - {{at: {THROW_AT * (k + 1)} s, shape: box, size: [0.2 HP, 0.2 HP, 0.2 HP], mass: 0.1 bm, "
        f"from: {side}, speed: froude_speed(1.4), target: thorax.mid}}\n"
        for k, side in enumerate(SIDES)
    )
    setup, model, data = build(write_scene(tmp_path, f"throws:\n{throws}"), animal)
    for event, side in zip(setup.events(model), SIDES, strict=True):
        data.qvel[:] = 0.0
        data.time = event.plan.time
        event(model, data)
        assert not touches_the_animal_at_launch(model, data, model.body(event.plan.body).id), side


@pytest.mark.parametrize("froude", [0.15, 0.6, 3.3])
@pytest.mark.parametrize("animal", ["rat", "dog", "elephant"])
def test_a_throw_at_a_moving_animal_starts_clear_of_it_from_every_side(
    tmp_path: Path, animal: str, froude: float
) -> None:
    """The same throws at an animal walking, trotting or galloping (Froude numbers): the aim
    leads it by its flight, and a throw from behind used to start inside the animal it aims
    ahead of (the walking dog's tenth box of the robustness series)."""
    throws = "".join(
        f"  - {{at: {THROW_AT * (k + 1)} s, shape: box, size: [0.2 HP, 0.2 HP, 0.2 HP], mass: 0.1 bm, "
        f"from: {side}, speed: froude_speed(1.4), target: thorax.mid}}\n"
        for k, side in enumerate(SIDES)
    )
    setup, model, data = build(write_scene(tmp_path, f"throws:\n{throws}"), animal)
    hp = setup.placements[0].built.animal.pelvis_height
    for event, side in zip(setup.events(model), SIDES, strict=True):
        data.qvel[:] = 0.0
        data.qvel[model.jnt_dofadr[model.body(f"{animal}/pelvis").jntadr[0]]] = math.sqrt(
            froude * STANDARD_GRAVITY * hp
        )
        data.time = event.plan.time
        event(model, data)
        assert not touches_the_animal_at_launch(model, data, model.body(event.plan.body).id), side


@pytest.mark.parametrize("lift_deg", [20.0, 40.0])
@pytest.mark.parametrize("animal", ANIMALS)
def test_a_throw_from_behind_starts_clear_of_a_carried_tail(tmp_path: Path, animal: str, lift_deg: float) -> None:
    """The tail carried out or up (every tail joint lifted as a walk carries it, or twice):
    a throw from behind starts clear of the tail as it is, not as it hangs at rest (with the
    rest pose's clearance 5 of these 20 touched: the dog's tail lifted 20 deg, the cat's, the
    cow's, the elephant's and the lion's lifted 40)."""
    throw = (
        f"  - {{at: {THROW_AT} s, shape: box, size: [0.2 HP, 0.2 HP, 0.2 HP], mass: 0.1 bm, "
        "from: back, speed: froude_speed(1.4), target: thorax.mid}\n"
    )
    setup, model, data = build(write_scene(tmp_path, f"throws:\n{throw}"), animal)
    for joint in range(model.njnt):
        if re.fullmatch(rf"{animal}/tail\d+", model.joint(joint).name):
            data.qpos[model.jnt_qposadr[joint]] = math.radians(lift_deg)
    (event,) = setup.events(model)
    data.time = event.plan.time
    event(model, data)
    assert not touches_the_animal_at_launch(model, data, model.body(event.plan.body).id)


def test_random_throws_are_seeded_and_within_their_ranges(tmp_path: Path) -> None:
    first, _, _ = build("robustness")
    again, _, _ = build("robustness")
    dog = first.placements[0].built.animal
    plans = first.throws
    assert len(plans) == 20
    assert [(p.time, p.mass, p.speed, tuple(p.direction)) for p in plans] == [
        (p.time, p.mass, p.speed, tuple(p.direction)) for p in again.throws
    ]
    assert [p.time for p in plans] == pytest.approx([2.0 + 2.0 * k for k in range(20)])
    masses = np.array([p.mass for p in plans]) / dog.mass_kg
    speeds = np.array([p.speed for p in plans]) / math.sqrt(STANDARD_GRAVITY * dog.pelvis_height)
    assert masses.min() >= 0.05 and masses.max() <= 0.15 and masses.std() > 0.01
    assert speeds.min() ** 2 >= 1.4 - 1e-9 and speeds.max() ** 2 <= 3.9 + 1e-9
    assert len({tuple(p.direction) for p in plans}) == 4
    text = (SHIPPED / "robustness.yaml").read_text().replace("seed: 1", "seed: 2")
    other, _, _ = build(write_scene(tmp_path, text.split("name: robustness\n", 1)[1]))
    assert [p.mass for p in other.throws] != [p.mass for p in plans]


def test_a_throw_too_slow_for_its_distance_is_an_error_at_its_speed(tmp_path: Path) -> None:
    line = "  - {at: 1 s, shape: sphere, size: [0.1 HP], mass: 0.1 bm, speed: 1 m/s, distance: 3 HP}"
    path = write_scene(tmp_path, f"throws:\n{line}\n")
    with pytest.raises(QuadpipeError) as caught:
        build_scene(load_scene(path), built_animal("dog"))
    assert str(caught.value) == (
        f"{path}:4:{line.index('1 m/s') + 1}: error throw-out-of-reach: throws.0.speed: "
        "at 1 m/s a throw reaches at most 0.102 m from this direction, not 1.97 m\n"
        "  hint: throw faster, or from closer (`distance`)"
    )


def test_flight_time_hits_the_point_at_the_speed() -> None:
    for up in (-0.5, 0.0, 0.5):
        direction = np.array([math.sqrt(1 - up**2), 0.0, up])
        flight = flight_time(5.0, 1.5, up, 9.81)
        launch = -1.5 * direction / flight + np.array([0, 0, 9.81 * flight / 2])
        landing = 1.5 * direction + launch * flight + np.array([0, 0, -9.81 / 2]) * flight**2
        assert landing == pytest.approx([0, 0, 0], abs=1e-12)
        assert np.linalg.norm(launch + np.array([0, 0, -9.81]) * flight) == pytest.approx(5.0)
    assert flight_time(1.0, 1.0, 0.0, 9.81) is None


def test_a_prop_starts_where_and_how_fast_it_is_told(tmp_path: Path) -> None:
    path = write_scene(
        tmp_path,
        "props:\n  - {name: ball, type: sphere, at: [3 HP, 0, 0.3 HP], size: [0.3 HP], mass: 0.05 bm, velocity: [-1 m/s, 0, 0]}\n",
    )
    setup, model, data = build(path)
    dog = setup.placements[0].built.animal
    assert model.body("ball").pos == pytest.approx([3 * dog.pelvis_height, 0, 0.3 * dog.pelvis_height])
    assert model.body_mass[model.body("ball").id] == pytest.approx(0.05 * dog.mass_kg)
    for event in setup.events(model):
        event(model, data)
    mujoco.mj_step(model, data)
    assert data.qvel[model.jnt_dofadr[model.body("ball").jntadr[0]]] == pytest.approx(-1.0, abs=0.01)


# --------------------------------------------------------------------------- goals


def test_a_goal_path_is_a_piecewise_linear_expression_in_t(tmp_path: Path) -> None:
    path = write_scene(
        tmp_path,
        "goals:\n  goal: [20 HP, 0, 0]\n  target: {path: [[2 s, [5 HP, 0, 0]], [12 s, [5 HP, 5 HP, 0]], [22 s, [0, 5 HP, 1 HP]]]}\n",
    )
    setup, _, _ = build(path)
    hp = setup.placements[0].built.animal.pelvis_height
    scale = Scale.of([1.0, 2.0], [1.0, 1.0])
    goal = compile_quantity(setup.goal_parameters["goal"], scale, POINT)
    assert goal.constant == pytest.approx(np.array([[20 * hp, 0, 0]] * 2))
    target = compile_quantity(setup.goal_parameters["target"], scale, POINT)
    expected = {0.0: [5, 0, 0], 2.0: [5, 0, 0], 7.0: [5, 2.5, 0], 12.0: [5, 5, 0], 17.0: [2.5, 5, 0.5], 30.0: [0, 5, 1]}
    for t, point in expected.items():
        assert target({"t": np.array([t, t])}) == pytest.approx(np.array([point, point]) * hp), t


def test_goal_path_times_must_increase(tmp_path: Path) -> None:
    path = write_scene(tmp_path, "goals:\n  goal: {path: [[2 s, [5 HP, 0, 0]], [1 s, [6 HP, 0, 0]]]}\n")
    with pytest.raises(QuadpipeError, match="goals.goal.path.1.0: the path's times must increase"):
        build_scene(load_scene(path), built_animal("dog"))


# --------------------------------------------------------------------------- errors


@pytest.fixture
def here(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """Work in a temporary folder, so error messages name files relatively."""
    monkeypatch.chdir(tmp_path)
    return tmp_path


def test_an_unknown_key_is_located_with_a_did_you_mean(here: Path) -> None:
    write_scene(here, "terrain:\n  - {type: hill, start: 4 HP, angel: 10 deg, height: 0.5 HP}\n")
    assert error_text(Path("scene.yaml")) == (
        "scene.yaml:4:31: error unknown-key: 'angel' is not a valid key here\n"
        "  hint: did you mean 'angle'? (valid: angle, height, start, top, type, width)"
    )


def test_a_wrong_unit_is_located_at_the_value(here: Path) -> None:
    write_scene(here, "terrain:\n  - {type: slope, start: 4 HP, angle: 10 m, length: 6 HP}\n")
    assert error_text(Path("scene.yaml")) == (
        "scene.yaml:4:39: error wrong-dimension: terrain.0.angle: expected an angle, got a length\n"
        "  hint: for example `10 deg`"
    )


def test_an_unknown_terrain_type_lists_the_valid_ones(here: Path) -> None:
    write_scene(here, "terrain:\n  - {type: hil, start: 4 HP}\n")
    assert error_text(Path("scene.yaml")) == (
        "scene.yaml:4:12: error unknown-terrain-type: there is no terrain type 'hil'\n"
        "  hint: did you mean 'hill'? (valid: box, hill, mesh, slope, stairs)"
    )


def test_an_unknown_scene_name_lists_the_valid_ones() -> None:
    with pytest.raises(QuadpipeError) as caught:
        load_scene("hil")
    assert str(caught.value) == (
        f"error unknown-scene: there is no scene named 'hil'\n  hint: did you mean 'hill'? (valid: {', '.join(SCENES)})"
    )


def test_every_problem_is_reported_at_once_in_file_order(here: Path) -> None:
    write_scene(
        here,
        "throws:\n  - {at: 3 s, shape: box, size: [1 HP, 1 HP, 1 HP], mass: 1 HP, speed: 4 m/s, target: pelvs, animal: 3}\n"
        "goals:\n  goal: {path: [[0 s, [1 HP, 0, 0]], [t, [2 HP, 0, 0]]]}\n"
        "animals:\n  - {name: a, species: dgo}\n  - {name: a, heading: 3}\n",
    )
    lines = [line for line in error_text(Path("scene.yaml")).splitlines() if not line.startswith("  hint")]
    assert lines == [
        "scene.yaml:4:59: error wrong-dimension: throws.0.mass: expected a mass, got a length",
        "scene.yaml:4:87: error unknown-role: throws.0.target: 'pelvs' is not a role",
        "scene.yaml:4:102: error unknown-animal-ref: there is no animal 3 in this scene",
        "scene.yaml:6:39: error not-constant: goals.goal.path.1.0: a scene value must be fixed, but 't' reads the simulation",
        "scene.yaml:8:24: error unknown-animal: there is no animal named 'dgo'",
        "scene.yaml:9:12: error duplicate-name: the name 'a' is used twice",
        "scene.yaml:9:24: error wrong-dimension: animals.1.heading: expected an angle, got a number",
    ]


@pytest.mark.parametrize(
    ("item", "value", "message"),
    [
        (
            "terrain:\n  - {type: hill, start: 4 HP, angle: 70 deg, height: 1 HP}",
            "70 deg",
            "error out-of-range: terrain.0.angle: '70 deg' must be at most 60 deg",
        ),
        (
            "terrain:\n  - {type: hill, start: 4 HP, angle: 10 deg, height: -1 HP}",
            "-1 HP",
            "error out-of-range: terrain.0.height: '-1 HP' must be more than 0",
        ),
        (
            "props:\n  - {name: b, type: box, at: [0, 0, 1 HP], size: [1 HP], mass: 1 kg}",
            "[1 HP]",
            "error invalid-value: props.0.size: a box has 3 size item(s): length (x), width (y), height (z); got 1",
        ),
        (
            "props:\n  - {name: floor, type: sphere, at: [0, 0, 1 HP], size: [1 HP], mass: 1 kg}",
            "floor",
            "error reserved-name: the name 'floor' is taken by the scene itself",
        ),
        ("animals: []", "[]", "error invalid-value: animals: the list is empty"),
        (
            "goals:\n  goal: [1 HP, 2 deg, 0]",
            "[1 HP",
            "error dimension-mismatch: goals.goal: vector components mix units in \"['1 HP', '2 deg', 0]\"",
        ),
    ],
)
def test_bad_values_are_located_at_the_value(here: Path, item: str, value: str, message: str) -> None:
    write_scene(here, item + "\n")
    with pytest.raises(QuadpipeError) as caught:
        build_scene(load_scene("scene.yaml"), built_animal("dog"))
    last = item.splitlines()[-1]
    line = 3 + item.count("\n")
    assert str(caught.value).splitlines()[0] == f"scene.yaml:{line}:{last.index(value) + 1}: {message}"


def test_an_unsupported_schema_version_is_refused(here: Path) -> None:
    (here / "scene.yaml").write_text("schema: 2\nname: test\n", encoding="utf-8")
    assert error_text(Path("scene.yaml")) == (
        "scene.yaml:1:9: error unsupported-schema: schema version 2 is not supported\n  hint: this quadpipe reads `schema: 1`"
    )


def test_write_schema_writes_the_current_schema(tmp_path: Path) -> None:
    written = write_schema(tmp_path)
    assert written == tmp_path / SCHEMA_PATH
    assert json.loads(written.read_text()) == scene_json_schema()
