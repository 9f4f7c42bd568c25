"""Footfall (Hildebrand) diagrams: a PNG picture with a panel per animal and a row of stance bars
per foot, over its last strides."""

from __future__ import annotations

import io
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from quadpipe.analysis.report import HILDEBRAND_ORDER, AnimalGait, GaitReport
from quadpipe.analysis.text import figure
from quadpipe.core.errors import QuadpipeError

DIAGRAM_STRIDES = 4
"""Strides shown in a footfall diagram (the last ones, the steadiest)."""

DIAGRAM_WIDTH_PX = 960
LABEL_WIDTH_PX = 56
RIGHT_MARGIN_PX = 24
TITLE_HEIGHT_PX = 52
ROW_HEIGHT_PX = 26
ROW_GAP_PX = 10
AXIS_HEIGHT_PX = 40
TICK_LENGTH_PX = 6
FONT_PX = 14
"""Layout of a footfall diagram, pixels: one panel per animal, one row per foot."""

MAX_TICKS = 12
NICE_STEPS_S = (0.05, 0.1, 0.2, 0.25, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 60.0)
"""Time axis: the smallest of these steps that needs at most `MAX_TICKS` ticks, seconds."""

BACKGROUND = (255, 255, 255)
BAR_COLOUR = (38, 84, 150)
GRID_COLOUR = (225, 225, 225)
TEXT_COLOUR = (20, 20, 20)

DIAGRAM_SUFFIXES = (".png",)


@dataclass(frozen=True)
class DiagramPanel:
    """Where one animal's footfall diagram lies in the picture, and the times it shows.

    Attributes:
        top: first pixel row of the panel.
        start_s: time at the left edge of the bars' area.
        end_s: time at its right edge.
    """

    top: int
    start_s: float
    end_s: float

    @property
    def left(self) -> int:
        """First pixel column of the bars' area."""
        return LABEL_WIDTH_PX

    @property
    def right(self) -> int:
        """Last pixel column of the bars' area."""
        return DIAGRAM_WIDTH_PX - RIGHT_MARGIN_PX - 1

    def x_of(self, seconds: float) -> float:
        """Pixel column of a time."""
        span = max(self.end_s - self.start_s, 1e-9)
        return self.left + (seconds - self.start_s) / span * (self.right - self.left)

    def row_band(self, row: int) -> tuple[int, int]:
        """First and last pixel rows of the bars of the `row`-th foot (`HILDEBRAND_ORDER`)."""
        top = self.top + TITLE_HEIGHT_PX + row * (ROW_HEIGHT_PX + ROW_GAP_PX)
        return top, top + ROW_HEIGHT_PX - 1

    @property
    def axis_y(self) -> int:
        """Pixel row of the time axis."""
        return self.top + TITLE_HEIGHT_PX + len(HILDEBRAND_ORDER) * (ROW_HEIGHT_PX + ROW_GAP_PX)


PANEL_HEIGHT_PX = TITLE_HEIGHT_PX + len(HILDEBRAND_ORDER) * (ROW_HEIGHT_PX + ROW_GAP_PX) + AXIS_HEIGHT_PX


def diagram_size(report: GaitReport) -> tuple[int, int]:
    """Width and height in pixels of the report's footfall diagram (at least one panel tall)."""
    return DIAGRAM_WIDTH_PX, PANEL_HEIGHT_PX * max(1, len(report.animals))


def diagram_panels(report: GaitReport) -> list[DiagramPanel]:
    """Each animal's panel: its last `DIAGRAM_STRIDES` whole strides, or all it has (or the clip)."""
    panels = []
    for index, animal in enumerate(report.animals):
        strides = animal.stride_frames
        if strides:
            first, last = strides[max(0, len(strides) - 1 - DIAGRAM_STRIDES)], strides[-1]
        else:
            first, last = 0, max(1, animal.frames - 1)
        panels.append(DiagramPanel(index * PANEL_HEIGHT_PX, first / animal.fps, last / animal.fps))
    return panels


def check_diagram_path(path: str | Path) -> None:
    """Raise `unsupported-diagram-format` unless the path ends in a diagram suffix (.png)."""
    suffix = Path(path).suffix.lower()
    if suffix not in DIAGRAM_SUFFIXES:
        raise QuadpipeError.single(
            "unsupported-diagram-format",
            f"cannot draw a footfall diagram as {suffix or 'a file without suffix'!r}: {str(path)!r}",
            file=str(path),
            hint="footfall diagrams are PNG pictures: name the file *.png",
        )


def footfall_diagram_png(report: GaitReport) -> bytes:
    """The footfall (Hildebrand) diagram as PNG bytes: a panel per animal, a row of stance bars per foot."""
    from PIL import Image, ImageDraw, ImageFont

    image = Image.new("RGB", diagram_size(report), BACKGROUND)
    draw = ImageDraw.Draw(image)
    font = ImageFont.load_default(size=FONT_PX)
    if not report.animals:
        draw.text((LABEL_WIDTH_PX, TITLE_HEIGHT_PX), "no animals in the clip", font=font, fill=TEXT_COLOUR)
    for animal, panel in zip(report.animals, diagram_panels(report)):
        _draw_panel(draw, font, animal, panel)
    buffer = io.BytesIO()
    image.save(buffer, format="PNG")
    return buffer.getvalue()


def draw_footfall_diagram(report: GaitReport, path: str | Path) -> None:
    """Write the footfall diagram as a PNG file, atomically.

    Raises:
        QuadpipeError: `unsupported-diagram-format`, or `unwritable-output`.
    """
    from quadpipe.core.atomic import write_bytes

    check_diagram_path(path)
    write_bytes(path, footfall_diagram_png(report))


def _draw_panel(draw: Any, font: Any, animal: AnimalGait, panel: DiagramPanel) -> None:
    _draw_title(draw, font, animal, panel)
    ticks = _ticks(panel.start_s, panel.end_s)
    bands_top, bands_bottom = panel.row_band(0)[0], panel.row_band(len(HILDEBRAND_ORDER) - 1)[1]
    for tick in ticks:
        x = round(panel.x_of(tick))
        draw.line((x, bands_top, x, bands_bottom), fill=GRID_COLOUR)
    for row, leg in enumerate(HILDEBRAND_ORDER):
        top, bottom = panel.row_band(row)
        draw.text((8, (top + bottom) / 2), leg.upper(), font=font, fill=TEXT_COLOUR, anchor="lm")
        for start, end in _stance_spans(animal, leg, panel):
            draw.rectangle((round(panel.x_of(start)), top, round(panel.x_of(end)), bottom), fill=BAR_COLOUR)
    _draw_axis(draw, font, panel, ticks)


def _draw_title(draw: Any, font: Any, animal: AnimalGait, panel: DiagramPanel) -> None:
    title = f"{animal.name} ({animal.species}): {animal.gait.label}"
    if animal.speed_m_s is not None:
        title += f", {animal.speed_m_s:.2f} m/s, Fr {animal.froude:.3f}, stride {animal.stride_period_s:.2f} s"
    duties = "duty " + "  ".join(f"{leg.upper()} {figure(animal.legs[leg].duty_factor)}" for leg in HILDEBRAND_ORDER)
    draw.text((8, panel.top + 6), title, font=font, fill=TEXT_COLOUR)
    draw.text((8, panel.top + 6 + FONT_PX + 6), duties, font=font, fill=TEXT_COLOUR)


def _draw_axis(draw: Any, font: Any, panel: DiagramPanel, ticks: list[float]) -> None:
    y = panel.axis_y
    draw.line((panel.left, y, panel.right, y), fill=TEXT_COLOUR)
    for tick in ticks:
        x = round(panel.x_of(tick))
        draw.line((x, y, x, y + TICK_LENGTH_PX), fill=TEXT_COLOUR)
        draw.text((x, y + TICK_LENGTH_PX + 2), f"{tick:g}", font=font, fill=TEXT_COLOUR, anchor="mt")
    draw.text((panel.right, y + TICK_LENGTH_PX + 2 + FONT_PX + 2), "time (s)", font=font, fill=TEXT_COLOUR, anchor="rt")


def _stance_spans(animal: AnimalGait, leg: str, panel: DiagramPanel) -> list[tuple[float, float]]:
    """Stance intervals of a foot, seconds, clipped to the panel's time span."""
    spans = []
    for footfall in animal.legs[leg].footfalls:
        start = 0.0 if footfall.touchdown_frame is None else footfall.touchdown_frame / animal.fps
        end = (
            (animal.frames - 1) / animal.fps if footfall.liftoff_frame is None else footfall.liftoff_frame / animal.fps
        )
        start, end = max(start, panel.start_s), min(end, panel.end_s)
        if end > start:
            spans.append((start, end))
    return spans


def _ticks(start: float, end: float) -> list[float]:
    """Round times between start and end, at the smallest nice step giving at most `MAX_TICKS`."""
    span = max(end - start, 1e-9)
    step = next((s for s in NICE_STEPS_S if span / s <= MAX_TICKS), NICE_STEPS_S[-1])
    first = math.ceil(start / step - 1e-9)
    last = math.floor(end / step + 1e-9)
    return [round(k * step, 6) for k in range(first, last + 1)]
