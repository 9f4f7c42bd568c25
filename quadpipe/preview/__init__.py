"""The live preview: watch an animal simulate in a window while editing its controller.

`quadpipe.preview.app` holds everything the preview does, testable without a display
(`LivePreview`, `ReplayPreview`, `load_replay`, the `Clock`, overlays as numpy);
`quadpipe.preview.window` draws it with open3d and maps keys to its actions
(`open_window(preview)`). See docs/preview.md.
"""

from quadpipe.preview.app import Clock, LivePreview, OverlayLayer, Pose, ReplayPreview, Scenery, load_replay

__all__ = ["Clock", "LivePreview", "OverlayLayer", "Pose", "ReplayPreview", "Scenery", "load_replay"]
