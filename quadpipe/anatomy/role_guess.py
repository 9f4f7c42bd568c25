"""Guessing roles from a skeleton's structure when neither a role map nor the file gives them.

The hierarchy and the rest positions decide (pelvis, thorax, which chain is which leg, the tail,
the neck); joint names decide only left and right. See `guess_roles`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from quadpipe.anatomy.role_names import name_side
from quadpipe.anatomy.roles import FRONT_CHAIN, HEAD_BONE, HIND_CHAIN, NECK, ROLES, SPINE, TAIL
from quadpipe.anatomy.skeleton import UP_AXES, JointRecord, RawSkeleton

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
