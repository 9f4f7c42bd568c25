"""The 39-bone reference hierarchy shared by every quadruped (thesis §3.1).

A *role* names a bone's place in that hierarchy, independently of what a skeleton file calls
it. Controllers, exporters and tools only ever speak of roles.

Counting as the thesis does: pelvis, thorax and head (3), spine0-2 (3), neck0-4 (5),
tail0-3 (4); per leg three leg bones and three foot bones (4 x 6 = 24):

- front legs: scapula, shoulder (humerus), elbow (forearm) | wrist (metacarpus), fpha0, fpha1
- hind legs:  hip (femur), knee (tibia), ankle (metatarsus) | hpha0, hpha1, hpha2

A bone is named after the joint at its proximal end, as in the thesis's limits table (the
"knee" bone is the tibia, which turns at the knee). Numbering is 0-based like the table's
`neck0`/`fpha0`/`hpha0` rows, counting away from the body. Legs are prefixed with the
Hildebrand gait notation: `lf_` left fore, `rf_` right fore, `lh_` left hind, `rh_` right hind.

Body frame used everywhere in quadpipe: metres, +X forward, +Y to the animal's left, +Z up.
"""

from __future__ import annotations

from collections.abc import Iterable
from fnmatch import fnmatchcase

LEGS: tuple[str, ...] = ("lf", "rf", "lh", "rh")
"""Leg prefixes: left fore, right fore, left hind, right hind."""

FRONT_CHAIN: tuple[str, ...] = ("scapula", "shoulder", "elbow", "wrist", "fpha0", "fpha1")
HIND_CHAIN: tuple[str, ...] = ("hip", "knee", "ankle", "hpha0", "hpha1", "hpha2")
SPINE: tuple[str, ...] = ("spine0", "spine1", "spine2")
NECK: tuple[str, ...] = ("neck0", "neck1", "neck2", "neck3", "neck4")
TAIL: tuple[str, ...] = ("tail0", "tail1", "tail2", "tail3")


def leg_chain(leg: str) -> tuple[str, ...]:
    """The bone names (without the leg prefix) of a leg: the fore chain for `lf`/`rf`, else hind."""
    return FRONT_CHAIN if leg.endswith("f") else HIND_CHAIN


TOE_BONES: dict[str, str] = {leg: f"{leg}_{leg_chain(leg)[-1]}" for leg in LEGS}
"""The last phalanx of each leg, whose far end is the toe tip."""

FOOT_BONES: dict[str, tuple[str, str]] = {
    leg: (f"{leg}_{leg_chain(leg)[-2]}", f"{leg}_{leg_chain(leg)[-1]}") for leg in LEGS
}
"""The bones whose contact with the world counts as the foot touching down: the last two phalanges."""


def _chain(parent: str, names: Iterable[str]) -> dict[str, str]:
    links = {}
    for name in names:
        links[name] = parent
        parent = name
    return links


def _build_parents() -> dict[str, str | None]:
    parents: dict[str, str | None] = {"pelvis": None}
    parents.update(_chain("pelvis", SPINE))
    parents["thorax"] = SPINE[-1]
    parents.update(_chain("thorax", NECK))
    parents["head"] = NECK[-1]
    parents.update(_chain("pelvis", TAIL))
    for leg in LEGS:
        chain = FRONT_CHAIN if leg.endswith("f") else HIND_CHAIN
        root = "thorax" if leg.endswith("f") else "pelvis"
        parents.update(_chain(root, (f"{leg}_{bone}" for bone in chain)))
    return parents


PARENT: dict[str, str | None] = _build_parents()
"""Parent role of each role (None for the pelvis, the root). Insertion order is parents-first."""

ROLES: tuple[str, ...] = tuple(PARENT)
"""All 39 roles, parents before children."""

MAIN_CHILD: dict[str, str] = {"pelvis": "spine0", "thorax": "neck0"}
"""For the two bones with several children, the child whose joint ends the bone."""

CHILDREN: dict[str, tuple[str, ...]] = {
    role: tuple(child for child, parent in PARENT.items() if parent == role) for role in ROLES
}

LEAVES: tuple[str, ...] = tuple(role for role in ROLES if not CHILDREN[role])
"""Bones with no child: their end point must come from the file (an end site)."""

BOX_BONES: tuple[str, ...] = ("pelvis", "thorax")
"""Bones modelled as boxes (each carries four joints)."""

HEAD_BONE = "head"
"""The bone modelled as five fused capsules."""

assert len(ROLES) == 39, "the reference hierarchy has 39 bones"


def kind_of(role: str) -> str:
    """A role without its leg prefix: `lf_elbow` -> `elbow`, `neck2` -> `neck2`."""
    prefix, _, rest = role.partition("_")
    return rest if prefix in LEGS and rest else role


def leg_of(role: str) -> str | None:
    """The leg prefix of a leg role (`lf`, ...) or None for axial bones."""
    prefix, _, rest = role.partition("_")
    return prefix if prefix in LEGS and rest else None


def is_front(role: str) -> bool:
    """Whether a leg role belongs to a front leg."""
    leg = leg_of(role)
    return leg is not None and leg.endswith("f")


JOINT_AXES: dict[str, str] = {"twist": "", "swing1": "_swing1", "swing2": "_swing2"}
"""A joint's axes, as a spring may pick them (`lh_hip.swing1`) -> the suffix of their MuJoCo
joint after the role: the twist about the bone's main (lateral) axis, swing1 about the forward
axis, swing2 about the vertical."""


def match_roles(pattern: str) -> list[str]:
    """Roles matching a shell-style glob (`*_hip`, `lf_*`, `spine?`), in hierarchy order."""
    return [role for role in ROLES if fnmatchcase(role, pattern)]


def ancestors(role: str) -> list[str]:
    """Roles from `role`'s parent up to the pelvis."""
    chain = []
    parent = PARENT[role]
    while parent is not None:
        chain.append(parent)
        parent = PARENT[parent]
    return chain
