"""The live preview: watch an animal simulate in a window while editing its controller.

Everything the preview does is testable without a display, as plain numpy:
`quadpipe.preview.live` (`LivePreview`: a simulation on the wall clock, hot reload, actions),
`quadpipe.preview.replay` (`ReplayPreview`, `load_replay`: a baked clip), `quadpipe.preview.clock`
(`Clock`), `quadpipe.preview.scenery` (shapes, poses, overlay layers), `quadpipe.preview.overlays`
(the live overlays), `quadpipe.preview.throws` (the throw pool) and `quadpipe.preview.base` (what
both modes share). `quadpipe.preview.window` draws it with open3d and maps keys to its actions
(`open_window(preview)`). See docs/preview.md.
"""

from quadpipe.preview.clock import Clock
from quadpipe.preview.live import LivePreview
from quadpipe.preview.replay import ReplayPreview, load_replay
from quadpipe.preview.scenery import OverlayLayer, Pose, Scenery

__all__ = ["Clock", "LivePreview", "OverlayLayer", "Pose", "ReplayPreview", "Scenery", "load_replay"]
