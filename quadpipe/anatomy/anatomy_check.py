"""Whether roles placed on a skeleton file make an animal that stands: every problem at once.

`check_anatomy` looks at the rest pose with the roles given (guessed or from a role map):

- each leg hangs under the trunk: its lowest point lies below its top joint, within
  `MAX_LEG_TILT_DEG` of straight down (else the pose does not stand: `--rest-frame` picks a
  frame of the file's motion where it does);
- legs whose names say a side (`L_`, `Left`, `.R`) lie on that side of the body;
- legs whose names say fore or hind (`LeftArm`, `Bip01 L Thigh`, `FL_`) are placed as such;
- the head lies ahead of the thorax (else pelvis and thorax are swapped).
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from quadpipe.anatomy.role_names import name_end, name_side
from quadpipe.anatomy.roles import LEGS, ROLES, leg_of
from quadpipe.anatomy.skeleton import UP_AXES, JointRecord, RawSkeleton
from quadpipe.core.errors import Issue

MAX_LEG_TILT_DEG = 50.0
"""A standing leg's top-to-foot line leans at most this much from straight down (degrees)."""

REST_FRAME_HINT = (
    "pose the rig standing in its file, or pass --rest-frame N to take frame N of the file's motion "
    "(a frame where the animal stands on its four legs) as the rest pose"
)


def check_anatomy(raw: RawSkeleton, roles: Mapping[str, str]) -> list[Issue]:
    """Every way the placed roles fail anatomy (empty when they pass or too little is placed)."""
    joint_of = {role: joint for joint in raw.joints if (role := roles.get(joint.name) or joint.role)}
    if "pelvis" not in joint_of or "thorax" not in joint_of:
        return []
    up = UP_AXES.get(raw.up, UP_AXES["y"])
    pelvis, thorax = (np.asarray(joint_of[r].position, float) for r in ("pelvis", "thorax"))
    forward = thorax - pelvis
    forward -= forward.dot(up) * up
    if np.linalg.norm(forward) < 1e-12:
        return []
    forward /= np.linalg.norm(forward)
    left = np.cross(up, forward)
    children = _children(raw)
    issues = _standing(raw, joint_of, children, up)
    for leg in LEGS:
        issues.extend(_named_leg(raw, leg, joint_of, children, pelvis if leg.endswith("h") else thorax, left))
    head = joint_of.get("head")
    if head is not None and float((np.asarray(head.position, float) - thorax) @ forward) < 0:
        issues.append(
            Issue(
                "implausible-roles",
                f"the head {head.name!r} lies behind the thorax {joint_of['thorax'].name!r}: "
                f"pelvis {joint_of['pelvis'].name!r} and thorax look swapped",
                raw.where(head),
                "give pelvis and thorax in a role map (--roles)",
            )
        )
    return issues


def _children(raw: RawSkeleton) -> dict[str, list[JointRecord]]:
    children: dict[str, list[JointRecord]] = {}
    for joint in raw.joints:
        if joint.parent is not None:
            children.setdefault(joint.parent, []).append(joint)
    return children


def _leg_joints(
    leg: str, joint_of: Mapping[str, JointRecord], children: Mapping[str, list[JointRecord]]
) -> list[JointRecord]:
    """The joints of a leg: its top placed joint and everything under it."""
    placed = [joint_of[role] for role in ROLES if leg_of(role) == leg and role in joint_of]
    found, stack = [], placed[:1]
    while stack:
        joint = stack.pop()
        found.append(joint)
        stack.extend(children.get(joint.name, []))
    return found


def _standing(
    raw: RawSkeleton, joint_of: Mapping[str, JointRecord], children: Mapping[str, list[JointRecord]], up: np.ndarray
) -> list[Issue]:
    """One issue naming every leg that does not hang under the trunk."""
    leaning = []
    for leg in LEGS:
        joints = _leg_joints(leg, joint_of, children)
        if not joints:
            continue
        top = np.asarray(joints[0].position, float)
        points = [np.asarray(p, float) for j in joints for p in (j.position, j.end) if p is not None]
        foot = min(points, key=lambda p: float(p @ up))
        drop = foot - top
        length = float(np.linalg.norm(drop))
        if length < 1e-12:
            continue
        tilt = math.degrees(math.acos(max(-1.0, min(1.0, float(-drop @ up) / length))))
        if tilt > MAX_LEG_TILT_DEG:
            leaning.append(f"{leg} ({joints[0].name!r}) {tilt:.0f} deg")
    if not leaning:
        return []
    return [
        Issue(
            "rest-pose-not-standing",
            f"the rest pose does not stand: {len(leaning)} leg(s) do not hang under the trunk "
            f"(top joint to lowest point, from straight down; at most {MAX_LEG_TILT_DEG:g}): {', '.join(leaning)}",
            raw.where(),
            REST_FRAME_HINT,
        )
    ]


def _named_leg(
    raw: RawSkeleton,
    leg: str,
    joint_of: Mapping[str, JointRecord],
    children: Mapping[str, list[JointRecord]],
    hub: np.ndarray,
    left: np.ndarray,
) -> list[Issue]:
    """Issues where a leg's names disagree with where it was placed (side, fore or hind)."""
    joints = _leg_joints(leg, joint_of, children)
    if not joints:
        return []
    issues = []
    first = joints[0]
    sides = {side for j in joints if (side := name_side(j.name))}
    lateral = float((np.mean([j.position for j in joints], axis=0) - hub) @ left)
    lies = "left" if lateral > 0 else "right"
    if len(sides) == 1 and sides != {lies}:
        issues.append(
            Issue(
                "implausible-roles",
                f"{leg} leg {first.name!r}: its name says {next(iter(sides))} but it lies on the animal's {lies}",
                raw.where(first),
                "fix the joint names, or give the legs in a role map (--roles)",
            )
        )
    ends = {end for j in joints if (end := name_end(j.name))}
    placed = "fore" if leg.endswith("f") else "hind"
    if len(ends) == 1 and ends != {placed}:
        issues.append(
            Issue(
                "implausible-roles",
                f"{leg} leg {first.name!r}: its name says a {next(iter(ends))} leg but it hangs from the "
                f"{'thorax' if placed == 'fore' else 'pelvis'}",
                raw.where(first),
                "give the legs in a role map (--roles)",
            )
        )
    return issues
