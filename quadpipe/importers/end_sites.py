"""End sites that make no sense, flagged and not used.

Mocap and game rigs end their leaf joints with end sites that carry no anatomy: of zero
length, pointing up from a foot, or longer than the whole limb above them. Trusted, they set
the ground (HP is measured to the toes) and the length of the last bone wrongly. Such an end
is replaced by the joint's parent bone continued by half its length, kept no lower than the
lowest other point of the skeleton (the toes that carry the animal), and named in one warning.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from quadpipe.anatomy.skeleton import UP_AXES, JointRecord, RawSkeleton
from quadpipe.core.errors import Issue

ZERO_END = 1e-6
"""An end closer to its joint than this fraction of the skeleton's span has zero length."""

FOOT_BAND = 0.1
"""A joint this fraction of the skeleton's height above its lowest joint is a foot."""

CONTINUED = 0.5
"""A junk end is replaced by the parent bone continued by this fraction of its length."""


def check_end_sites(raw: RawSkeleton) -> RawSkeleton:
    """`raw` with its junk end sites replaced, and a warning naming them."""
    if not raw.joints:
        return raw
    by_name = {joint.name: joint for joint in raw.joints}
    up = UP_AXES.get(raw.up, UP_AXES["y"])
    points = np.asarray([j.position for j in raw.joints], dtype=float)
    heights = points @ up
    span = float(np.max(np.ptp(points, axis=0))) if len(points) > 1 else 0.0
    lowest, height = float(heights.min()), float(np.ptp(heights))
    flagged: list[str] = []
    joints = []
    for joint in raw.joints:
        why = _junk(joint, by_name, up, span, lowest + FOOT_BAND * height)
        if why is None:
            joints.append(joint)
            continue
        flagged.append(f"{joint.name} ({why})")
        joints.append(replace(joint, end=_replacement(joint, by_name, up, lowest)))
    if not flagged:
        return raw
    warning = Issue(
        "junk-end-sites",
        f"{len(flagged)} end site(s) make no sense and are not used: {', '.join(flagged[:8])}"
        + (" ..." if len(flagged) > 8 else ""),
        raw.where(),
        "each is replaced by its parent bone continued by half its length; fix the end sites in the file",
        severity="warning",
    )
    return replace(raw, joints=tuple(joints), warnings=(*raw.warnings, warning))


def _junk(
    joint: JointRecord, by_name: dict[str, JointRecord], up: np.ndarray, span: float, foot_level: float
) -> str | None:
    """Why a joint's end site makes no sense, or None when it does (or it has none)."""
    if joint.end is None or joint.parent is None:
        return None
    start, end = np.asarray(joint.position, float), np.asarray(joint.end, float)
    length = float(np.linalg.norm(end - start))
    if length <= ZERO_END * span:
        return "zero length"
    if float(start @ up) <= foot_level and float((end - start) @ up) > 0.5 * length:
        return "points up from a foot"
    limb = _limb_length(joint, by_name)
    if limb > 0 and length > limb:
        return f"longer than its limb, {length:.3g} > {limb:.3g}"
    return None


def _limb_length(joint: JointRecord, by_name: dict[str, JointRecord]) -> float:
    """Length of the bones from the joint up to the nearest fork (or root); 0 for a limb of
    one bone, which is too short to judge by."""
    children: dict[str, int] = {}
    for other in by_name.values():
        if other.parent is not None:
            children[other.parent] = children.get(other.parent, 0) + 1
    total, bones, current = 0.0, 0, joint
    while current.parent is not None:
        parent = by_name[current.parent]
        total += float(np.linalg.norm(np.subtract(current.position, parent.position)))
        bones += 1
        if children.get(parent.name, 0) > 1:
            break
        current = parent
    return total if bones >= 2 else 0.0


def _replacement(
    joint: JointRecord, by_name: dict[str, JointRecord], up: np.ndarray, lowest: float
) -> tuple[float, float, float]:
    """The parent bone continued by `CONTINUED` of its length, no lower than `lowest`."""
    start = np.asarray(joint.position, float)
    parent = np.asarray(by_name[joint.parent].position, float) if joint.parent else start - up
    end = start + CONTINUED * (start - parent)
    below = lowest - float(end @ up)
    if below > 0:
        end = end + below * up
    if np.linalg.norm(end - start) < 1e-12:
        end = start + CONTINUED * np.linalg.norm(start - parent) * np.cross(
            up, [1.0, 0.0, 0.0] if abs(up[0]) < 0.9 else [0.0, 1.0, 0.0]
        )
    return float(end[0]), float(end[1]), float(end[2])
