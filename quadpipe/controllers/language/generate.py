"""Regenerate the controller language's generated files: `python -m quadpipe.controllers.language.generate`.

Rewrites `schemas/controller.schema.json` and the reference part of `docs/controllers.md`
in the repository this package sits in (see `reference.py`).
"""

from __future__ import annotations

from pathlib import Path

from quadpipe.controllers.language.reference import write_generated


def main() -> None:
    """Write both files and say which."""
    root = Path(__file__).resolve().parents[3]
    for path in write_generated(root):
        print(f"wrote {path.relative_to(root)}")


if __name__ == "__main__":
    main()
