"""Names in skeleton files and role maps: joint names (namespaces, DAG paths, which side a
name says) and the anatomical bone names people write for roles."""

from __future__ import annotations

import re

from quadpipe.anatomy.roles import FRONT_CHAIN, LEGS, ROLES
from quadpipe.core.errors import did_you_mean

LEFT_WORDS = {"l", "left", "lt", "lf", "lh", "fl", "bl", "hl", "lb"}
RIGHT_WORDS = {"r", "right", "rt", "rf", "rh", "fr", "br", "hr", "rb"}
"""Name parts (case-insensitive) that say which side a joint is on (`FL_` is front left)."""

FRONT_WORDS = {"front", "fore", "f", "lf", "rf", "fl", "fr", "arm", "forearm", "hand", "finger", "clavicle"}
HIND_WORDS = {"back", "hind", "rear", "b", "h", "lh", "rh", "bl", "br", "hl", "hr", "lb", "rb", "upleg", "thigh"}
HIND_WORDS |= {"calf", "shin", "horselink", "femur", "tibia"}
"""Name parts that say a leg is a fore or a hind leg (mocap `LeftArm` is a fore leg, `LeftUpLeg` a
hind one; 3ds Max Biped `Clavicle`/`Thigh`; Rigify `upper_arm`/`thigh`; `Front`/`Back`, `F`/`B`)."""

AXIAL_WORDS = {"tail": "tail", "tails": "tail", "dock": "tail", "head": "head", "skull": "head", "jaw": "head"}
"""Name parts that say a joint is not a leg: tail, or head (whose chain ends the neck)."""

ANATOMY: dict[str, str] = {
    "clavicle": "scapula",
    "humerus": "shoulder",
    "upperarm": "shoulder",
    "radius": "elbow",
    "ulna": "elbow",
    "forearm": "elbow",
    "metacarpus": "wrist",
    "hand": "wrist",
    "femur": "hip",
    "thigh": "hip",
    "tibia": "knee",
    "fibula": "knee",
    "shin": "knee",
    "calf": "knee",
    "metatarsus": "ankle",
    "foot": "ankle",
}
"""Anatomical bone names -> the role kind of that bone (a bone is named after its proximal joint)."""

_NAME_PARTS = re.compile(r"[A-Z]+(?=[A-Z][a-z])|[A-Z]?[a-z]+|[A-Z]+|\d+")


def short_name(name: str) -> str:
    """A joint name without its Maya DAG path and namespace: `|grp|ns:L_Hip` -> `L_Hip`."""
    return name.rsplit("|", 1)[-1].rsplit(":", 1)[-1]


def name_words(name: str) -> set[str]:
    """The lower-cased words of a joint name: `Bip01 L Thigh` -> bip, 01, l, thigh; `LeftUpLeg`
    -> left, up, leg, upleg (adjacent CamelCase pairs are words too)."""
    words: set[str] = set()
    for part in re.split(r"[^A-Za-z0-9]+", short_name(name)):
        found = [w.lower() for w in _NAME_PARTS.findall(part)]
        words.update(found)
        words.update(a + b for a, b in zip(found, found[1:]))
    return words


def name_end(name: str) -> str | None:
    """'fore' or 'hind' when a joint's name says which leg pair it belongs to."""
    words = name_words(name)
    is_fore, is_hind = bool(words & FRONT_WORDS), bool(words & HIND_WORDS)
    if is_fore == is_hind:
        return None
    return "fore" if is_fore else "hind"


def name_axial(name: str) -> str | None:
    """'tail' or 'head' when a joint's name says it is one of those (`Tail2`, `Bip01 Head`, `Skull`)."""
    return next((AXIAL_WORDS[w] for w in sorted(name_words(name)) if w in AXIAL_WORDS), None)


def name_side(name: str) -> str | None:
    """'left' or 'right' when a joint's name says so (`L_Hip`, `LeftUpLeg`, `hip.r`, `Bip01 R Thigh`)."""
    words = name_words(name)
    is_left, is_right = bool(words & LEFT_WORDS), bool(words & RIGHT_WORDS)
    if is_left == is_right:
        return None
    return "left" if is_left else "right"


def unknown_role_hint(role: str) -> str:
    """A hint for a role that does not exist: the anatomical name's role, or the closest roles."""
    prefix, _, rest = role.partition("_")
    kind = ANATOMY.get((rest if prefix in LEGS else role).lower())
    if kind is not None:
        end = "f" if kind in FRONT_CHAIN else "h"
        legs = [prefix[0] + end] if prefix in LEGS else [leg for leg in LEGS if leg.endswith(end)]
        suggestion = " or ".join(repr(f"{leg}_{kind}") for leg in legs)
        bone = rest if prefix in LEGS else role
        return f"bones are named after the joint at their proximal end: the {bone} is {suggestion}"
    return did_you_mean(role, ROLES, listing=False) or "see `quadpipe roles` for the 39 roles"
