"""Health checks on a MuJoCo simulation: warnings, penetration, joint-limit overshoot, blow-ups.

MuJoCo reports trouble quietly: it counts warnings in `data.warning` and, on a NaN, resets the
simulation without telling anyone. These functions make the trouble visible.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator

import mujoco
import numpy as np


@contextlib.contextmanager
def mujoco_warnings() -> Iterator[list[str]]:
    """Collect the text of MuJoCo's warnings (compiler and simulation) raised inside the block."""
    collected: list[str] = []
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(collected.append)
    try:
        yield collected
    finally:
        mujoco.set_mju_user_warning(previous)


def _ignore(message: str) -> None:
    """A MuJoCo warning handler that drops the message (its count stays in `data.warning`)."""


def keep_mujoco_quiet() -> None:
    """Stop MuJoCo printing its warnings and appending them to `MUJOCO_LOG.TXT` in the working
    folder: quadpipe reads them from `data.warning` (`warning_counts`) and reports them itself.

    A handler already set (e.g. `mujoco_warnings` collecting them) is left in place.
    """
    if mujoco.get_mju_user_warning() is None:
        mujoco.set_mju_user_warning(_ignore)


def warning_counts(data: mujoco.MjData) -> dict[str, int]:
    """Non-zero entries of `data.warning`, by warning name (e.g. `mjWARN_BADQACC`)."""
    return {
        mujoco.mjtWarning(index).name: int(data.warning[index].number)
        for index in range(mujoco.mjtWarning.mjNWARNING)
        if data.warning[index].number
    }


def max_penetration(model: mujoco.MjModel, data: mujoco.MjData, geoms: np.ndarray | None = None) -> float:
    """Deepest contact penetration in metres (0 when nothing overlaps).

    Args:
        geoms: restrict to contacts involving these geom ids (e.g. one animal's bones).
    """
    contacts = data.contact
    depth = -contacts.dist[: data.ncon]
    if geoms is not None:
        mine = np.isin(contacts.geom1[: data.ncon], geoms) | np.isin(contacts.geom2[: data.ncon], geoms)
        depth = depth[mine]
    return float(max(0.0, depth.max(initial=0.0)))


def max_limit_overshoot(model: mujoco.MjModel, data: mujoco.MjData) -> float:
    """Largest distance in radians by which a limited hinge is outside its range (0 inside)."""
    limited = np.flatnonzero(model.jnt_limited & (model.jnt_type == mujoco.mjtJoint.mjJNT_HINGE))
    if limited.size == 0:
        return 0.0
    angles = data.qpos[model.jnt_qposadr[limited]]
    low, high = model.jnt_range[limited].T
    return float(max(0.0, np.max(low - angles), np.max(angles - high)))


def is_finite(data: mujoco.MjData) -> bool:
    """Whether positions and velocities are all finite."""
    return bool(np.isfinite(data.qpos).all() and np.isfinite(data.qvel).all())
