"""Regenerate the scene format's generated files: `python -m quadpipe.world.generate`.

Rewrites `schemas/scene.schema.json` and `schemas/direction.schema.json` in the repository
this package sits in (see `schema.py`).
"""

from __future__ import annotations

from pathlib import Path

from quadpipe.world.schema import write_direction_schema, write_schema


def main() -> None:
    """Regenerate `schemas/scene.schema.json` and `schemas/direction.schema.json` in the repository this package sits in."""
    root = Path(__file__).resolve().parents[2]
    for write in (write_schema, write_direction_schema):
        print(f"wrote {write(root).relative_to(root)}")


if __name__ == "__main__":
    main()
