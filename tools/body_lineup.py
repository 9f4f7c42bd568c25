"""Render the built-in animals standing side by side, with their bodies: docs/bodies/lineup.png.

Each animal is simulated for one frame with the `rigid` controller (its rest pose), moved
sideways so that they stand in a row from the smallest to the largest, and drawn from the
front-left with a fixed camera. Usage: `python tools/body_lineup.py [out.png] [--look bones]`.
"""

from __future__ import annotations

import dataclasses
import sys

import numpy as np

from quadpipe.clip.model import Clip
from quadpipe.core import configs
from quadpipe.render import Camera, render_clip
from quadpipe.sim.simulation import simulate

GAP_M = 0.4
"""Room left between two animals, metres (plus their own half widths)."""


def lineup() -> Clip:
    """One clip, one frame: every built-in animal at rest, side by side, sorted by mass."""
    tracks = [simulate(name, "rigid", seconds=0.0).clip.animals[0] for name in configs.available("animals")]
    tracks.sort(key=lambda track: track.mass_kg)
    placed, y = [], 0.0
    for track in tracks:
        half_width = 0.5 * track.pelvis_height
        y -= half_width
        shift = np.array([-track.rest_start[0, 0], y - track.rest_start[0, 1], 0.0])
        placed.append(
            dataclasses.replace(
                track,
                name=track.species,
                positions=track.positions[:1] + shift,
                rotations=track.rotations[:1],
                rest_start=track.rest_start + shift,
                rest_end=track.rest_end + shift,
                foot_contacts=track.foot_contacts[:1],
            )
        )
        y -= half_width + GAP_M
    placed.reverse()  # the elephant first: the picture is scaled by the first animal
    return Clip(30.0, placed, terrain=simulate("dog", "rigid", seconds=0.0).clip.terrain)


def main() -> None:
    output = sys.argv[1] if len(sys.argv) > 1 else "docs/bodies/lineup.png"
    look = "bones" if "--look" in sys.argv and sys.argv[-1] == "bones" else "body"
    clip = lineup()
    middle = np.mean([track.rest_start[0] for track in clip.animals], axis=0)
    camera = Camera(
        mode="fixed", lookat=(middle[0], middle[1], 1.2), azimuth_deg=-125, elevation_deg=-12, distance_hp=4.2
    )
    render_clip(clip, output, width=1600, height=700, grid=(1, 1), overlays=[], camera=camera, look=look)
    print(f"wrote {output}")


if __name__ == "__main__":
    main()
