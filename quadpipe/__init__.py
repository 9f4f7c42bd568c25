"""quadpipe: quadrupeds animated by physics alone, baked into clips that load everywhere."""

__version__ = "0.1.0"
