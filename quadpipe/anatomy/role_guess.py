"""Guessing roles from a skeleton's structure when neither a role map nor the file gives them.

The hierarchy and the rest positions decide (pelvis, thorax, which chain is which leg, the tail,
the neck); joint names decide only left and right. See `guess_roles`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from quadpipe.anatomy.anatomy_check import check_anatomy
from quadpipe.anatomy.role_names import name_axial, name_end, name_side
from quadpipe.anatomy.roles import FRONT_CHAIN, HEAD_BONE, HIND_CHAIN, NECK, ROLES, SPINE, TAIL
from quadpipe.anatomy.skeleton import UP_AXES, JointRecord, RawSkeleton, reroot
from quadpipe.core.errors import Issue

MIN_BRANCHES = 3
"""A joint with this many children or more is a branch point (pelvis or thorax)."""


@dataclass(frozen=True)
class RoleGuess:
    """What `guess_roles` found.

    Attributes:
        roles: joint name -> role, for the joints it could place.
        missing: roles it could not place, in hierarchy order.
        notes: one line per decision (which joint is the pelvis, which chain is which leg
            and why), for messages and for the header of a written role map.
        skips: the notes of chains longer than their roles, where joints were skipped.
        problems: where the guess fails anatomy (`check_anatomy`): legs not under the trunk,
            left legs on the right, a fore leg named as a hind one...
    """

    roles: dict[str, str]
    missing: tuple[str, ...]
    notes: tuple[str, ...]
    skips: tuple[str, ...] = ()
    problems: tuple[Issue, ...] = ()

    def issues(self, raw: RawSkeleton) -> list[Issue]:
        """Every problem of the guess as one error's issues: the missing roles, what fails
        anatomy, then the notes on what was guessed."""
        issues: list[Issue] = []
        if self.missing:
            shown = ", ".join(self.missing[:12]) + (" ..." if len(self.missing) > 12 else "")
            issues.append(
                Issue(
                    "missing-roles",
                    f"{len(self.missing)} of the 39 roles could not be guessed from the joints' names and layout: {shown}",
                    raw.where(),
                    f"`quadpipe roles {raw.source} -o roles.yaml` writes what was guessed; "
                    "complete it and pass it with --roles roles.yaml",
                )
            )
        issues.extend(self.problems)
        if issues:
            issues.extend(Issue("guessed-roles", note, raw.where(), severity="note") for note in self.notes)
        return issues


@dataclass
class _Report:
    """Roles placed so far and the notes explaining them."""

    roles: dict[str, str] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    skips: list[str] = field(default_factory=list)

    def result(self, raw: RawSkeleton) -> RoleGuess:
        placed = set(self.roles.values())
        missing = tuple(role for role in ROLES if role not in placed)
        problems = tuple(check_anatomy(raw, self.roles))
        return RoleGuess(dict(self.roles), missing, tuple(self.notes), tuple(self.skips), problems)


@dataclass
class _Tree:
    """The joint hierarchy with the geometric helpers guessing needs."""

    raw: RawSkeleton
    by_name: dict[str, JointRecord] = field(init=False)
    children: dict[str, list[str]] = field(init=False)
    up: np.ndarray = field(init=False)
    above: set[str] = field(default_factory=set)
    """Joints that were above the root in the file (a COG or `Bip01`): never a leg or tail."""
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
        positions = [self.by_name[n].position for n in names]
        ends = [end for n in names if (end := self.by_name[n].end) is not None]
        return np.asarray(positions + ends, dtype=float)

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

    The structure decides, whatever the file's root: the pelvis and the thorax are two joints
    where three or more chains meet (counting the way toward the file's root as a chain), on
    one path (the spine); of all such pairs, the one whose other chains reach furthest (four
    legs) wins, the pelvis being the one nearer the file's root. At the pelvis, the two
    chains reaching lowest are the hind legs and the deepest other one the tail; at the
    thorax, the two lowest are the front legs and the deepest other one the neck and head
    (ending at a joint named head or skull, or where the chain forks: jaw, ears, trunk). A
    chain whose names say tail or head is never a leg. Left and right come from the joints'
    names (`L_`, `Left`, `.l`, `_R`, `Bip01 R ...`, `FL_`) when both legs of a pair say
    opposite sides, else from which side of the body they lie on. A chain follows the
    deepest child at each fork; a chain longer than its roles keeps its first and last joints
    and evenly spaced ones between. The result is checked against anatomy (`problems`).
    """
    report = _Report()
    found = _find_pelvis_and_thorax(raw)
    if found is None:
        report.notes.append(
            f"no joint has {MIN_BRANCHES} or more chains leaving it with another such joint further along "
            "one of them (pelvis -> spine -> thorax)"
        )
        return report.result(raw)
    tree, (pelvis, spine_child, thorax) = found
    report.roles[pelvis], report.roles[thorax] = "pelvis", "thorax"
    report.notes.append(f"pelvis {pelvis!r} and thorax {thorax!r}: the two joints where several chains meet")
    spine = [name for name in _path_between(tree, spine_child, thorax) if name not in tree.above]
    _fit(spine, SPINE, "spine", report)
    forward = _forward(tree, pelvis, thorax)
    hind = [c for c in tree.children[pelvis] if c != spine_child and c not in tree.above]
    _place_limbs(tree, pelvis, hind, ("lh", "rh"), HIND_CHAIN, ("tail", TAIL), forward, report)
    front = tree.children[thorax]
    neck = ("neck and head", (*NECK, HEAD_BONE))
    _place_limbs(tree, thorax, front, ("lf", "rf"), FRONT_CHAIN, neck, forward, report)
    return report.result(raw)


def _find_pelvis_and_thorax(raw: RawSkeleton) -> tuple[_Tree, tuple[str, str, str]] | None:
    """The tree re-rooted at the pelvis, and (pelvis, its child toward the thorax, thorax)."""
    depth = _file_depths(raw)
    best: tuple[tuple[float, int], _Tree, tuple[str, str, str]] | None = None
    for hub in (name for name in depth if _neighbours(raw, name) >= MIN_BRANCHES):
        tree = _Tree(reroot(raw, hub), above=_file_ancestors(raw, hub))
        for child in tree.children[hub]:
            thorax = _first_branch_below(tree, child)
            if thorax is None:
                continue
            others = [c for c in tree.children[hub] if c != child and c not in tree.above], tree.children[thorax]
            reach = sum(_two_longest(tree, hub_name, chains) for hub_name, chains in zip((hub, thorax), others))
            key = (round(reach, 6), -depth[hub])
            if best is None or key > best[0]:
                best = (key, tree, (hub, child, thorax))
    return (best[1], best[2]) if best else None


def _file_ancestors(raw: RawSkeleton, name: str) -> set[str]:
    """The joints above `name` in the file's own hierarchy."""
    parent = {joint.name: joint.parent for joint in raw.joints}
    found: set[str] = set()
    current = parent.get(name)
    while current is not None and current not in found:
        found.add(current)
        current = parent.get(current)
    return found


def _file_depths(raw: RawSkeleton) -> dict[str, int]:
    """Each joint's number of ancestors in the file."""
    parent = {joint.name: joint.parent for joint in raw.joints}
    depths: dict[str, int] = {}
    for name in parent:
        count, current = 0, parent[name]
        while current is not None and current in parent and count <= len(parent):
            count, current = count + 1, parent[current]
        depths[name] = count
    return depths


def _neighbours(raw: RawSkeleton, name: str) -> int:
    """Chains leaving a joint: its children, and its parent when it has one."""
    joint = next(j for j in raw.joints if j.name == name)
    return sum(1 for j in raw.joints if j.parent == name) + (joint.parent is not None)


def _two_longest(tree: _Tree, hub: str, chains: Sequence[str]) -> float:
    """How far the two furthest-reaching chains at a hub reach from it (legs reach furthest)."""
    centre = np.asarray(tree.by_name[hub].position, float)
    reaches = sorted(float(np.max(np.linalg.norm(tree.points(tree.subtree(c)) - centre, axis=1))) for c in chains)
    return sum(reaches[-2:])


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
    candidates = sorted(chains, key=lambda c: (_named_axial(tree, c), tree.lowest(c)))
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
        _fit(_axial_path(tree, max(rest, key=tree.depth)), axial_roles, label, report)
    else:
        report.notes.append(f"no chain left at {hub!r} for the {label}")


def _named_axial(tree: _Tree, start: str) -> bool:
    """Whether a chain's names say it is a tail or a head (so not a leg)."""
    return any(name_axial(name) is not None and name_end(name) is None for name in tree.main_path(start))


def _axial_path(tree: _Tree, start: str) -> list[str]:
    """The deepest path from `start`, ending at a joint named head or skull, else at the first
    fork (a head carrying jaw, ears or a trunk)."""
    path = tree.main_path(start)
    for index, name in enumerate(path):
        if name_axial(name) == "head" or len(tree.children[name]) >= 2:
            return path[: index + 1]
    return path


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
