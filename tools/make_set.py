"""Generate the shipped bumpy set, `configs/sets/bumpy.obj`: the same bytes on every run.

A 40 m x 8 m ground (x from -3 m to 37 m, y from -4 m to 4 m in quadpipe's frame) on a
regular grid of 101 x 21 vertices (4000 triangles), raised by seeded Gaussian bumps and a
gentle swell, tapered to z = 0 along its border so it meets the floor without a step. It is
written as Blender's OBJ exporter writes by default, y up (the file's x is quadpipe's left,
y up, z forward: `quadpipe.clip.kinematics.Y_UP_AXES`), in metres, faces counter-clockwise
seen from above. Usage: `python tools/make_set.py [out.obj]`.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from quadpipe.clip.kinematics import to_y_up

OUT = Path("configs/sets/bumpy.obj")
X_RANGE_M = (-3.0, 37.0)
Y_RANGE_M = (-4.0, 4.0)
VERTICES_X, VERTICES_Y = 101, 21
SEED = 15
BUMPS = 60
BUMP_HEIGHT_M = (0.02, 0.06)
"""Range of each bump's peak height, metres (the dog's pelvis height is 0.66 m)."""

BUMP_WIDTH_M = (0.6, 1.4)
"""Range of each bump's Gaussian sigma, metres."""

SWELL_M, SWELL_WAVELENGTH_M = 0.03, 9.0
"""A long swell along x on top of the bumps: amplitude and wavelength, metres."""

TAPER_M = 1.5
"""Width of the border over which the ground comes down to z = 0, metres."""


def heights(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """The ground's height at (x, y), metres: bumps and swell, tapered to 0 at the border."""
    rng = np.random.default_rng(SEED)
    z = SWELL_M * (1 - np.cos(2 * np.pi * (x - X_RANGE_M[0]) / SWELL_WAVELENGTH_M)) / 2
    for _ in range(BUMPS):
        cx, cy = rng.uniform(*X_RANGE_M), rng.uniform(*Y_RANGE_M)
        peak, sigma = rng.uniform(*BUMP_HEIGHT_M), rng.uniform(*BUMP_WIDTH_M)
        z = z + peak * np.exp(-((x - cx) ** 2 + (y - cy) ** 2) / (2 * sigma**2))
    edge = np.minimum.reduce([x - X_RANGE_M[0], X_RANGE_M[1] - x, y - Y_RANGE_M[0], Y_RANGE_M[1] - y])
    taper = np.clip(edge / TAPER_M, 0.0, 1.0)
    return z * taper * taper * (3 - 2 * taper)


def obj_text() -> str:
    """The set as OBJ text: vertices (y up, 6 decimals), then triangles."""
    x, y = np.meshgrid(np.linspace(*X_RANGE_M, VERTICES_X), np.linspace(*Y_RANGE_M, VERTICES_Y))
    points = np.stack([x, y, heights(x, y)], axis=-1).reshape(-1, 3)
    lines = ["# quadpipe bumpy set: tools/make_set.py (y up, metres)", "o bumpy"]
    lines += [f"v {a:.6f} {b:.6f} {c:.6f}" for a, b, c in to_y_up(points) + 0.0]
    for row in range(VERTICES_Y - 1):
        for column in range(VERTICES_X - 1):
            a = row * VERTICES_X + column + 1
            lines += [f"f {a} {a + 1} {a + VERTICES_X + 1}", f"f {a} {a + VERTICES_X + 1} {a + VERTICES_X}"]
    return "\n".join(lines) + "\n"


def main() -> None:
    """Write the set (to the path given, or `configs/sets/bumpy.obj`)."""
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else OUT
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(obj_text(), encoding="utf-8")
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
