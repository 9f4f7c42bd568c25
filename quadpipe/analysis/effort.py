"""Controller effort: the net force and the work of a controller's forces, when the clip recorded them."""

from __future__ import annotations

import numpy as np

from quadpipe.analysis.report import ControllerEffort
from quadpipe.animals.sizing import GRAVITY
from quadpipe.clip.model import AnimalTrack, Clip
from quadpipe.core.errors import QuadpipeError

CONTROLLER_FORCE_SENSOR = "controller_force:{animal}"
"""Clip sensor: (F, 3) net external force the controller applied to the animal, newtons."""

CONTROLLER_POWER_SENSOR = "controller_power:{animal}"
"""Clip sensor: (F,) mechanical power of the controller's forces on the animal, watts."""


def controller_force_key(animal: str) -> str:
    """The sensor name of an animal's net controller force in `Clip.sensors`.

    The value is (F, 3): the vector sum of every Cartesian force the controller applied to the
    animal's bodies, in newtons, averaged over the physics steps that end at each frame (frame 0:
    zero). Force couples (equal and opposite forces) cancel in it; what is left is external.
    """
    return CONTROLLER_FORCE_SENSOR.format(animal=animal)


def controller_power_key(animal: str) -> str:
    """The sensor name of an animal's controller power in `Clip.sensors`.

    The value is (F,): the power of the controller's forces (each force dotted with the velocity
    of the point it acts on, summed), in watts, averaged over the physics steps that end at each
    frame (frame 0: zero), so that the work up to a frame is the sum of the values divided by fps.
    """
    return CONTROLLER_POWER_SENSOR.format(animal=animal)


def controller_effort(clip: Clip, track: AnimalTrack, frames: int, pelvis: np.ndarray) -> ControllerEffort | None:
    """What the controller's forces did to an animal over its first `frames` frames (None: not recorded).

    Args:
        pelvis: (frames, 2) horizontal pelvis path, for the work per metre travelled.

    Raises:
        QuadpipeError: `bad-clip-sensor` when a controller sensor has the wrong shape.
    """
    force = _sensor(clip, controller_force_key(track.name), (3,))
    power = _sensor(clip, controller_power_key(track.name), ())
    if force is None and power is None:
        return None
    mean_force = (
        None if force is None else float(np.linalg.norm(force[:frames], axis=1).mean() / (track.mass_kg * GRAVITY))
    )
    work = None if power is None else float(power[:frames].sum() / clip.fps)
    distance = float(np.linalg.norm(pelvis[-1] - pelvis[0])) if frames else 0.0
    per_kg_m = None if work is None or distance <= 0.0 else work / (track.mass_kg * distance)
    return ControllerEffort(mean_force, work, per_kg_m)


def _sensor(clip: Clip, key: str, item_shape: tuple[int, ...]) -> np.ndarray | None:
    if key not in clip.sensors:
        return None
    values = np.asarray(clip.sensors[key], dtype=float)
    if values.shape != (clip.frame_count, *item_shape):
        raise QuadpipeError.single(
            "bad-clip-sensor",
            f"clip sensor {key!r} has shape {values.shape}, expected {(clip.frame_count, *item_shape)}",
            hint="controller sensors hold one value per frame: (frames, 3) newtons for forces, (frames,) watts for power",
        )
    return values
