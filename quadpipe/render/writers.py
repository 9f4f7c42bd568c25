"""Render files: `render_clip` and its writers of MP4 and GIF videos and PNG contact sheets, by suffix."""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from quadpipe.bodies import Look
from quadpipe.clip.model import Clip
from quadpipe.core.atomic import atomic_path
from quadpipe.core.errors import QuadpipeError
from quadpipe.core.formats import FileFormat, FormatTable
from quadpipe.render.camera import Camera, check_camera
from quadpipe.render.overlays import Overlay
from quadpipe.render.poses import check_clip
from quadpipe.render.renderer import DEFAULT_HEIGHT, DEFAULT_WIDTH, check_size, output_frames, render_frames
from quadpipe.render.sheet import SHEET_GRID, check_grid, contact_sheet

VIDEO_CRF = 18
VIDEO_PRESET = "medium"
VIDEO_TIMEOUT_S = 600.0
"""H.264 settings: constant rate factor (lower is better; 18 looks lossless), x264 speed
preset, and how long ffmpeg may take to finish the file, seconds."""

GIF_COLOURS = 256
"""Palette size of each GIF frame (octree, no dithering: 5x faster than Pillow's default and
half the file size, with only slight banding in the sky)."""

RENDER_FORMATS = FormatTable(
    (
        FileFormat((".mp4",), __name__, "write_mp4", "H.264 video", "imageio-ffmpeg", "imageio_ffmpeg"),
        FileFormat((".gif",), __name__, "write_gif", "animated GIF", "pillow", "PIL"),
        FileFormat((".png",), __name__, "write_sheet", "contact sheet", "pillow", "PIL"),
    )
)
"""What `render_clip` writes, by file suffix; each writer takes the clip, the path and the `RenderOptions`."""


def render_clip(
    clip: Clip,
    output_path: str | Path,
    *,
    width: int = DEFAULT_WIDTH,
    height: int = DEFAULT_HEIGHT,
    fps: float | None = None,
    camera: Camera = Camera(),
    overlays: Sequence[Overlay] | None = None,
    grid: tuple[int, int] = SHEET_GRID,
    look: Look = "body",
) -> None:
    """Render a clip to a video (`.mp4`, `.gif`) or a contact sheet (`.png`), atomically.

    Args:
        clip: what to draw.
        output_path: the file; its suffix picks the format (see `RENDER_FORMATS`).
        width, height: frame size in pixels (a contact sheet's tile size; H.264 needs both even).
        fps: video frame rate; None: the clip's.
        camera: how to frame the clip.
        overlays: decorations; None: the built-in `DEFAULT_OVERLAYS` (pass [] for none).
        grid: contact sheet columns and rows.
        look: draw the animals' skinned bodies (`body`) or their bones (`bones`).

    Raises:
        QuadpipeError: `unknown-format`, `format-unavailable`, `unwritable-output`, `bad-size`, `bad-fps`,
            `bad-grid`, `bad-overlay`, `bad-camera`, `empty-clip`, `no-animal`,
            `no-finite-frame`, `no-headless-gl`.
    """
    path = Path(output_path)
    suffix = path.suffix.lower()
    writer = render_format(path).load(path)
    options = RenderOptions(width, height, fps, camera, overlays, grid, look)
    options.check(clip, suffix)
    with atomic_path(path, suffix=suffix) as temporary:
        writer(clip, temporary, options)


def render_format(path: Path) -> FileFormat:
    """The render format a path's suffix names.

    Raises:
        QuadpipeError: `unknown-format`, listing the formats.
    """
    fmt = RENDER_FORMATS.find(path)
    if fmt is None:
        raise QuadpipeError.single(
            "unknown-format",
            f"cannot render to {path.name!r}: unknown suffix {path.suffix or '(none)'!r}",
            file=str(path),
            hint=f"supported: {', '.join(f'{s} ({f.description})' for s, f in RENDER_FORMATS.items())}",
        )
    return fmt


@dataclass(frozen=True)
class RenderOptions:
    """render_clip's settings, handed to the format writers."""

    width: int
    height: int
    fps: float | None
    camera: Camera
    overlays: Sequence[Overlay] | None
    grid: tuple[int, int]
    look: Look = "body"

    def check(self, clip: Clip, suffix: str) -> None:
        """Reject settings the format cannot take, before any file is made."""
        check_clip(clip)
        check_size(self.width, self.height)
        output_frames(clip, self.fps)
        check_camera(self.camera)
        for overlay in self.overlays or ():
            overlay.check(clip.frame_count)
        if suffix == ".mp4" and (self.width % 2 or self.height % 2):
            raise QuadpipeError.single(
                "bad-size",
                f"H.264 video needs an even width and height, not {self.width}x{self.height}",
                hint="give even sizes, e.g. 640x480",
            )
        if suffix == ".png":
            check_grid(self.grid)

    def frames(self, clip: Clip) -> Iterator[np.ndarray]:
        """The rendered output frames."""
        return render_frames(
            clip,
            width=self.width,
            height=self.height,
            fps=self.fps,
            camera=self.camera,
            overlays=self.overlays,
            look=self.look,
        )

    def frame_rate(self, clip: Clip) -> float:
        """Frames per second of the output."""
        return float(self.fps or clip.fps)


def write_mp4(clip: Clip, path: Path, options: RenderOptions) -> None:
    """H.264 video (yuv420p, so every player opens it)."""
    import imageio_ffmpeg

    writer = imageio_ffmpeg.write_frames(
        str(path),
        (options.width, options.height),
        fps=options.frame_rate(clip),
        codec="libx264",
        pix_fmt_out="yuv420p",
        quality=None,
        macro_block_size=2,
        ffmpeg_log_level="error",
        ffmpeg_timeout=VIDEO_TIMEOUT_S,
        output_params=["-crf", str(VIDEO_CRF), "-preset", VIDEO_PRESET, "-movflags", "+faststart"],
    )
    writer.send(None)
    try:
        for frame in options.frames(clip):
            writer.send(np.ascontiguousarray(frame))
    finally:
        writer.close()


def write_gif(clip: Clip, path: Path, options: RenderOptions) -> None:
    """Animated GIF, looping."""
    from PIL import Image

    frames = (
        Image.fromarray(frame).quantize(GIF_COLOURS, method=Image.Quantize.FASTOCTREE, dither=Image.Dither.NONE)
        for frame in options.frames(clip)
    )
    first = next(frames)
    delay_ms = 1000.0 / options.frame_rate(clip)
    first.save(path, format="GIF", save_all=True, append_images=frames, duration=delay_ms, loop=0)


def write_sheet(clip: Clip, path: Path, options: RenderOptions) -> None:
    """Contact sheet: a grid of evenly spaced frames, each stamped with its time."""
    from PIL import Image

    sheet = contact_sheet(
        clip,
        width=options.width,
        height=options.height,
        camera=options.camera,
        overlays=options.overlays,
        grid=options.grid,
        look=options.look,
    )
    Image.fromarray(sheet).save(path, format="PNG")
