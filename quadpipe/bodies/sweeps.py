"""The body as tubes swept along the skeleton: trunk, neck, head, ears, legs, tail (and trunk).

A `Sweep` is a tube along a polyline of stations, each with an elliptical cross-section (depth
and width radii) and each span skinned to one bone. The stations come from the rest skeleton
(joint positions) and the species' girths (`BodyProfile`): a girth and a depth-to-width ratio
give an ellipse's two radii (Ramanujan's perimeter). The body is the smooth union of the sweeps
(`quadpipe.bodies.field`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from quadpipe.anatomy.roles import FRONT_CHAIN, HIND_CHAIN, LEGS, NECK, SPINE, TAIL
from quadpipe.bodies.profile import BodyProfile, Ear

CM = 0.01

UP, LEFT = np.array([0.0, 0.0, 1.0]), np.array([0.0, 1.0, 0.0])

HEAD_STATIONS = (0.0, 0.4, 1.0)
"""Where the head's skull, cheek and muzzle girths sit along the head bone."""

FOOT_LIFT = 1.0
"""Foot sweeps are raised by this many of their depth radii, so that soles rest on the ground."""

PROBOSCIS_STATIONS = 6
"""Stations along an elephant's trunk."""


@dataclass(frozen=True)
class Sweep:
    """A tube along stations; span i (stations i, i+1) is skinned to bone `bones[i]`.

    Attributes:
        name: what it is (`trunk`, `lf_leg`, `left_ear`...).
        centres: (S, 3) station centres, metres, rest pose.
        depths: (S,) radius along the depth direction (perpendicular to the axis and `lateral`).
        widths: (S,) radius along `lateral`.
        lateral: unit direction of the width (the animal's left for most sweeps).
        bones: (S - 1,) bone index of each span.
    """

    name: str
    centres: np.ndarray
    depths: np.ndarray
    widths: np.ndarray
    lateral: np.ndarray
    bones: np.ndarray


def ellipse_radii(girth: float, depth_to_width: float) -> tuple[float, float]:
    """(depth, width) radii of the ellipse of perimeter `girth` and the given aspect."""
    h = ((depth_to_width - 1.0) / (depth_to_width + 1.0)) ** 2
    perimeter_per_width = math.pi * (depth_to_width + 1.0) * (1.0 + 3.0 * h / (10.0 + math.sqrt(4.0 - 3.0 * h)))
    width = girth / perimeter_per_width
    return depth_to_width * width, width


def body_sweeps(roles: Sequence[str], start: np.ndarray, end: np.ndarray, profile: BodyProfile) -> list[Sweep]:
    """Every sweep of an animal's body, in a fixed order.

    Args:
        roles: the bones' roles.
        start, end: (B, 3) each bone's joint and end point in the rest pose, metres.
        profile: the species' girths.
    """
    index = {role: i for i, role in enumerate(roles)}
    sweeps = [_trunk(profile, index, start, end), _neck(profile, index, start, end)]
    sweeps.append(_head(profile, index, start, end))
    sweeps += [_ear(profile.ear, sweeps[-1], side, index["head"], start, end) for side in (1.0, -1.0)]
    if profile.proboscis is not None:
        sweeps.append(_proboscis(profile, sweeps[2], index["head"]))
    for leg in LEGS:
        sweeps.append(_leg(profile, leg, index, start, end))
    sweeps.append(_tail(profile, index, start, end))
    return sweeps


def _trunk(profile: BodyProfile, index: dict[str, int], start: np.ndarray, end: np.ndarray) -> Sweep:
    """Hips to withers along pelvis, spine and thorax, hanging below the spine."""
    bones = ["pelvis", *SPINE, "thorax"]
    points = np.array([start[index[b]] for b in bones] + [end[index["thorax"]]])
    radii = [
        ellipse_radii(profile.chest_girth_cm * CM * r, profile.trunk_depth_to_width) for r in profile.trunk_girth_ratios
    ]
    depths, widths = np.array(radii).T
    centres = points - (depths * (1.0 - profile.back_above_spine))[:, None] * UP
    return Sweep("trunk", centres, depths, widths, LEFT, np.array([index[b] for b in bones]))


def _neck(profile: BodyProfile, index: dict[str, int], start: np.ndarray, end: np.ndarray) -> Sweep:
    """Withers to poll along the neck bones, girth tapering from base to throat."""
    points = np.array([start[index[b]] for b in NECK] + [end[index[NECK[-1]]]])
    fractions = _arc_fractions(points)
    girths = np.interp(fractions, [0.0, 1.0], profile.neck_girths_cm) * CM
    depths, widths = np.array([ellipse_radii(g, profile.neck_depth_to_width) for g in girths]).T
    return Sweep("neck", points, depths, widths, LEFT, np.array([index[b] for b in NECK]))


def _head(profile: BodyProfile, index: dict[str, int], start: np.ndarray, end: np.ndarray) -> Sweep:
    """Poll to nose along the head bone: skull, cheeks, muzzle; the jaw hangs below the bone."""
    head = index["head"]
    radii = np.array([ellipse_radii(g * CM, profile.head_depth_to_width) for g in profile.head_girths_cm])
    depths, widths = radii.T
    axis = end[head] - start[head]
    length = float(np.linalg.norm(axis))
    fractions = np.array(HEAD_STATIONS)
    fractions[-1] -= depths[-1] / length  # the muzzle's round end reaches the bone's end
    above = _perpendicular(UP, axis)
    centres = start[head] + fractions[:, None] * axis - (profile.head_drop * depths)[:, None] * above
    return Sweep("head", centres, depths, widths, LEFT, np.full(len(fractions) - 1, head))


def _ear(ear: Ear, head: Sweep, side: float, bone: int, start: np.ndarray, end: np.ndarray) -> Sweep:
    """An ear on one side of the skull (side +1 left, -1 right), a flap from base to tip."""
    forward = _unit(end[bone] - start[bone])
    forward = _unit(forward - forward @ LEFT * LEFT)
    base = head.centres[0] + (head.centres[1] - head.centres[0]) * (ear.position / HEAD_STATIONS[1])
    base = base + side * LEFT * head.widths[0] * 0.7 + UP * head.depths[0] * 0.6
    elevation, spread, back = (math.radians(a) for a in (ear.elevation_deg, ear.spread_deg, ear.back_deg))
    direction = (
        math.cos(elevation) * (math.sin(spread) * side * LEFT - math.cos(spread) * math.sin(back) * forward)
        + math.sin(elevation) * UP
    )
    centres = base + np.outer([0.0, 0.5, 1.0], direction) * ear.length_cm * CM
    widths = np.array(ear.widths_cm) * CM / 2.0
    depths = np.full(3, ear.thickness_cm * CM / 2.0)
    lateral = _perpendicular(forward, direction)
    return Sweep("left_ear" if side > 0 else "right_ear", centres, depths, widths, lateral, np.full(2, bone))


def _proboscis(profile: BodyProfile, head: Sweep, bone: int) -> Sweep:
    """An elephant's trunk: from the muzzle, hanging down, leaning forwards."""
    assert profile.proboscis is not None
    trunk = profile.proboscis
    lean = math.radians(trunk.forward_deg)
    forward = _unit(head.centres[-1] - head.centres[0])
    forward = _unit(forward - forward @ UP * UP)
    direction = math.sin(lean) * forward - math.cos(lean) * UP
    fractions = np.linspace(0.0, 1.0, PROBOSCIS_STATIONS)
    centres = head.centres[-1] + np.outer(fractions, direction) * trunk.length_cm * CM
    radii = np.interp(fractions, [0.0, 1.0], trunk.girths_cm) * CM / (2.0 * math.pi)
    return Sweep("proboscis", centres, radii, radii, LEFT, np.full(PROBOSCIS_STATIONS - 1, bone))


def _leg(profile: BodyProfile, leg: str, index: dict[str, int], start: np.ndarray, end: np.ndarray) -> Sweep:
    """A leg from the scapula or hip down to the toe tip, girths from the profile's four.

    The four girths sit at the joints of the second, third and fourth bones and at the toe tip
    (upper arm or thigh, forearm or gaskin, cannon, foot); the first bone (scapula, or the hip's
    femur head) keeps the first girth.
    """
    front = leg.endswith("f")
    chain = FRONT_CHAIN if front else HIND_CHAIN
    girths = profile.foreleg_girths_cm if front else profile.hindleg_girths_cm
    bones = [index[f"{leg}_{b}"] for b in chain]
    points = np.array([start[b] for b in bones] + [end[bones[-1]]])
    anchor_stations = [1, 2, 3, len(points) - 1] if front else [0, 1, 2, len(points) - 1]
    along = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])
    station_girths = np.interp(along, along[anchor_stations], girths) * CM
    depths, widths = np.array([ellipse_radii(g, profile.leg_depth_to_width) for g in station_girths]).T
    feet = slice(len(points) - 3, len(points))
    points[feet] += depths[feet, None] * FOOT_LIFT * UP
    return Sweep(f"{leg}_leg", points, depths, widths, LEFT, np.array(bones))


def _tail(profile: BodyProfile, index: dict[str, int], start: np.ndarray, end: np.ndarray) -> Sweep:
    """The tail along its four bones, girths at the base, the middle and the tip."""
    bones = [index[b] for b in TAIL]
    points = np.array([start[b] for b in bones] + [end[bones[-1]]])
    radii = np.interp(_arc_fractions(points), [0.0, 0.5, 1.0], profile.tail_girths_cm) * CM / (2.0 * math.pi)
    return Sweep("tail", points, radii, radii, LEFT, np.array(bones))


def _arc_fractions(points: np.ndarray) -> np.ndarray:
    """Each point's distance along the polyline, as a fraction of its length."""
    along = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])
    return along / along[-1]


def _unit(vector: np.ndarray) -> np.ndarray:
    return vector / np.linalg.norm(vector)


def _perpendicular(vector: Sequence[float] | np.ndarray, axis: np.ndarray) -> np.ndarray:
    """The unit part of `vector` perpendicular to `axis`."""
    axis = _unit(np.asarray(axis, dtype=float))
    vector = np.asarray(vector, dtype=float)
    return _unit(vector - (vector @ axis) * axis)
