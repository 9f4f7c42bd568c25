"""Contact sheets: a grid of evenly spaced frames of a clip, each stamped with its time."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from quadpipe.bodies import Look
from quadpipe.clip.model import Clip
from quadpipe.core.errors import QuadpipeError
from quadpipe.render.camera import Camera
from quadpipe.render.display import SHEET_MULTISAMPLES
from quadpipe.render.overlays import Overlay
from quadpipe.render.renderer import DEFAULT_HEIGHT, DEFAULT_WIDTH, ClipRenderer

SHEET_GRID = (4, 3)
"""Contact sheet tiles: columns, rows."""

STAMP_HEIGHT_FRACTION = 1 / 16
STAMP_MIN_PX = 10
STAMP_MARGIN_FRACTION = 0.3
STAMP_BACKGROUND = (0, 0, 0, 150)
STAMP_TEXT = (255, 255, 255, 255)
"""Time stamps on contact sheet tiles: font size (a fraction of the tile height, at least
`STAMP_MIN_PX`), margin around the text (a fraction of the font size), box and text colours."""


def check_grid(grid: tuple[int, int]) -> None:
    """Raise unless the grid has at least one column and one row.

    Raises:
        QuadpipeError: code `bad-grid`.
    """
    if len(grid) != 2 or min(grid) < 1:
        raise QuadpipeError.single(
            "bad-grid", f"contact sheet grid {tuple(grid)} needs at least 1 column and 1 row", hint="e.g. 4x3"
        )


def sheet_frames(clip: Clip, grid: tuple[int, int] = SHEET_GRID) -> np.ndarray:
    """The clip frames a contact sheet shows: evenly spaced from the first to the last."""
    count = min(grid[0] * grid[1], clip.frame_count)
    return np.round(np.linspace(0, clip.frame_count - 1, count)).astype(int)


def contact_sheet(
    clip: Clip,
    *,
    width: int = DEFAULT_WIDTH,
    height: int = DEFAULT_HEIGHT,
    camera: Camera = Camera(),
    overlays: Sequence[Overlay] | None = None,
    grid: tuple[int, int] = SHEET_GRID,
    look: Look = "body",
) -> np.ndarray:
    """A grid of evenly spaced frames, row by row, each stamped `t = 1.23 s`, as an RGB array.

    The sheet has `min(columns, tiles)` columns of `width` pixels and as many rows of `height`
    pixels as the tiles need (fewer tiles than the grid holds when the clip is that short).

    Raises:
        QuadpipeError: `bad-grid`, and those of `ClipRenderer`.
    """
    check_grid(grid)
    frames = sheet_frames(clip, grid)
    columns = min(grid[0], len(frames))
    rows = math.ceil(len(frames) / columns)
    sheet = np.zeros((rows * height, columns * width, 3), dtype=np.uint8)
    with ClipRenderer(
        clip, width=width, height=height, camera=camera, overlays=overlays, multisamples=SHEET_MULTISAMPLES, look=look
    ) as renderer:
        for tile, frame in enumerate(frames):
            row, column = divmod(tile, columns)
            picture = stamp_time(renderer.render(int(frame)), frame / clip.fps)
            sheet[row * height : (row + 1) * height, column * width : (column + 1) * width] = picture
    return sheet


def stamp_time(picture: np.ndarray, seconds: float) -> np.ndarray:
    """A copy of an RGB picture with `t = 1.23 s` written in its top-left corner."""
    from PIL import Image, ImageDraw, ImageFont

    height = picture.shape[0]
    size = max(STAMP_MIN_PX, round(height * STAMP_HEIGHT_FRACTION))
    font = ImageFont.load_default(size=size)
    image = Image.fromarray(picture).convert("RGBA")
    layer = Image.new("RGBA", image.size, (0, 0, 0, 0))
    draw = ImageDraw.Draw(layer)
    margin = round(size * STAMP_MARGIN_FRACTION)
    text = f"t = {seconds:.2f} s"
    left, top, right, bottom = draw.textbbox((2 * margin, 2 * margin), text, font=font)
    draw.rectangle((left - margin, top - margin, right + margin, bottom + margin), fill=STAMP_BACKGROUND)
    draw.text((2 * margin, 2 * margin), text, font=font, fill=STAMP_TEXT)
    return np.asarray(Image.alpha_composite(image, layer).convert("RGB"))
