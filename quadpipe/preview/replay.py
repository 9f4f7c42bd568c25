"""Replaying a baked clip in the preview: the same clock and actions over the clip's frames."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from quadpipe.clip.model import Clip
from quadpipe.core.errors import QuadpipeError
from quadpipe.preview.base import Preview
from quadpipe.preview.clock import Clock
from quadpipe.preview.scenery import HIDDEN_BELOW_HP, OverlayLayer, Pose, clip_poses, clip_scenery, layer, pose_of

REPLAY_OVERLAYS = ("contacts", "trail")
"""Overlay layers of a replay, by name (all shown at the start; drawn by `quadpipe.render`)."""


class ReplayPreview(Preview):
    """A baked clip played on the preview clock, looping; overlays from `quadpipe.render`.

    Args:
        clip: the clip (see `load_replay`).
    """

    overlay_names = REPLAY_OVERLAYS

    def __init__(self, clip: Clip):
        from quadpipe.render import builtin_overlays

        if clip.frame_count == 0:
            raise QuadpipeError.single("empty-clip", "the clip has no frames to replay")
        super().__init__(Clock(1.0 / clip.fps))
        self.clip = clip
        self.frame = 0
        self._overlays = {overlay.name: overlay for overlay in builtin_overlays(clip, REPLAY_OVERLAYS)}
        self.scenery = clip_scenery(clip)
        self.scenery_version = 0
        self._positions, self._quaternions = clip_poses(clip)
        self._focus = self._positions[0, 0].copy()

    @property
    def time(self) -> float:
        """Time of the current frame, seconds."""
        return self.frame / self.clip.fps

    def advance(self, wall_dt: float) -> int:
        """Move on by the frames `wall_dt` wall seconds are worth, looping at the end; returns them."""
        frames = self.clock.advance(wall_dt)
        self.frame = (self.frame + frames) % self.clip.frame_count
        return frames

    def reset(self) -> None:
        """Back to the first frame."""
        self.frame = 0
        self.clock.reset()

    def pose(self) -> Pose:
        """Every scenery body's pose at the current frame."""
        hp = self.scenery.hp
        return pose_of(self._positions[self.frame], self._quaternions[self.frame], -HIDDEN_BELOW_HP * hp)

    def focus(self) -> np.ndarray:
        """The first animal's pelvis at this frame (its last finite place once it diverged)."""
        pelvis = self._positions[self.frame, 0]
        if np.isfinite(pelvis).all():
            self._focus = pelvis.copy()
        return self._focus

    def overlays(self) -> list[OverlayLayer]:
        """The shown layers at the current frame (items the clip marks NaN left out)."""
        layers = []
        for name in self.overlay_names:
            if name not in self.shown:
                continue
            overlay = self._overlays[name]
            starts = overlay.starts[self.frame]
            ends = starts if overlay.ends is None else overlay.ends[self.frame]
            keep = np.isfinite(starts).all(axis=1) & np.isfinite(ends).all(axis=1)
            layers.append(layer(name, overlay.kind, starts[keep], ends[keep], overlay.rgba))
        return layers

    def status_line(self) -> str:
        """Time, frame, clock state, and what the clip was made with."""
        meta = self.clip.metadata
        made = ", ".join(f"{key} {meta[key]}" for key in ("animal", "controller", "scene") if key in meta)
        parts = [self._clock_text(self.time), f"frame {self.frame + 1}/{self.clip.frame_count}"]
        return "  |  ".join(parts + ([made] if made else []))


REPLAY_SUFFIXES = (".npz",)
"""Clip files a preview can replay."""


def load_replay(path: str | Path) -> ReplayPreview:
    """A replay preview of a baked clip file.

    Raises:
        QuadpipeError: `unsupported-clip-format` for a suffix other than .npz, or the clip
            loader's errors (`file-not-found`, `bad-clip-file`).
    """
    from quadpipe.exporters.npz import load_clip

    path = Path(path)
    if path.suffix.lower() not in REPLAY_SUFFIXES:
        raise QuadpipeError.single(
            "unsupported-clip-format",
            f"cannot replay {str(path)!r}: previews read {', '.join(REPLAY_SUFFIXES)} clips",
            file=str(path),
            hint="bake the motion with `-o run.npz` (quadpipe simulate / bake)",
        )
    return ReplayPreview(load_clip(path))
