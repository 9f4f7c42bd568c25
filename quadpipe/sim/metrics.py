"""The figures of a simulated clip: distance, speed, pelvis heights, falls, injected force and work."""

from __future__ import annotations

import numpy as np

from quadpipe.animals import sizing
from quadpipe.clip.model import AnimalTrack, Clip

FALL_HEIGHT_HP = 0.4
"""An animal whose pelvis drops below this many pelvis heights has fallen."""


def _injected(clip: Clip, track: AnimalTrack) -> dict[str, float]:
    """Net external force and work the controller injected (couples cancel; pulls do not)."""
    force = clip.sensors.get(f"controller_force:{track.name}")
    power = clip.sensors.get(f"controller_power:{track.name}")
    if force is None or power is None:
        return {}
    weight = track.mass_kg * sizing.GRAVITY
    return {
        "net_force_mean_bw": float(np.linalg.norm(force, axis=1).mean() / weight),
        "net_force_max_bw": float(np.linalg.norm(force, axis=1).max() / weight),
        "work_j": float(power[1:].sum() / clip.fps),
        "work_j_per_kg_m": float(
            power[1:].sum()
            / clip.fps
            / track.mass_kg
            / max(np.linalg.norm(track.positions[-1, 0, :2] - track.positions[0, 0, :2]), 1e-9)
        ),
    }


def clip_metrics(clip: Clip) -> dict:
    """Per-animal figures of a clip: distance, speed, pelvis heights, falls (lengths also in HP)."""
    animals = {}
    for track in clip.animals:
        hp = track.pelvis_height
        pelvis = track.positions[:, 0]
        travel = pelvis[-1, :2] - pelvis[0, :2]
        heights = pelvis[:, 2]
        fallen = heights < FALL_HEIGHT_HP * hp
        animals[track.name] = {
            "distance_m": float(np.linalg.norm(travel)),
            "distance_hp": float(np.linalg.norm(travel) / hp),
            "forward_hp": float(travel[0] / hp),
            "speed_m_s": float(np.linalg.norm(travel) / max(clip.duration, 1e-9)),
            "pelvis_height_min_hp": float(heights.min() / hp),
            "pelvis_height_max_hp": float(heights.max() / hp),
            "fell": bool(fallen.any()),
            "first_fall_s": float(np.argmax(fallen) / clip.fps) if fallen.any() else None,
            **_injected(clip, track),
        }
    return {"duration_s": clip.duration, "frames": clip.frame_count, "animals": animals}
