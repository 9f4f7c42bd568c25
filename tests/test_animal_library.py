"""The shipped animal library: every config loads into a sound standing skeleton, and each
species keeps the proportions that make it that species (checks a scaled dog would fail).

Geometry is read in quadpipe's body frame: metres, +X forward, +Y left, +Z up.
"""

from __future__ import annotations

import functools
import importlib.util
import math
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from quadpipe.anatomy.roles import FRONT_CHAIN, HIND_CHAIN, LEGS, NECK, ROLES, SPINE, TAIL
from quadpipe.anatomy.skeleton import Bone, Skeleton
from quadpipe.animals.library import Animal, load_animal
from quadpipe.core import configs

REPO = Path(__file__).resolve().parent.parent
GENERATOR = REPO / "tools" / "make_skeletons.py"

ANIMALS = configs.available("animals")

HP_TOLERANCE = 0.01
"""Pelvis height and foot heights must match to 1 % of HP."""

MIN_BONE_RADII = 1.2
"""No bone shorter than 1.2 bone radii."""

FOOT_UNDER_BODY_HP = 0.3
"""A foot's middle lies within 0.3 HP (fore-aft) of its shoulder or hip joint."""

MIRROR_TOLERANCE_M = 1e-4
"""Right legs mirror left ones to rounding (0.1 mm)."""

FIG7_TOLERANCE = 0.10
"""The dog's part lengths follow the thesis's Fig. 7 part masses to within 10 %."""

FIG7_PART_MASSES = {"tail": 186.0, "spine": 106.0, "neck": 106.0, "front leg": 266.0, "rear leg": 231.0}
FIG7_PARTS = {
    "tail": TAIL,
    "spine": SPINE,
    "neck": NECK,
    "front leg": tuple(f"lf_{bone}" for bone in FRONT_CHAIN),
    "rear leg": tuple(f"lh_{bone}" for bone in HIND_CHAIN),
}
AXIAL_TO_NOSE = ("pelvis", *SPINE, "thorax", *NECK, "head")


@functools.cache
def animal(name: str) -> Animal:
    """A library animal, loaded once per session."""
    return load_animal(name)


def bone(name: str, role: str):
    """One bone of a library animal."""
    return animal(name).skeleton[role]


def hp(name: str) -> float:
    """The animal's HP in metres."""
    return animal(name).pelvis_height


def chain_length(name: str, roles: tuple[str, ...]) -> float:
    """Summed length of some bones, in metres."""
    return sum(bone(name, role).length for role in roles)


def hind_chain(name: str) -> float:
    """The left hind leg's summed bone length, in metres."""
    return chain_length(name, tuple(f"lh_{kind}" for kind in HIND_CHAIN))


def front_chain(name: str) -> float:
    """The left front leg's summed bone length, in metres."""
    return chain_length(name, tuple(f"lf_{kind}" for kind in FRONT_CHAIN))


def from_vertical_deg(name: str, role: str) -> float:
    """Angle between a bone and the vertical, in degrees."""
    return math.degrees(math.acos(min(1.0, abs(float(bone(name, role).direction[2])))))


def height_hp(name: str, role: str) -> float:
    """Height of a bone's proximal joint, in HP."""
    return float(bone(name, role).start[2]) / hp(name)


def bone_ratio(name: str, role: str, other: str) -> float:
    """Length of one bone over another's."""
    return bone(name, role).length / bone(name, other).length


def test_library_holds_the_thesis_animals():
    assert set(ANIMALS) >= {"elephant", "cow", "horse", "bear", "lion", "dog", "goat", "pig", "cat", "rat"}


@pytest.mark.parametrize("name", ANIMALS)
def test_loads_cleanly_with_every_role(name):
    loaded = animal(name)
    assert loaded.warnings == ()
    assert tuple(loaded.skeleton.bones) == ROLES


@pytest.mark.parametrize("name", ANIMALS)
def test_pelvis_stands_at_the_configured_height(name):
    loaded = animal(name)
    assert abs(loaded.skeleton.pelvis_height - loaded.pelvis_height) <= HP_TOLERANCE * loaded.pelvis_height
    assert abs(float(bone(name, "pelvis").start[2]) - loaded.pelvis_height) <= HP_TOLERANCE * loaded.pelvis_height


@pytest.mark.parametrize("name", ANIMALS)
def test_all_four_feet_touch_the_ground_and_nothing_is_below_it(name):
    bones = animal(name).skeleton.bones
    for leg in LEGS:
        toe = FRONT_CHAIN[-1] if leg.endswith("f") else HIND_CHAIN[-1]
        assert abs(float(bones[f"{leg}_{toe}"].end[2])) <= HP_TOLERANCE * hp(name), leg
    lowest = min(min(b.start[2], b.end[2]) for b in bones.values())
    assert lowest >= -HP_TOLERANCE * hp(name)


@pytest.mark.parametrize("name", ANIMALS)
def test_left_legs_on_the_left_mirrored_by_the_right(name):
    for kind in FRONT_CHAIN + HIND_CHAIN:
        side = "f" if kind in FRONT_CHAIN else "h"
        left, right = bone(name, f"l{side}_{kind}"), bone(name, f"r{side}_{kind}")
        assert left.start[1] > 0 and left.end[1] > 0
        mirror = np.array([1.0, -1.0, 1.0])
        assert np.allclose(right.start, left.start * mirror, atol=MIRROR_TOLERANCE_M)
        assert np.allclose(right.end, left.end * mirror, atol=MIRROR_TOLERANCE_M)


@pytest.mark.parametrize("name", ANIMALS)
def test_bones_are_longer_than_their_capsule_radius(name):
    radius = hp(name) / 75.0 + 0.001
    short = {role: b.length for role, b in animal(name).skeleton.bones.items() if b.length < MIN_BONE_RADII * radius}
    assert short == {}


@pytest.mark.parametrize("name", ANIMALS)
def test_feet_stand_under_shoulders_and_hips(name):
    for leg, top, foot in (("lf", "shoulder", ("wrist", "fpha1")), ("lh", "hip", ("ankle", "hpha2"))):
        middle = (bone(name, f"{leg}_{foot[0]}").start + bone(name, f"{leg}_{foot[1]}").end) / 2.0
        offset = float(middle[0] - bone(name, f"{leg}_{top}").start[0])
        assert abs(offset) <= FOOT_UNDER_BODY_HP * hp(name), leg


@pytest.mark.parametrize("name", ANIMALS)
def test_every_joint_turns_about_the_lateral_axis(name):
    for role, b in animal(name).skeleton.bones.items():
        assert np.allclose(b.axis, [0.0, 1.0, 0.0]), role


# --- Species: each check fails for a dog scaled to the species' HP -------------------------


def check_elephant() -> None:
    """Columnar legs: upper and lower leg segments near vertical; short feet."""
    for role in ("lf_shoulder", "lf_elbow", "lh_hip", "lh_knee"):
        assert from_vertical_deg("elephant", role) <= 15.0, role
    foot = chain_length("elephant", ("lf_wrist", "lf_fpha0", "lf_fpha1"))
    assert foot <= 0.16 * front_chain("elephant")


def check_horse() -> None:
    """Long legs and metapodials, unguligrade with the fetlock off the ground."""
    assert hind_chain("horse") / hp("horse") > 1.05 * hind_chain("pig") / hp("pig")
    assert bone_ratio("horse", "lf_wrist", "lf_elbow") >= 0.6
    assert bone_ratio("horse", "lh_ankle", "lh_knee") >= 0.65
    assert height_hp("horse", "lf_fpha0") >= 0.1 and height_hp("horse", "lh_hpha0") >= 0.1


def check_cow() -> None:
    """An ungulate like the horse but wider-bodied; fetlocks raised."""
    cow_width = float(bone("cow", "lh_hip").start[1]) / hp("cow")
    assert cow_width >= 1.2 * float(bone("horse", "lh_hip").start[1]) / hp("horse")
    assert bone_ratio("cow", "lf_wrist", "lf_elbow") >= 0.6
    assert height_hp("cow", "lf_fpha0") >= 0.08 and height_hp("cow", "lh_hpha0") >= 0.08


def check_goat() -> None:
    """A small ungulate: long cannons, raised fetlocks, tail carried up."""
    assert bone_ratio("goat", "lf_wrist", "lf_elbow") >= 0.6
    assert height_hp("goat", "lf_fpha0") >= 0.08 and height_hp("goat", "lh_hpha0") >= 0.08
    assert bone("goat", "tail3").end[2] > bone("goat", "tail0").start[2]


def check_pig() -> None:
    """Short legs under a long trunk."""
    trunk = float(bone("pig", "neck0").start[0] - bone("pig", "pelvis").start[0])
    assert trunk / hp("pig") >= 1.2
    assert hind_chain("pig") / hp("pig") <= 0.95


def check_bear() -> None:
    """Plantigrade: hind metatarsus near horizontal, heel low."""
    assert from_vertical_deg("bear", "lh_ankle") >= 90.0 - 25.0
    assert height_hp("bear", "lh_ankle") <= 0.1


def check_felid(name: str) -> None:
    """Digitigrade cats: short metatarsus against the tibia (a canid's is longer)."""
    assert bone_ratio(name, "lh_ankle", "lh_knee") <= 0.5
    assert height_hp(name, "lh_ankle") >= 0.15


def check_cat() -> None:
    """Felid feet, and a hind leg much longer than the fore leg below the shoulder."""
    check_felid("cat")
    fore = chain_length("cat", ("lf_shoulder", "lf_elbow", "lf_wrist"))
    hind = chain_length("cat", ("lh_hip", "lh_knee", "lh_ankle"))
    assert hind >= 1.25 * fore


def check_rat() -> None:
    """Crouched, with a tail about as long as head and body."""
    assert chain_length("rat", TAIL) >= 0.8 * chain_length("rat", AXIAL_TO_NOSE)
    assert height_hp("rat", "lh_hip") <= 0.6 * hind_chain("rat") / hp("rat")


def check_dog() -> None:
    """The thesis's Fig. 7: capsule parts' (sum L + n 4/3 r) in proportion to their masses."""
    radius = hp("dog") / 75.0 + 0.001
    amounts = {
        part: sum(bone("dog", r).length + 4.0 / 3.0 * radius for r in roles) for part, roles in FIG7_PARTS.items()
    }
    total_amount, total_mass = sum(amounts.values()), sum(FIG7_PART_MASSES.values())
    for part, amount in amounts.items():
        ratio = (amount / total_amount) / (FIG7_PART_MASSES[part] / total_mass)
        assert abs(ratio - 1.0) <= FIG7_TOLERANCE, f"{part}: {ratio:.3f}"


SPECIES_CHECKS: dict[str, Callable[[], None]] = {
    "elephant": check_elephant,
    "horse": check_horse,
    "cow": check_cow,
    "goat": check_goat,
    "pig": check_pig,
    "bear": check_bear,
    "lion": lambda: check_felid("lion"),
    "cat": check_cat,
    "rat": check_rat,
    "dog": check_dog,
}


@pytest.mark.parametrize("name", sorted(SPECIES_CHECKS))
def test_species_proportions(name):
    assert name in ANIMALS
    SPECIES_CHECKS[name]()


def scaled_dog(name: str) -> Animal:
    """The dog's skeleton scaled to another animal's HP, posing as that animal."""
    dog, real = load_animal("dog"), load_animal(name)
    factor = real.pelvis_height / dog.pelvis_height
    bones = {
        role: Bone(role, b.name, b.start * factor, b.end * factor, b.axis) for role, b in dog.skeleton.bones.items()
    }
    return Animal(
        name, Skeleton(name, dog.skeleton.source, bones), dog.limits, real.pelvis_height, real.mass_kg, dog.source
    )


@pytest.mark.parametrize("name", sorted(set(SPECIES_CHECKS) - {"dog"}))
def test_species_check_rejects_a_scaled_dog(monkeypatch, name):
    impostor = scaled_dog(name)
    genuine = animal
    monkeypatch.setitem(globals(), "animal", lambda other: impostor if other == name else genuine(other))
    with pytest.raises(AssertionError):
        SPECIES_CHECKS[name]()


def test_generator_reproduces_the_shipped_skeletons(tmp_path, monkeypatch):
    spec = importlib.util.spec_from_file_location("make_skeletons", GENERATOR)
    generator = importlib.util.module_from_spec(spec)
    monkeypatch.setitem(sys.modules, spec.name, generator)
    spec.loader.exec_module(generator)
    written = generator.generate(output_dir=tmp_path)
    assert {path.stem for path in written} >= set(SPECIES_CHECKS)
    for path in written:
        shipped = REPO / "configs" / "skeletons" / path.name
        assert path.read_bytes() == shipped.read_bytes(), f"{path.name}: run tools/make_skeletons.py"
