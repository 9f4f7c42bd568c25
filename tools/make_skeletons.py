"""Generate the shipped skeletons, `configs/skeletons/<animal>.xml`, from per-species tables.

Run from the repository root:

    .venv/bin/python tools/make_skeletons.py            # rewrite all ten files
    .venv/bin/python tools/make_skeletons.py dog horse  # only these

Each species is a table of bone lengths, in units of its pelvis height HP (the thesis's Fig. 6
values, read as centimetres), and of bone directions in the sagittal plane:

- axial bones (pelvis, spine, thorax, neck, head) point forward, tilted by `pitch` degrees above
  the horizontal; tail bones point backward, tilted by `pitch` degrees above the horizontal;
- leg bones hang from the hip or the scapula's dorsal end, each leaning `lean` degrees from the
  vertical, positive with the far end forward (toward the head).

The pelvis joint sits at height HP exactly. Each leg is then scaled as a whole, keeping its
angles, so that the tip of its last phalanx touches the ground (height 0); the scale is printed
and stays close to 1 when the table is sound. Left legs are at +x, right legs mirror them.

Output: quadpipe's skeleton XML (docs/formats.md): centimetres, y up, z forward, x to the
animal's left; every joint's main axis is the lateral axis "1 0 0". Numbers are rounded to
0.01 cm (0.001 cm for animals under 10 cm), so the files are the same on every run.
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass
from pathlib import Path

from quadpipe.anatomy import roles

REPO = Path(__file__).resolve().parent.parent
OUTPUT_DIR = REPO / "configs" / "skeletons"

LATERAL_AXIS = "1 0 0"
"""Every joint's main (twist) axis: the animal's left-right axis, pointing left."""

DECIMALS = 2
SMALL_DECIMALS = 3
SMALL_ANIMAL_HP_CM = 10.0
"""Coordinates are rounded to 0.01 cm, or to 0.001 cm for animals lower than 10 cm."""

RADIUS_PER_HP = 1.0 / 75.0
RADIUS_OFFSET_CM = 0.1
"""The thesis's bone radius in cm: HP / 75 + 0.1."""

DOG_FIG7_PART_MASSES = {"tail": 186.0, "spine": 106.0, "neck": 106.0, "front leg": 266.0, "rear leg": 231.0}
"""The thesis's Fig. 7: masses of the dog's capsule parts (arbitrary units)."""

DOG_PART_BONES = {
    "tail": roles.TAIL,
    "spine": roles.SPINE,
    "neck": roles.NECK,
    "front leg": tuple(f"lf_{bone}" for bone in roles.FRONT_CHAIN),
    "rear leg": tuple(f"lh_{bone}" for bone in roles.HIND_CHAIN),
}
"""The bones of each Fig. 7 part (one leg of each pair)."""


@dataclass(frozen=True)
class Seg:
    """One bone of a chain: length (fraction of HP) and angle in degrees (pitch or lean)."""

    length: float
    angle: float


@dataclass(frozen=True)
class Species:
    """The rest-pose table of one species. Lengths and offsets are fractions of HP.

    Attributes:
        name: file name and skeleton name.
        hp_cm: the thesis's pelvis height (Fig. 6).
        pelvis: pelvis joint to spine0 joint (the sacrum), forward with a pitch.
        spine: spine0..spine2, forward; spine2 ends at the thorax joint.
        thorax: thorax joint to neck0 joint (the thoracic vertebrae under the withers).
        neck: neck0..neck4 (neck0 starts at the cervicothoracic junction).
        head: skull, from the occiput to the nose tip.
        tail_root: tail0 joint from the pelvis joint: (backward, up).
        tail: tail0..tail3, backward, pitch above the horizontal.
        hip: hip (acetabulum) joint from the pelvis joint: (backward, down, lateral).
        hind: femur, tibia, metatarsus and three phalanges, leaning from the vertical.
        scapula: scapula's dorsal end from the thorax joint: (forward, up, lateral).
        shoulder_lateral: lateral offset of the shoulder joint and the rest of the front leg.
        front: scapula, humerus, forearm, metacarpus and two phalanges, leaning.
    """

    name: str
    hp_cm: float
    pelvis: Seg
    spine: tuple[Seg, Seg, Seg]
    thorax: Seg
    neck: tuple[Seg, Seg, Seg, Seg, Seg]
    head: Seg
    tail_root: tuple[float, float]
    tail: tuple[Seg, Seg, Seg, Seg]
    hip: tuple[float, float, float]
    hind: tuple[Seg, Seg, Seg, Seg, Seg, Seg]
    scapula: tuple[float, float, float]
    shoulder_lateral: float
    front: tuple[Seg, Seg, Seg, Seg, Seg, Seg]

    @property
    def radius_cm(self) -> float:
        """The thesis's bone radius for this animal."""
        return self.hp_cm * RADIUS_PER_HP + RADIUS_OFFSET_CM


def segs(*pairs: tuple[float, float]) -> tuple[Seg, ...]:
    """Build a chain from (length, angle) pairs."""
    return tuple(Seg(length, angle) for length, angle in pairs)


# --- The species tables -------------------------------------------------------------------
# Sagittal angles: axial `pitch` above the horizontal; leg `lean` from the vertical, + forward.

DOG = Species(
    # Large Labrador-like dog, digitigrade. Limb fractions: between the dm_control dog (Pharaoh
    # hound; forelimb scapula/humerus/radius/metacarpus 0.27/0.27/0.34/0.11, hindlimb
    # femur/tibia/metatarsus 0.33/0.44/0.23) and the Blender Rigify wolf metarig (0.21/0.28/
    # 0.28/0.14/0.09 and 0.31/0.34/0.24/0.11); scapula ~ humerus ~ femur, tibia longest.
    # Standing pose: scapula laid back ~40 deg from the vertical, elbow under the withers,
    # metapodials near vertical, toes on the ground; stifle 133 and hock 147 deg (a standing
    # dog's stifle is 135-145, mean 145 at mid-stance, its hock 145-163: Vet. Sci. 2022, 9:644;
    # docs/gaits.md, "Standing poses"; they were 112 and 130, then 135 and 135). The femur,
    # tibia and metatarsus are 0.93 of their first lengths, so that the straighter leg still
    # ends on the ground with the pelvis at HP.
    # Axial lengths (tail, spine, neck) follow the thesis's Fig. 7 part masses (see `report`).
    name="dog",
    hp_cm=65.56,
    pelvis=Seg(0.14, 0.0),
    spine=segs((0.165, 3.0), (0.165, 2.0), (0.165, 0.0)),
    thorax=Seg(0.28, -6.0),
    neck=segs((0.09, 40.0), (0.09, 45.0), (0.09, 48.0), (0.09, 50.0), (0.09, 50.0)),
    head=Seg(0.36, -35.0),
    tail_root=(0.05, 0.01),
    tail=segs((0.23, -20.0), (0.23, -40.0), (0.23, -55.0), (0.21, -65.0)),
    hip=(0.04, 0.08, 0.11),
    hind=segs((0.328, 21.0), (0.375, -26.0), (0.225, 7.0), (0.055, 50.0), (0.045, 65.0), (0.04, 80.0)),
    scapula=(0.16, 0.02, 0.06),
    shoulder_lateral=0.11,
    front=segs((0.312, 38.0), (0.332, -50.0), (0.372, -2.0), (0.161, 15.0), (0.06, 55.0), (0.05, 75.0)),
)

ELEPHANT = Species(
    # African bush elephant, a large adult (shoulder ~3.2 m). Graviportal, "columnar" limbs:
    # Ren et al. 2008 (J. Exp. Biol. 211:2735, 15 elephants) measured at mid-stance forearm,
    # forefoot and thigh within 4-11 deg of the vertical, upper arm ~19, shank ~23, hind foot
    # ~38 deg; standing still they are straighter still. Long femur and humerus, short forearm
    # and shank, short feet on a fat pad: metapodials steep, phalanges stubby (Hutchinson et
    # al. 2011, "From flat foot to fat foot", Science 334:1699). Long upright scapula, very
    # short neck, big skull, tail about 1-1.3 m. The fore leg stands as a column: forearm 3 deg
    # forward, metacarpus 11 deg (25 before session 15; the toe tip 1.1 cm behind where it was).
    name="elephant",
    hp_cm=299.82,
    pelvis=Seg(0.15, 5.0),
    spine=segs((0.14, 8.0), (0.14, 6.0), (0.14, 4.0)),
    thorax=Seg(0.30, -4.0),
    neck=segs((0.04, 10.0), (0.04, 10.0), (0.04, 5.0), (0.04, 0.0), (0.04, -5.0)),
    head=Seg(0.33, -45.0),
    tail_root=(0.06, 0.0),
    tail=segs((0.11, -55.0), (0.11, -75.0), (0.10, -85.0), (0.09, -88.0)),
    hip=(0.05, 0.11, 0.14),
    hind=segs((0.493, 6.0), (0.309, -10.0), (0.08, 40.0), (0.04, 60.0), (0.029, 70.0), (0.023, 80.0)),
    scapula=(0.14, 0.06, 0.10),
    shoulder_lateral=0.15,
    front=segs((0.332, 20.0), (0.388, -12.0), (0.31, 3.0), (0.083, 11.0), (0.044, 50.0), (0.033, 70.0)),
)

COW = Species(
    # Holstein cow (hip height ~145-150 cm). Approximate bovine bone lengths from veterinary
    # osteology (Nickel, Schummer & Seiferle, "The Anatomy of the Domestic Animals", vol. 1):
    # scapula ~42 cm, humerus ~30, radius ~30, cannon ~22, P1 6.5, P2+P3 ~11; femur ~42,
    # tibia ~40, cannon ~25. Unguligrade on two claws, pasterns more sloped than the horse's, a straight
    # ("post-legged") hock. Heavier body than the horse: wider hips and shoulders, long pelvis,
    # short neck carried low, a tail reaching the hock.
    name="cow",
    hp_cm=144.17,
    pelvis=Seg(0.24, 2.0),
    spine=segs((0.17, 1.0), (0.17, 0.0), (0.17, 0.0)),
    thorax=Seg(0.32, -8.0),
    neck=segs((0.08, 20.0), (0.08, 20.0), (0.08, 20.0), (0.08, 15.0), (0.08, 10.0)),
    head=Seg(0.34, -55.0),
    tail_root=(0.12, 0.02),
    tail=segs((0.18, -60.0), (0.17, -80.0), (0.16, -88.0), (0.15, -90.0)),
    hip=(0.08, 0.16, 0.14),
    hind=segs((0.312, 25.0), (0.302, -22.0), (0.187, 3.0), (0.049, 40.0), (0.037, 45.0), (0.047, 55.0)),
    scapula=(0.12, 0.05, 0.08),
    shoulder_lateral=0.14,
    front=segs((0.365, 35.0), (0.268, -40.0), (0.268, 0.0), (0.195, 0.0), (0.061, 45.0), (0.091, 55.0)),
)

HORSE = Species(
    # Light riding horse (withers ~155 cm). Approximate equine bone lengths (Sisson & Grossman,
    # "The Anatomy of the Domestic Animals"; Wikipedia, "Limbs of the horse"): scapula ~40 cm,
    # humerus ~30, radius ~34, third metacarpal (cannon) ~23, long pastern P1 ~9, short
    # pastern + coffin ~9; femur ~42, tibia ~37, third metatarsal ~28 (hind cannon longer).
    # Standing angles: shoulder joint 120-130 deg (Adams and Stashak's Lameness in Horses, 7th
    # ed., p. 29), forearm and cannons vertical, pastern and hoof wall ~50-55 deg to the ground.
    # The 45-55 deg "shoulder slope" of conformation is the line from the withers to the point
    # of the shoulder, not the scapula's axis (docs/kinematics_references.md): the scapula
    # leans 38 deg from the vertical (52 to the horizontal), the humerus 17 deg back, for a
    # shoulder of 125 deg (they were 42 and 35, 103 deg). The scapula's top, the elbow and all
    # below it stay where they were (hoof, rest length and withers kept), the scapula and the
    # humerus re-lengthened to meet (0.342, 0.258 -> 0.261, 0.272: a scapula of 37 cm). Joint
    # limits are angles from the rest pose, so the horse's scapula and shoulder limits are set
    # for this pose (configs/limits/horse.tsv). The fetlock stands well off the ground
    # (unguligrade); long neck, long head carried steeply.
    name="horse",
    hp_cm=140.69,
    pelvis=Seg(0.20, 3.0),
    spine=segs((0.16, 2.0), (0.16, 1.0), (0.16, 0.0)),
    thorax=Seg(0.30, -10.0),
    neck=segs((0.11, 40.0), (0.11, 45.0), (0.11, 50.0), (0.11, 55.0), (0.10, 55.0)),
    head=Seg(0.42, -65.0),
    tail_root=(0.09, 0.02),
    tail=segs((0.10, -30.0), (0.09, -60.0), (0.08, -75.0), (0.08, -85.0)),
    hip=(0.08, 0.17, 0.10),
    hind=segs((0.315, 35.0), (0.284, -28.0), (0.21, 0.0), (0.063, 38.0), (0.042, 42.0), (0.047, 50.0)),
    scapula=(0.12, 0.06, 0.06),
    shoulder_lateral=0.12,
    front=segs((0.261, 38.0), (0.272, -17.0), (0.294, 0.0), (0.198, 0.0), (0.078, 38.0), (0.084, 45.0)),
)

BEAR = Species(
    # Brown bear (Ursus arctos), a mid-sized adult. Plantigrade: the whole hind foot, heel
    # included, rests on the ground, and the fore paw's palm too (Shine et al. 2015, J. Exp.
    # Biol. 218:3102, grizzly locomotion; Storer & Tevis, "California Grizzly": "both fore and
    # hind feet are fully plantigrade", limbs of nearly equal length). Long femur and humerus,
    # short broad metapodials, big head, short thick neck, a tail of only 6-20 cm. The hip is
    # broad and the back rises to the shoulder hump.
    name="bear",
    hp_cm=93.66,
    pelvis=Seg(0.15, 4.0),
    spine=segs((0.17, 4.0), (0.17, 3.0), (0.17, 2.0)),
    thorax=Seg(0.28, -8.0),
    neck=segs((0.07, 15.0), (0.07, 15.0), (0.07, 12.0), (0.07, 10.0), (0.07, 5.0)),
    head=Seg(0.40, -25.0),
    tail_root=(0.07, 0.0),
    tail=segs((0.04, -40.0), (0.035, -55.0), (0.035, -65.0), (0.03, -70.0)),
    hip=(0.05, 0.08, 0.13),
    hind=segs((0.508, 15.0), (0.395, -8.0), (0.181, 80.0), (0.051, 85.0), (0.04, 88.0), (0.034, 90.0)),
    scapula=(0.12, 0.06, 0.07),
    shoulder_lateral=0.14,
    front=segs((0.337, 30.0), (0.426, -20.0), (0.348, -3.0), (0.123, 70.0), (0.062, 80.0), (0.056, 85.0)),
)

LION = Species(
    # Lioness (shoulder ~1.0-1.1 m). Felids keep one posture from cat to tiger and scale their
    # bones instead (Doube et al. 2009, "Three-dimensional geometric analysis of felid limb
    # bone allometry", PLoS ONE 4:e4742), so the lion shares the cat's angles; proportions
    # after the Blender Rigify cat metarig: humerus and radius long, metacarpus short, femur
    # and tibia about equal, metatarsus ~40 % of the tibia. Digitigrade and more crouched than
    # the dog, big head, short neck carried low, tail ~0.8 m (about 1.05 HP).
    name="lion",
    hp_cm=76.48,
    pelvis=Seg(0.14, 2.0),
    spine=segs((0.18, 4.0), (0.18, 2.0), (0.18, 0.0)),
    thorax=Seg(0.27, -6.0),
    neck=segs((0.065, 25.0), (0.065, 25.0), (0.065, 20.0), (0.065, 15.0), (0.065, 10.0)),
    head=Seg(0.40, -25.0),
    tail_root=(0.05, 0.01),
    tail=segs((0.27, -55.0), (0.27, -70.0), (0.26, -60.0), (0.24, -30.0)),
    hip=(0.04, 0.08, 0.10),
    hind=segs((0.45, 30.0), (0.429, -45.0), (0.182, 15.0), (0.054, 55.0), (0.048, 70.0), (0.043, 85.0)),
    scapula=(0.14, 0.03, 0.05),
    shoulder_lateral=0.10,
    front=segs((0.308, 32.0), (0.383, -42.0), (0.351, -4.0), (0.128, 20.0), (0.058, 60.0), (0.048, 80.0)),
)

GOAT = Species(
    # Domestic goat (withers ~64 cm, Animal Diversity Web). A small ruminant ungulate: long
    # metapodials (cannon ~0.2 HP), steep pasterns, scapula and humerus about equal, tibia
    # longer than femur (approximate, after Nickel, Schummer & Seiferle's caprine osteology). Short upright tail,
    # neck carried high, head pointing down.
    name="goat",
    hp_cm=59.54,
    pelvis=Seg(0.18, 5.0),
    spine=segs((0.16, 2.0), (0.16, 0.0), (0.16, 0.0)),
    thorax=Seg(0.28, -6.0),
    neck=segs((0.07, 45.0), (0.07, 50.0), (0.07, 55.0), (0.07, 60.0), (0.07, 60.0)),
    head=Seg(0.34, -50.0),
    tail_root=(0.08, 0.02),
    tail=segs((0.05, 30.0), (0.05, 45.0), (0.05, 55.0), (0.045, 60.0)),
    hip=(0.06, 0.13, 0.09),
    hind=segs((0.309, 30.0), (0.347, -35.0), (0.212, 5.0), (0.063, 40.0), (0.043, 45.0), (0.048, 55.0)),
    scapula=(0.13, 0.05, 0.05),
    shoulder_lateral=0.10,
    front=segs((0.283, 35.0), (0.273, -40.0), (0.305, 0.0), (0.218, 0.0), (0.071, 40.0), (0.082, 50.0)),
)

PIG = Species(
    # Domestic pig the size of an adult minipig (Goettingen minipig: 40-50 cm high, 45-55 kg;
    # University of Goettingen breed page). Short-legged and long-bodied: leg bones short
    # against a deep trunk, the hip joint well below the back line, short metapodials, standing
    # on the two main claws (unguligrade, dew claws off the ground). Long pelvis and loin,
    # long snout, short thick neck (porcine osteology, Nickel, Schummer & Seiferle).
    name="pig",
    hp_cm=48.41,
    pelvis=Seg(0.26, 2.0),
    spine=segs((0.26, 1.0), (0.26, 0.0), (0.26, 0.0)),
    thorax=Seg(0.36, -5.0),
    neck=segs((0.055, 15.0), (0.055, 15.0), (0.055, 10.0), (0.055, 10.0), (0.055, 5.0)),
    head=Seg(0.55, -30.0),
    tail_root=(0.10, 0.0),
    tail=segs((0.09, -50.0), (0.09, -70.0), (0.085, -80.0), (0.08, -85.0)),
    hip=(0.08, 0.24, 0.11),
    hind=segs((0.31, 25.0), (0.277, -25.0), (0.144, 10.0), (0.055, 45.0), (0.044, 55.0), (0.05, 65.0)),
    scapula=(0.14, 0.0, 0.07),
    shoulder_lateral=0.12,
    front=segs((0.344, 35.0), (0.293, -35.0), (0.255, 0.0), (0.153, 15.0), (0.064, 45.0), (0.076, 55.0)),
)

CAT = Species(
    # Domestic cat (~4-5 kg, shoulder ~25 cm). Feline proportions (Rigify cat metarig; Doube et
    # al. 2009, PLoS ONE 4:e4742): hind limb much longer than the fore, tibia longest, long
    # lumbar spine. Digitigrade and crouched, with a tail about as long as the body's height
    # (25-30 cm) carried low with the tip up.
    name="cat",
    hp_cm=27.93,
    pelvis=Seg(0.16, 3.0),
    spine=segs((0.21, 4.0), (0.21, 2.0), (0.21, 0.0)),
    thorax=Seg(0.28, -8.0),
    neck=segs((0.05, 35.0), (0.05, 35.0), (0.05, 30.0), (0.05, 25.0), (0.05, 20.0)),
    head=Seg(0.32, -30.0),
    tail_root=(0.05, 0.01),
    tail=segs((0.27, -45.0), (0.26, -60.0), (0.25, -40.0), (0.22, 10.0)),
    hip=(0.04, 0.07, 0.09),
    hind=segs((0.442, 35.0), (0.486, -50.0), (0.221, 20.0), (0.061, 60.0), (0.05, 75.0), (0.048, 85.0)),
    scapula=(0.14, 0.02, 0.04),
    shoulder_lateral=0.09,
    front=segs((0.274, 28.0), (0.383, -42.0), (0.372, -2.0), (0.12, 20.0), (0.06, 60.0), (0.049, 80.0)),
)

RAT = Species(
    # Brown rat (Rattus norvegicus). Limb proportions and the crouched standing pose from the
    # dm_control rodent model (locomotion/walkers/assets/rodent.xml, built from a rat CT scan):
    # femur 3.5 cm leaning ~31 deg forward, tibia 3.9 cm leaning ~56 deg back, a long hind
    # foot held nearly flat (plantigrade), for a hip ~5 cm high; forelimbs crouched with the
    # elbow well behind the shoulder (Bonnan et al. 2016, PLoS ONE 11:e0149377, rat forelimb
    # XROMM). Long head (~0.9 of the hip height) and a tail about as long as head + body.
    # Phalanges stay >= 1.2 bone radii, since the thesis's radius (HP/75 + 0.1 cm) is thick
    # for an animal this small.
    name="rat",
    hp_cm=2.54,
    pelvis=Seg(0.30, 10.0),
    spine=segs((0.42, 15.0), (0.42, 0.0), (0.42, -12.0)),
    thorax=Seg(0.60, -15.0),
    neck=segs((0.10, 10.0), (0.10, 10.0), (0.10, 5.0), (0.10, 0.0), (0.10, 0.0)),
    head=Seg(0.85, -20.0),
    tail_root=(0.12, 0.0),
    tail=segs((0.85, -15.0), (0.85, -4.0), (0.85, 0.0), (0.85, 0.0)),
    hip=(0.08, 0.12, 0.20),
    hind=segs((0.549, 31.0), (0.604, -56.0), (0.366, 80.0), (0.075, 85.0), (0.07, 88.0), (0.07, 90.0)),
    scapula=(0.35, 0.10, 0.12),
    shoulder_lateral=0.22,
    front=segs((0.507, 50.0), (0.579, -60.0), (0.531, 20.0), (0.121, 70.0), (0.085, 80.0), (0.078, 88.0)),
)

SPECIES: dict[str, Species] = {
    species.name: species for species in (ELEPHANT, COW, HORSE, BEAR, LION, DOG, GOAT, PIG, CAT, RAT)
}


# --- Geometry -----------------------------------------------------------------------------

Point = tuple[float, float, float]
"""A position in the file's axes, in cm: (x to the animal's left, y up, z forward)."""


@dataclass(frozen=True)
class Joint:
    """One generated joint: role (also its name), parent, rest position, and a leaf's end."""

    name: str
    parent: str | None
    position: Point
    end: Point | None = None


def _axial_offset(seg: Seg, hp_cm: float, backward: bool = False) -> tuple[float, float]:
    """(up, forward) displacement in cm along an axial bone of the given pitch."""
    pitch = math.radians(seg.angle)
    length = seg.length * hp_cm
    return length * math.sin(pitch), (-1.0 if backward else 1.0) * length * math.cos(pitch)


def _axial_chain(
    names: tuple[str, ...], chain: tuple[Seg, ...], parent: str, start: Point, hp_cm: float, backward: bool = False
) -> tuple[list[Joint], Point]:
    """Joints of a chain of axial bones, and the far end of its last bone."""
    joints = []
    x, y, z = start
    for name, seg in zip(names, chain):
        joints.append(Joint(name, parent, (x, y, z)))
        up, forward = _axial_offset(seg, hp_cm, backward)
        y, z = y + up, z + forward
        parent = name
    return joints, (x, y, z)


def leg_drop(chain: tuple[Seg, ...]) -> float:
    """Height a leg chain spans before scaling, in HP: the sum of length * cos(lean)."""
    return sum(seg.length * math.cos(math.radians(seg.angle)) for seg in chain)


def _leg(
    prefix: str, bones: tuple[str, ...], chain: tuple[Seg, ...], root: str, top: Point, lateral: float, hp_cm: float
) -> tuple[list[Joint], float]:
    """One leg hanging from `top`, scaled so its last phalanx ends at height 0.

    Args:
        prefix: leg prefix (`lf`, ...).
        bones: the leg's bone kinds, top down.
        chain: their lengths (HP) and leans.
        root: the bone the leg hangs from (thorax or pelvis).
        top: the first joint's position.
        lateral: x of every joint below the first one.
        hp_cm: the animal's HP.

    Returns:
        The joints, and the scale applied to the table's lengths.
    """
    scale = top[1] / (leg_drop(chain) * hp_cm)
    joints = []
    parent = root
    x, y, z = top
    for bone, seg in zip(bones, chain):
        role = f"{prefix}_{bone}"
        joints.append(Joint(role, parent, (x, y, z)))
        lean = math.radians(seg.angle)
        length = seg.length * hp_cm * scale
        x, y, z = lateral, y - length * math.cos(lean), z + length * math.sin(lean)
        parent = role
    last = joints[-1]
    joints[-1] = Joint(last.name, last.parent, last.position, (x, 0.0, z))
    return joints, scale


def build(species: Species) -> tuple[list[Joint], dict[str, float]]:
    """All 39 joints of a species' rest pose, parents first, and each leg's scale."""
    hp = species.hp_cm
    joints = [Joint("pelvis", None, (0.0, hp, 0.0))]
    up, forward = _axial_offset(species.pelvis, hp)
    spine, thorax_at = _axial_chain(roles.SPINE, species.spine, "pelvis", (0.0, hp + up, forward), hp)
    joints += spine
    joints.append(Joint("thorax", roles.SPINE[-1], thorax_at))
    up, forward = _axial_offset(species.thorax, hp)
    neck, head_at = _axial_chain(
        roles.NECK, species.neck, "thorax", (0.0, thorax_at[1] + up, thorax_at[2] + forward), hp
    )
    joints += neck
    up, forward = _axial_offset(species.head, hp)
    joints.append(Joint("head", roles.NECK[-1], head_at, (0.0, head_at[1] + up, head_at[2] + forward)))

    back, rise = species.tail_root
    tail, tail_end = _axial_chain(
        roles.TAIL, species.tail, "pelvis", (0.0, hp + rise * hp, -back * hp), hp, backward=True
    )
    tail[-1] = Joint(tail[-1].name, tail[-1].parent, tail[-1].position, tail_end)
    joints += tail

    scales = {}
    for prefix, side in (("lf", 1.0), ("rf", -1.0)):
        forward, rise, lateral = species.scapula
        top = (side * lateral * hp, thorax_at[1] + rise * hp, thorax_at[2] + forward * hp)
        leg, scales[prefix] = _leg(
            prefix, roles.FRONT_CHAIN, species.front, "thorax", top, side * species.shoulder_lateral * hp, hp
        )
        joints += leg
    for prefix, side in (("lh", 1.0), ("rh", -1.0)):
        back, drop, lateral = species.hip
        top = (side * lateral * hp, hp - drop * hp, -back * hp)
        leg, scales[prefix] = _leg(prefix, roles.HIND_CHAIN, species.hind, "pelvis", top, side * lateral * hp, hp)
        joints += leg
    by_name = {joint.name: joint for joint in joints}
    return [by_name[role] for role in roles.ROLES], scales


def bone_lengths(joints: list[Joint]) -> dict[str, float]:
    """Length of each bone in cm: to its main child's joint, or to its end for a leaf."""
    by_name = {joint.name: joint for joint in joints}
    lengths = {}
    for joint in joints:
        children = roles.CHILDREN[joint.name]
        end = by_name[roles.MAIN_CHILD.get(joint.name, children[0])].position if children else joint.end
        lengths[joint.name] = math.dist(joint.position, end)
    return lengths


def fig7_shares(joints: list[Joint], radius_cm: float) -> dict[str, tuple[float, float]]:
    """Per Fig. 7 part: (its share of the parts' summed L + 4/3 r, its share of the thesis's masses).

    A capsule of length L and radius r weighs rho * pi r^2 (L + 4/3 r), so with one radius and
    one density the parts' masses go as their sums of (L + 4/3 r).
    """
    lengths = bone_lengths(joints)
    amounts = {
        part: sum(lengths[bone] + 4.0 / 3.0 * radius_cm for bone in bones) for part, bones in DOG_PART_BONES.items()
    }
    total_amount = sum(amounts.values())
    total_mass = sum(DOG_FIG7_PART_MASSES.values())
    return {part: (amounts[part] / total_amount, DOG_FIG7_PART_MASSES[part] / total_mass) for part in amounts}


# --- Output -------------------------------------------------------------------------------


def _number(value: float, decimals: int) -> str:
    """A coordinate rounded to `decimals`, without trailing zeros or a negative zero."""
    text = f"{round(value, decimals) + 0.0:.{decimals}f}".rstrip("0").rstrip(".")
    return "0" if text == "-0" else text


def _vector(point: Point, decimals: int) -> str:
    return " ".join(_number(value, decimals) for value in point)


def to_xml(species: Species, joints: list[Joint]) -> str:
    """The skeleton file's text (see docs/formats.md)."""
    decimals = SMALL_DECIMALS if species.hp_cm < SMALL_ANIMAL_HP_CM else DECIMALS
    lines = [
        '<?xml version="1.0" encoding="utf-8"?>',
        f"<!-- {species.name}: generated by tools/make_skeletons.py from its table; edit the table, not this file. -->",
        f'<skeleton name="{species.name}" units="cm" up="y" version="1">',
    ]
    for joint in joints:
        attrs = [f'name="{joint.name}"', f'role="{joint.name}"']
        if joint.parent is not None:
            attrs.append(f'parent="{joint.parent}"')
        attrs.append(f'position="{_vector(joint.position, decimals)}"')
        attrs.append(f'axis="{LATERAL_AXIS}"')
        if joint.end is not None:
            attrs.append(f'end="{_vector(joint.end, decimals)}"')
        lines.append(f"  <joint {' '.join(attrs)}/>")
    lines.append("</skeleton>")
    return "\n".join(lines) + "\n"


def generate(names: list[str] | None = None, output_dir: Path = OUTPUT_DIR) -> list[Path]:
    """Write the skeleton files of the named species (all when None) and return their paths."""
    output_dir.mkdir(parents=True, exist_ok=True)
    written = []
    for name in names or list(SPECIES):
        species = SPECIES[name]
        joints, _ = build(species)
        path = output_dir / f"{name}.xml"
        path.write_text(to_xml(species, joints), encoding="utf-8")
        written.append(path)
    return written


def report(species: Species) -> list[str]:
    """Lines on a species' skeleton: leg scales, shortest bone and, for the dog, the Fig. 7 check."""
    joints, scales = build(species)
    lengths = bone_lengths(joints)
    shortest = min(lengths, key=lengths.__getitem__)
    lines = [
        "leg scales "
        + ", ".join(f"{leg} {scale:.3f}" for leg, scale in scales.items())
        + f"; shortest bone {shortest} {lengths[shortest]:.3f} cm = {lengths[shortest] / species.radius_cm:.2f} radii"
    ]
    if species.name == "dog":
        for part, (share, target) in fig7_shares(joints, species.radius_cm).items():
            lines.append(
                f"Fig. 7 {part:9s}: share of sum(L + 4/3 r) {share:.3f}, of the masses {target:.3f}, ratio {share / target:.3f}"
            )
    return lines


def main(argv: list[str]) -> int:
    """Regenerate the species named in `argv` (all when empty) and print the checks."""
    unknown = [name for name in argv if name not in SPECIES]
    if unknown:
        print(f"unknown species: {', '.join(unknown)}; known: {', '.join(SPECIES)}", file=sys.stderr)
        return 2
    for path in generate(argv or None):
        print(f"wrote {path}")
        for line in report(SPECIES[path.stem]):
            print(f"  {line}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
