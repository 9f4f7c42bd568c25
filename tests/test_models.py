"""Contract tests over the animal registry: every animal builds, weighs, and settles.

Driven by `configs.available("animals")`, so a new animal file is tested without editing
this file (as dm_control's suite_test does).
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from quadpipe.anatomy import roles
from quadpipe.animals import sizing
from quadpipe.animals.model import box_extent, clamped_radii
from quadpipe.core import configs
from quadpipe.sim import health as physics
from quadpipe.world.placement import Placement, build_world
from tests.conftest import built_animal

ANIMALS = configs.available("animals")

SETTLE_SECONDS = 5.0
MAX_PENETRATION_RADII = 0.10
MAX_LIMIT_OVERSHOOT_RAD = 0.05
SETTLED_WINDOW_S = 0.5
SETTLED_KINETIC_ENERGY = 1e-3
"""Settled: kinetic energy below this fraction of m*g*HP throughout the last half second."""

THESIS_FIG7_DOG = {
    "tail": 186,
    "pelvis": 1311,
    "spine": 106,
    "thorax": 656,
    "neck": 106,
    "head": 280,
    "front leg": 266,
    "rear leg": 231,
}
FIG7_PARTS = {
    "tail": roles.TAIL,
    "pelvis": ("pelvis",),
    "spine": roles.SPINE,
    "thorax": ("thorax",),
    "neck": roles.NECK,
    "head": ("head",),
    "front leg": tuple(f"lf_{b}" for b in roles.FRONT_CHAIN),
    "rear leg": tuple(f"lh_{b}" for b in roles.HIND_CHAIN),
}


def test_the_library_has_the_ten_thesis_animals():
    assert set(ANIMALS) >= {"elephant", "cow", "horse", "bear", "lion", "dog", "goat", "pig", "cat", "rat"}


@pytest.mark.parametrize("name", ANIMALS)
def test_compiles_with_every_role_and_no_warning(name):
    built = built_animal(name)
    with physics.mujoco_warnings() as warnings:
        model = built.spec.copy().compile()
    assert warnings == []
    bodies = {model.body(i).name for i in range(1, model.nbody)}
    assert bodies == set(roles.ROLES)
    assert math.isclose(model.body_subtreemass[0], built.animal.mass_kg, rel_tol=1e-9)
    assert model.ngeom == 39 - 1 + 5  # one geom per bone, five for the head


@pytest.mark.parametrize("name", ANIMALS)
def test_capsules_respect_the_radius_rule(name):
    built = built_animal(name)
    bones = built.animal.skeleton.bones
    rule = built.animal.pelvis_height / 75 + 0.001
    assert built.radius == pytest.approx(rule)
    model = built.spec.copy().compile()
    for role in roles.ROLES:
        if role in roles.BOX_BONES or role == roles.HEAD_BONE:
            continue
        neighbours = [role] + list(roles.CHILDREN[role]) + ([roles.PARENT[role]] if roles.PARENT[role] else [])
        radius = model.geom(role).size[0]
        assert radius <= rule + 1e-12
        assert all(radius <= bones[n].length + 1e-12 for n in neighbours), role
        assert radius == pytest.approx(min([rule] + [bones[n].length for n in neighbours]))


@pytest.mark.parametrize("name", ANIMALS)
def test_joints_follow_the_limits_table_through_default_classes(name):
    built = built_animal(name)
    model = built.spec.copy().compile()
    for role, limit in built.animal.limits.items():
        twist = model.joint(role)
        assert tuple(twist.range) == pytest.approx((limit.twist_min, limit.twist_max))
        assert built.spec.joint(role).classname.name == roles.kind_of(role)
        for suffix, swing in (("_swing1", limit.swing1), ("_swing2", limit.swing2)):
            present = any(model.joint(i).name == role + suffix for i in range(model.njnt))
            assert present == (swing > 0), role + suffix
            if present:
                assert tuple(model.joint(role + suffix).range) == pytest.approx((-swing, swing))


def test_dog_part_masses_keep_the_thesis_fig7_proportions():
    masses = built_animal("dog").masses
    pelvis = masses["pelvis"]
    for part, members in FIG7_PARTS.items():
        ours = sum(masses[m] for m in members) / pelvis
        thesis = THESIS_FIG7_DOG[part] / THESIS_FIG7_DOG["pelvis"]
        assert ours == pytest.approx(thesis, rel=0.10), part


@pytest.mark.parametrize("name", ANIMALS)
def test_boxes_enclose_their_joints(name):
    bones = built_animal(name).animal.skeleton.bones
    for role in roles.BOX_BONES:
        centre, half = box_extent(bones[role], bones, built_animal(name).radius)
        for child in roles.CHILDREN[role]:
            assert np.all(np.abs(bones[child].start - centre) <= half + 1e-12)


def test_clamped_radius_never_exceeds_a_neighbour():
    bones = built_animal("rat").animal.skeleton.bones
    radii = clamped_radii(bones, radius=1.0)  # an absurd radius: every bone gets clamped
    for role, radius in radii.items():
        assert radius == min(
            [bones[role].length]
            + [bones[n].length for n in roles.CHILDREN[role]]
            + ([bones[roles.PARENT[role]].length] if roles.PARENT[role] else [])
        )


@pytest.mark.parametrize(
    ("hp", "steps", "tau"),
    [(0.6556, 4, 0.00517), (0.0254, 17, 0.00102), (0.2793, 5, 0.00337), (2.9982, 2, 0.01106)],
)
def test_size_rules(hp, steps, tau):
    assert sizing.substeps(hp) == steps
    assert sizing.constraint_time_constant(hp) == pytest.approx(tau, rel=0.01)
    assert sizing.constraint_time_constant(hp) >= 2 * sizing.timestep(hp)


def test_joint_limits_keep_the_thesis_softness_and_are_softer_than_the_contact():
    """The dog's joint limits at MuJoCo's default 0.02 s (the thesis-era softness), the stiff contact four times quicker."""
    hp = 0.6556
    assert sizing.joint_limit_time_constant(hp) == pytest.approx(0.0204, rel=0.01)
    assert sizing.joint_limit_time_constant(hp) > 3 * sizing.constraint_time_constant(hp)


def test_the_animal_model_has_no_floor_and_the_world_adds_one():
    built = built_animal("dog")
    animal_model = built.spec.copy().compile()
    assert all(animal_model.geom(i).type != mujoco.mjtGeom.mjGEOM_PLANE for i in range(animal_model.ngeom))
    world = build_world([Placement("dog", built)]).compile()
    assert world.geom("floor").type == mujoco.mjtGeom.mjGEOM_PLANE
    assert world.body("dog/pelvis").id > 0


@pytest.mark.parametrize("name", ANIMALS)
def test_dropped_from_rest_it_settles_cleanly(name):
    built = built_animal(name)
    scale = built.animal.mass_kg * sizing.GRAVITY * built.animal.pelvis_height
    with physics.mujoco_warnings() as warnings:
        model = build_world([Placement(name, built)]).compile()
        model.opt.enableflags |= mujoco.mjtEnableBit.mjENBL_ENERGY
        data = mujoco.MjData(model)
        steps = round(SETTLE_SECONDS / model.opt.timestep)
        window = round(SETTLED_WINDOW_S / model.opt.timestep)
        late_energy = []
        for step in range(steps):
            mujoco.mj_step(model, data)
            if step >= steps - window:
                mujoco.mj_energyVel(model, data)
                late_energy.append(data.energy[1] / scale)
    assert warnings == [] and physics.warning_counts(data) == {}
    assert physics.is_finite(data)
    assert data.qpos[2] < 0.9 * built.animal.pelvis_height  # a ragdoll: it really fell
    assert max(late_energy) < SETTLED_KINETIC_ENERGY
    assert physics.max_penetration(model, data) < MAX_PENETRATION_RADII * built.radius
    assert physics.max_limit_overshoot(model, data) < MAX_LIMIT_OVERSHOOT_RAD


def test_same_animal_builds_the_same_model_twice():
    from quadpipe.animals.library import load_animal
    from quadpipe.animals.model import build_animal

    first = build_animal(load_animal("dog")).spec.copy()
    second = build_animal(load_animal("dog")).spec.copy()
    first.compile(), second.compile()
    assert first.to_xml() == second.to_xml()
