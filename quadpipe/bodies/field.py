"""The body's implicit surface: an approximate signed distance to each sweep, smoothly united.

Each span of a sweep is a tapered elliptical tube with rounded ends; its field at a point is
the point's elliptical radius (in units of the span's radii at the nearest point of its axis)
minus one, times the span's mean radius: about the distance to the surface near it, negative
inside. A sweep's field is the minimum over its spans; the body's is the exponential smooth
minimum of the sweeps' (`-k log sum exp(-f / k)`), which blends the neck into the chest and
the legs into the trunk over about `k`.

Skin weights come from the same fields: a surface point belongs to the spans whose surfaces are
near it, with weights falling off exponentially with the distance to each (over `falloff`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from quadpipe.bodies.sweeps import Sweep

BAND_BLENDS = 8.0
"""A sweep's field is evaluated only within this many blend widths of its bounding box; beyond,
its share of the smooth minimum (below exp(-8) = 3e-4 of the nearest one's) is dropped."""

MIN_WEIGHT = 1e-3
"""Influences weaker than this are dropped (weight 0, joint 0), the rest renormalized."""


def span_fields(sweep: Sweep, points: np.ndarray) -> np.ndarray:
    """(P, S-1) field of each span of `sweep` at `points` (metres, negative inside)."""
    a, b = sweep.centres[:-1], sweep.centres[1:]
    axis = b - a
    length2 = np.maximum(np.einsum("ij,ij->i", axis, axis), 1e-18)
    unit_axis = axis / np.sqrt(length2)[:, None]
    lateral = sweep.lateral - (unit_axis @ sweep.lateral)[:, None] * unit_axis
    lateral /= np.linalg.norm(lateral, axis=1, keepdims=True)
    depth_axis = np.cross(unit_axis, lateral)
    offset = points[:, None, :] - a[None, :, :]  # (P, S-1, 3)
    t = np.clip(np.einsum("psk,sk->ps", offset, axis) / length2, 0.0, 1.0)
    depth = sweep.depths[:-1] + t * (sweep.depths[1:] - sweep.depths[:-1])
    width = sweep.widths[:-1] + t * (sweep.widths[1:] - sweep.widths[:-1])
    rel = offset - t[..., None] * axis
    along = np.einsum("psk,sk->ps", rel, unit_axis)
    across = np.einsum("psk,sk->ps", rel, lateral)
    down = np.einsum("psk,sk->ps", rel, depth_axis)
    cap = np.sqrt(depth * width)
    radius = np.sqrt((along / cap) ** 2 + (across / width) ** 2 + (down / depth) ** 2)
    return (radius - 1.0) * cap


def sweep_bounds(sweep: Sweep) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper corners of a box holding the sweep."""
    reach = np.maximum(sweep.depths, sweep.widths)[:, None]
    return (sweep.centres - reach).min(axis=0), (sweep.centres + reach).max(axis=0)


def body_field(sweeps: Sequence[Sweep], axes: Sequence[np.ndarray], blend: float) -> np.ndarray:
    """The body's field sampled on the grid `axes` (x, y, z sample coordinates), smooth union
    of the sweeps over `blend` metres; positive far from every sweep."""
    shape = tuple(len(axis) for axis in axes)
    total = np.zeros(shape)
    for sweep in sweeps:
        low, high = sweep_bounds(sweep)
        ranges = [
            np.flatnonzero((axis >= lo - BAND_BLENDS * blend) & (axis <= hi + BAND_BLENDS * blend))
            for axis, lo, hi in zip(axes, low, high)
        ]
        if any(len(r) == 0 for r in ranges):
            continue
        grid = np.meshgrid(*(axis[r] for axis, r in zip(axes, ranges)), indexing="ij")
        points = np.stack([g.reshape(-1) for g in grid], axis=1)
        field = span_fields(sweep, points).min(axis=1)
        block = tuple(slice(r[0], r[-1] + 1) for r in ranges)
        total[block] += np.exp(-field / blend).reshape(grid[0].shape)
    with np.errstate(divide="ignore"):
        return np.where(total > 0, -blend * np.log(total), np.inf)


def skin_weights(
    sweeps: Sequence[Sweep], points: np.ndarray, bone_count: int, falloff: float, influences: int
) -> tuple[np.ndarray, np.ndarray]:
    """Each point's `influences` strongest bones and their weights (summing to 1).

    A span's pull on a point is exp(-(its field - the nearest span's field) / falloff); a bone's
    is the sum over its spans. Returns (P, influences) bone indices, strongest first, and weights
    (an unused influence has weight 0 and bone 0).
    """
    fields = np.concatenate([span_fields(sweep, points) for sweep in sweeps], axis=1)
    owners = np.concatenate([sweep.bones for sweep in sweeps])
    pull = np.exp(-(fields - fields.min(axis=1, keepdims=True)) / falloff)
    per_bone = np.zeros((len(points), bone_count))
    for column, bone in enumerate(owners):
        per_bone[:, bone] += pull[:, column]
    order = np.argsort(-per_bone, axis=1, kind="stable")[:, :influences]
    weights = np.take_along_axis(per_bone, order, axis=1)
    weights /= weights.sum(axis=1, keepdims=True)
    weak = weights < MIN_WEIGHT
    weights[weak], order[weak] = 0.0, 0
    return order, weights / weights.sum(axis=1, keepdims=True)
