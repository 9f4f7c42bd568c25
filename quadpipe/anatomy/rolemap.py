"""Which joint of a skeleton file plays which role: role maps, and guessing when there is none.

A role map is a small YAML file:

    units: cm          # optional: the file's length unit (BVH declares none)
    up: y              # optional: the file's up axis
    roles:             # joint name (shell glob, case-insensitive) -> role
      Hips: pelvis
      "*:L_UpperLeg": lh_hip
      "*_end": ~       # no role: these joints stay unplaced

Without a role map, roles written in the file are used (the quadpipe XML format has them);
when the file has none, `guess_roles` places them from the joints' names (left/right only)
and from the hierarchy and the rest positions (everything else). See docs/formats.md.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from fnmatch import fnmatchcase
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from pydantic import BaseModel, ConfigDict, Field, field_validator

from quadpipe.anatomy.roles import FRONT_CHAIN, HEAD_BONE, HIND_CHAIN, LEGS, NECK, PARENT, ROLES, SPINE, TAIL
from quadpipe.anatomy.skeleton import UNIT_TO_METRES, UP_AXES, JointRecord, RawSkeleton, check_structure
from quadpipe.core.errors import Issue, Location, QuadpipeError, did_you_mean
from quadpipe.core.yamlio import load_yaml, validate_document

GLOB_CHARACTERS = "*?["
"""Characters that make a role-map key a pattern rather than a plain name."""

MIN_BRANCHES = 3
"""A joint with this many children or more is a branch point (pelvis or thorax)."""

LEFT_WORDS = {"l", "left", "lt", "lf", "lh"}
RIGHT_WORDS = {"r", "right", "rt", "rf", "rh"}
"""Name parts (case-insensitive) that say which side a joint is on."""

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

SHOWN_JOINTS = 5
"""How many joint names a message lists before writing '...'."""

_NAME_PARTS = re.compile(r"[A-Z]+(?=[A-Z][a-z])|[A-Z]?[a-z]+|[A-Z]+|\d+")


# -- role map files -------------------------------------------------------------------------


class RoleMapModel(BaseModel):
    """Schema of a role map YAML file."""

    model_config = ConfigDict(extra="forbid")

    units: str | None = Field(None, description="Length unit of the skeleton file: m, cm, mm, in or ft.")
    up: str | None = Field(None, description="Up axis of the skeleton file: y or z.")
    roles: dict[str, str | None] | None = Field(
        None, description="Joint name or shell glob (case-insensitive) -> role; null leaves the joint unplaced."
    )

    @field_validator("units")
    @classmethod
    def _known_unit(cls, value: str | None) -> str | None:
        if value is not None and value not in UNIT_TO_METRES:
            raise ValueError(f"unit {value!r} is unknown; use one of {', '.join(UNIT_TO_METRES)}")
        return value

    @field_validator("up")
    @classmethod
    def _known_up(cls, value: str | None) -> str | None:
        if value is not None and value not in UP_AXES:
            raise ValueError(f"up axis {value!r} is unknown; use one of {', '.join(UP_AXES)}")
        return value


@dataclass(frozen=True)
class RolePattern:
    """One `pattern: role` line of a role map (`role` None leaves matching joints unplaced)."""

    pattern: str
    role: str | None
    where: Location

    @property
    def is_glob(self) -> bool:
        """Whether the key is a shell glob rather than a plain joint name."""
        return any(c in self.pattern for c in GLOB_CHARACTERS)

    def matches(self, name: str) -> bool:
        """Case-insensitive match against a joint name, or the name without namespace or DAG path."""
        pattern = self.pattern.casefold()
        candidates = {name.casefold(), short_name(name).casefold()}
        if self.is_glob:
            return any(fnmatchcase(c, pattern) for c in candidates)
        return pattern in candidates


@dataclass(frozen=True)
class RoleMap:
    """A loaded role map; `patterns` is None when the file has no `roles` key."""

    source: str
    units: str | None
    up: str | None
    patterns: tuple[RolePattern, ...] | None


def load_role_map(path: str | Path) -> RoleMap:
    """Read and check a role map YAML file.

    Raises:
        QuadpipeError: YAML or schema errors, and `unknown-role` for every role that is not
            one of the 39, each at its line with a "did you mean" hint.
    """
    doc = load_yaml(path)
    model = validate_document(RoleMapModel, doc)
    patterns = None
    if model.roles is not None:
        patterns = tuple(
            RolePattern(pattern, role, doc.locate(("roles", pattern))) for pattern, role in model.roles.items()
        )
        _check_roles(patterns)
    return RoleMap(doc.file, model.units, model.up, patterns)


def _check_roles(patterns: Sequence[RolePattern]) -> None:
    issues = [
        Issue(
            "unknown-role",
            f"{p.role!r} (for {p.pattern!r}) is not a role of the reference hierarchy",
            p.where,
            unknown_role_hint(p.role),
        )
        for p in patterns
        if p.role is not None and p.role not in PARENT
    ]
    if issues:
        raise QuadpipeError(issues)


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


def short_name(name: str) -> str:
    """A joint name without its Maya DAG path and namespace: `|grp|ns:L_Hip` -> `L_Hip`."""
    return name.rsplit("|", 1)[-1].rsplit(":", 1)[-1]


def apply_role_map(raw: RawSkeleton, role_map: RoleMap) -> tuple[dict[str, str], tuple[Issue, ...]]:
    """Roles of the joints matched by a role map's patterns.

    A joint takes the role of the pattern that names it exactly (case-insensitive), else of
    the first glob in file order that matches it.

    Returns:
        joint name -> role, and warnings for patterns that match no joint.

    Raises:
        QuadpipeError: `ambiguous-pattern` when one pattern gives its role to several
            joints, `duplicate-role` when two patterns give the same role.
    """
    patterns = role_map.patterns or ()
    chosen: dict[str, RolePattern] = {}
    for joint in raw.joints:
        exact = [p for p in patterns if not p.is_glob and p.matches(joint.name)]
        pattern = exact[0] if exact else next((p for p in patterns if p.is_glob and p.matches(joint.name)), None)
        if pattern is not None:
            chosen[joint.name] = pattern
    issues = _role_conflicts(chosen)
    if issues:
        raise QuadpipeError(issues)
    used = {id(p) for p in chosen.values()}
    names = [j.name for j in raw.joints]
    warnings = tuple(
        Issue(
            "unused-pattern",
            f"{p.pattern!r} matches no joint of {Path(raw.source).name}",
            p.where,
            did_you_mean(p.pattern, names, listing=False) or None,
            severity="warning",
        )
        for p in patterns
        if id(p) not in used
    )
    return {name: p.role for name, p in chosen.items() if p.role is not None}, warnings


def _role_conflicts(chosen: Mapping[str, RolePattern]) -> list[Issue]:
    by_role: dict[str, list[tuple[str, RolePattern]]] = {}
    for name, pattern in chosen.items():
        if pattern.role is not None:
            by_role.setdefault(pattern.role, []).append((name, pattern))
    issues = []
    for role, holders in by_role.items():
        if len(holders) < 2:
            continue
        (first_name, first), (second_name, second) = holders[0], holders[1]
        if first is second:
            names = ", ".join(repr(n) for n, _ in holders[:SHOWN_JOINTS])
            names += " ..." if len(holders) > SHOWN_JOINTS else ""
            issues.append(
                Issue(
                    "ambiguous-pattern",
                    f"{first.pattern!r} gives role {role} to {len(holders)} joints: {names}",
                    first.where,
                    "make the pattern match one joint (write the full name)",
                )
            )
        else:
            issues.append(
                Issue(
                    "duplicate-role",
                    f"role {role} is given to {first_name!r} "
                    f"(by {first.pattern!r}, line {first.where.line}) "
                    f"and to {second_name!r} (by {second.pattern!r})",
                    second.where,
                    "each role belongs to exactly one joint",
                )
            )
    return issues


# -- guessing -------------------------------------------------------------------------------


@dataclass(frozen=True)
class RoleGuess:
    """What `guess_roles` found.

    Attributes:
        roles: joint name -> role, for the joints it could place.
        missing: roles it could not place, in hierarchy order.
        notes: one line per decision (which joint is the pelvis, which chain is which leg
            and why), for messages and for the header of a written role map.
        skips: the notes of chains longer than their roles, where joints were skipped.
    """

    roles: dict[str, str]
    missing: tuple[str, ...]
    notes: tuple[str, ...]
    skips: tuple[str, ...] = ()


@dataclass
class _Report:
    """Roles placed so far and the notes explaining them."""

    roles: dict[str, str] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    skips: list[str] = field(default_factory=list)

    def result(self) -> RoleGuess:
        placed = set(self.roles.values())
        missing = tuple(role for role in ROLES if role not in placed)
        return RoleGuess(dict(self.roles), missing, tuple(self.notes), tuple(self.skips))


@dataclass
class _Tree:
    """The joint hierarchy with the geometric helpers guessing needs."""

    raw: RawSkeleton
    by_name: dict[str, JointRecord] = field(init=False)
    children: dict[str, list[str]] = field(init=False)
    up: np.ndarray = field(init=False)
    _depths: dict[str, int] = field(init=False, default_factory=dict)

    def __post_init__(self) -> None:
        self.by_name = {j.name: j for j in self.raw.joints}
        self.children = {j.name: [] for j in self.raw.joints}
        for joint in self.raw.joints:
            if joint.parent in self.children:
                self.children[joint.parent].append(joint.name)
        self.up = UP_AXES.get(self.raw.up, UP_AXES["y"])

    def subtree(self, name: str) -> list[str]:
        """`name` and all its descendants, parents first."""
        found, stack = [], [name]
        while stack:
            current = stack.pop()
            found.append(current)
            stack.extend(reversed(self.children[current]))
        return found

    def depth(self, name: str) -> int:
        """Joints on the longest path from `name` down to a leaf, `name` included."""
        if name not in self._depths:
            self._depths[name] = 1 + max((self.depth(c) for c in self.children[name]), default=0)
        return self._depths[name]

    def points(self, names: Sequence[str]) -> np.ndarray:
        """Positions of the joints, and the ends they carry."""
        points = [self.by_name[n].position for n in names]
        points += [self.by_name[n].end for n in names if self.by_name[n].end is not None]
        return np.asarray(points, dtype=float)

    def lowest(self, name: str) -> float:
        """Height of the lowest point of a subtree (legs reach the ground; tails and necks do not)."""
        return float(np.min(self.points(self.subtree(name)) @ self.up))

    def is_branch(self, name: str) -> bool:
        return len(self.children[name]) >= MIN_BRANCHES

    def main_path(self, start: str) -> list[str]:
        """From `start` down the deepest branch; a final joint with no end is an end marker, not a bone."""
        path = [start]
        while self.children[path[-1]]:
            path.append(max(self.children[path[-1]], key=self.depth))
        last = self.by_name[path[-1]]
        if len(path) > 1 and last.end is None:
            path.pop()
        return path


def guess_roles(raw: RawSkeleton) -> RoleGuess:
    """Place the 39 roles on a skeleton whose file gives none.

    The structure decides: the pelvis is a joint where three or more chains leave and one
    of them (the spine) leads to another such joint (the thorax). At the pelvis, the two
    chains reaching lowest are the hind legs and the deepest other one the tail; at the
    thorax, the two lowest are the front legs and the deepest other one the neck and head.
    Left and right come from the joints' names (`L_`, `Left`, `.l`, `_R`, `Bip01 R ...`) when
    both legs of a pair say opposite sides, else from which side of the body they lie on.
    A chain follows the deepest child at each fork; a chain longer than its roles keeps its
    first and last joints and evenly spaced ones between.
    """
    tree = _Tree(raw)
    report = _Report()
    pair = _find_pelvis_and_thorax(tree)
    if pair is None:
        report.notes.append(
            f"no joint has {MIN_BRANCHES} or more chains leaving it with another such joint further along "
            "one of them (pelvis -> spine -> thorax)"
        )
        return report.result()
    pelvis, spine_child, thorax = pair
    report.roles[pelvis], report.roles[thorax] = "pelvis", "thorax"
    report.notes.append(f"pelvis {pelvis!r} and thorax {thorax!r}: the two joints where several chains meet")
    _fit(_path_between(tree, spine_child, thorax), SPINE, "spine", report)
    forward = _forward(tree, pelvis, thorax)
    hind = [c for c in tree.children[pelvis] if c != spine_child]
    _place_limbs(tree, pelvis, hind, ("lh", "rh"), HIND_CHAIN, ("tail", TAIL), forward, report)
    front = tree.children[thorax]
    neck = ("neck and head", (*NECK, HEAD_BONE))
    _place_limbs(tree, thorax, front, ("lf", "rf"), FRONT_CHAIN, neck, forward, report)
    return report.result()


def _find_pelvis_and_thorax(tree: _Tree) -> tuple[str, str, str] | None:
    """(pelvis, its child toward the thorax, thorax) with the most joints in their other chains."""
    best: tuple[int, tuple[str, str, str]] | None = None
    for pelvis in (j.name for j in tree.raw.joints if tree.is_branch(j.name)):
        for child in tree.children[pelvis]:
            thorax = _first_branch_below(tree, child)
            if thorax is None:
                continue
            others = [c for c in tree.children[pelvis] if c != child] + tree.children[thorax]
            score = sum(len(tree.subtree(c)) for c in others)
            if best is None or score > best[0]:
                best = (score, (pelvis, child, thorax))
    return best[1] if best else None


def _first_branch_below(tree: _Tree, start: str) -> str | None:
    """The nearest branch point at or below `start`, following children that lead to one."""
    current = start
    while not tree.is_branch(current):
        leading = [c for c in tree.children[current] if any(tree.is_branch(n) for n in tree.subtree(c))]
        if not leading:
            return None
        current = max(leading, key=lambda c: len(tree.subtree(c)))
    return current


def _path_between(tree: _Tree, start: str, stop: str) -> list[str]:
    """Joints from `start` down to `stop`'s parent (empty when `start` is `stop`)."""
    path = []
    current = tree.by_name[stop].parent
    while current is not None and current != tree.by_name[start].parent:
        path.append(current)
        current = tree.by_name[current].parent
    return path[::-1]


def _forward(tree: _Tree, pelvis: str, thorax: str) -> np.ndarray:
    """Horizontal unit vector from the pelvis toward the thorax."""
    forward = np.asarray(tree.by_name[thorax].position, float) - np.asarray(tree.by_name[pelvis].position, float)
    forward -= forward.dot(tree.up) * tree.up
    norm = np.linalg.norm(forward)
    return forward / norm if norm > 1e-12 else forward


def _place_limbs(
    tree: _Tree,
    hub: str,
    chains: Sequence[str],
    legs: tuple[str, str],
    leg_chain: tuple[str, ...],
    axial: tuple[str, tuple[str, ...]],
    forward: np.ndarray,
    report: _Report,
) -> None:
    """Legs (the two chains reaching lowest) and the axial chain (the deepest other one) at a hub."""
    candidates = sorted(chains, key=tree.lowest)
    leg_starts, rest = candidates[:2], candidates[2:]
    kind = "front" if legs[0].endswith("f") else "hind"
    if len(leg_starts) < 2:
        report.notes.append(f"{hub!r} has {len(leg_starts)} chain(s) for the two {kind} legs")
    paths = [tree.main_path(start) for start in leg_starts]
    for (side, reason), path in zip(_sides(tree, paths, forward, hub), paths):
        prefix = legs[0] if side == "left" else legs[1]
        _fit(path, tuple(f"{prefix}_{bone}" for bone in leg_chain), f"{side} {kind} leg ({reason})", report)
    label, axial_roles = axial
    if rest:
        _fit(tree.main_path(max(rest, key=tree.depth)), axial_roles, label, report)
    else:
        report.notes.append(f"no chain left at {hub!r} for the {label}")


def _sides(tree: _Tree, paths: Sequence[list[str]], forward: np.ndarray, hub: str) -> list[tuple[str, str]]:
    """(side, how it was decided) for each leg chain: names when they agree, else positions."""
    by_name = [next((side for name in path if (side := name_side(name))), None) for path in paths]
    if len(paths) == 2 and set(by_name) == {"left", "right"}:
        return [(side, "side from its names") for side in by_name]  # type: ignore[misc]
    left = np.cross(tree.up, forward)
    centre = np.asarray(tree.by_name[hub].position, float)
    lateral = [float((tree.points(path).mean(axis=0) - centre) @ left) for path in paths]
    if len(paths) == 2:
        order = ["left", "right"] if lateral[0] > lateral[1] else ["right", "left"]
        return [(side, "side from its position") for side in order]
    return [("left" if v > 0 else "right", "side from its position") for v in lateral]


def name_side(name: str) -> str | None:
    """'left' or 'right' when a joint's name says so (`L_Hip`, `LeftUpLeg`, `hip.r`, `Bip01 R Thigh`)."""
    words = {w.lower() for part in re.split(r"[^A-Za-z0-9]+", short_name(name)) for w in _NAME_PARTS.findall(part)}
    is_left, is_right = bool(words & LEFT_WORDS), bool(words & RIGHT_WORDS)
    if is_left == is_right:
        return None
    return "left" if is_left else "right"


def _fit(chain: Sequence[str], chain_roles: Sequence[str], label: str, report: _Report) -> None:
    """Give a chain's joints its roles; note a chain too short, or the joints skipped in a long one."""
    count, needed = len(chain), len(chain_roles)
    if count >= needed:
        picks = [round(i * (count - 1) / (needed - 1)) for i in range(needed)] if needed > 1 else [0]
        chosen = [chain[i] for i in picks]
    else:
        chosen = list(chain)
    report.roles.update(zip(chosen, chain_roles))
    span = f"{chain_roles[0]}..{chain_roles[-1]}" if needed > 1 else chain_roles[0]
    first = f" from {chain[0]!r}" if chain else ""
    text = f"{label}: {count} joint(s){first} for {needed} role(s) {span}"
    if count < needed:
        text += f"; too short: {', '.join(chain_roles[count:])} not placed"
    elif count > needed:
        text += f"; skipped {', '.join(repr(name) for name in chain if name not in chosen)}"
        report.skips.append(text)
    report.notes.append(text)


# -- putting it together --------------------------------------------------------------------


@dataclass(frozen=True)
class RoleResolution:
    """The result of `resolve_roles`: what `assemble` needs, and warnings for the user.

    Attributes:
        raw: the skeleton with the role map's units and up axis applied (and the file's own
            roles removed when a role map gives roles).
        roles: joint name -> role, for joints the file gives no role.
        warnings: unused role-map patterns, guessed chains that skipped joints.
        guess: the guess, when roles were guessed.
    """

    raw: RawSkeleton
    roles: dict[str, str]
    warnings: tuple[Issue, ...] = ()
    guess: RoleGuess | None = None


def resolve_roles(raw: RawSkeleton, role_map: str | Path | None = None) -> RoleResolution:
    """Decide every joint's role: from a role map, else from the file, else by guessing.

    A role map with `roles` replaces the file's own roles; one without `roles` only sets
    units or the up axis. Roles are guessed when neither the map nor the file gives all 39;
    roles the file does give win over guessed ones.

    Raises:
        QuadpipeError: a bad role map; `missing-roles` (with what was guessed) when guessing
            cannot place all 39 roles.
    """
    if role_map is not None:
        loaded = load_role_map(role_map)
        raw = replace(raw, units=loaded.units or raw.units, up=loaded.up or raw.up)
        if loaded.patterns is not None:
            raw = replace(raw, joints=tuple(replace(j, role=None) for j in raw.joints))
            roles, warnings = apply_role_map(raw, loaded)
            return RoleResolution(raw, roles, warnings)
    file_roles = {j.role: j.name for j in raw.joints if j.role}
    if set(ROLES) <= set(file_roles):
        return RoleResolution(raw, {})
    check_structure(raw)
    guess = guess_roles(raw)
    if any(role not in file_roles for role in guess.missing):
        raise QuadpipeError(_missing_issues(raw, guess))
    named = {j.name for j in raw.joints if j.role}
    roles = {name: role for name, role in guess.roles.items() if name not in named and role not in file_roles}
    warnings = tuple(
        Issue(
            "guessed-chain",
            f"roles guessed with joints skipped: {note}",
            raw.where(),
            "check the skipped joints; a role map (--roles) fixes the choice",
            severity="warning",
        )
        for note in guess.skips
    )
    return RoleResolution(raw, roles, warnings, guess)


def _missing_issues(raw: RawSkeleton, guess: RoleGuess) -> list[Issue]:
    shown = ", ".join(guess.missing[:12]) + (" ..." if len(guess.missing) > 12 else "")
    error = Issue(
        "missing-roles",
        f"{len(guess.missing)} of the 39 roles could not be guessed from the joints' names and layout: {shown}",
        raw.where(),
        f"`quadpipe roles {raw.source} -o roles.yaml` writes what was guessed; complete it and pass it with --roles roles.yaml",
    )
    notes = [Issue("guessed-roles", note, raw.where(), severity="note") for note in guess.notes]
    return [error, *notes]


def role_map_text(
    roles: Mapping[str, str],
    *,
    source: str | None = None,
    missing: Sequence[str] = (),
    units: str | None = None,
    up: str | None = None,
) -> str:
    """A role map YAML document giving `roles` (joint name -> role), in hierarchy order.

    Joint names are escaped so that none of them reads as a glob.
    """
    order = {role: index for index, role in enumerate(ROLES)}
    entries = sorted(roles.items(), key=lambda item: order.get(item[1], len(order)))
    header = [
        f"# Role map{f' for {Path(source).name}' if source else ''}, written by quadpipe.",
        "# Keys are joint names (shell globs, case-insensitive); values are roles (`quadpipe roles`).",
        "# Check it, then pass it with --roles.",
    ]
    if missing:
        header.append(f"# Not placed yet: {', '.join(missing)}")
    data: dict[str, Any] = {}
    if units:
        data["units"] = units
    if up:
        data["up"] = up
    data["roles"] = {_escape_glob(name): role for name, role in entries}
    return "\n".join(header) + "\n" + yaml.safe_dump(data, sort_keys=False, allow_unicode=True, width=1000)


def _escape_glob(name: str) -> str:
    return re.sub(r"([*?\[])", r"[\1]", name)


def write_role_map(path: str | Path, roles: Mapping[str, str], **options: Any) -> None:
    """Write `role_map_text(roles, **options)` to a file (atomically)."""
    from quadpipe.core.atomic import write_text

    write_text(path, role_map_text(roles, **options))
