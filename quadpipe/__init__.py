"""quadpipe: quadrupeds animated by physics alone, baked into clips that load everywhere."""

from quadpipe.core.version import __version__

__all__ = ["__version__"]
