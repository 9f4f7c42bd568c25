"""Importers: skeleton files and joint-limit tables into the format-free core model.

Each module handles one file format and ends with a table registering its readers by file
suffix (`SKELETON_READERS`, `LIMITS_READERS`); this package merges the tables. To add a
format, write a module with a reader returning a `RawSkeleton` and add it to `_MODULES`.
"""

from __future__ import annotations

from dataclasses import replace
from importlib import import_module
from pathlib import Path
from typing import Callable

from quadpipe.core.errors import QuadpipeError
from quadpipe.anatomy.limits import JointLimits
from quadpipe.anatomy.rolemap import RoleGuess, guess_roles, resolve_roles, write_role_map
from quadpipe.anatomy.skeleton import RawSkeleton, Skeleton, assemble

_MODULES = ("quadpipe_xml", "maya_ascii", "bvh", "limits_table")


def _registry(table: str) -> dict[str, Callable]:
    readers: dict[str, Callable] = {}
    for name in _MODULES:
        module = import_module(f"{__name__}.{name}")
        readers.update(getattr(module, table, {}))
    return readers


def skeleton_readers() -> dict[str, Callable[[Path], RawSkeleton]]:
    """File suffix -> reader returning a `RawSkeleton`."""
    return _registry("SKELETON_READERS")


def limits_readers() -> dict[str, Callable[[Path], JointLimits]]:
    """File suffix -> reader returning `JointLimits`."""
    return _registry("LIMITS_READERS")


def _reader_for(path: Path, readers: dict[str, Callable], what: str) -> Callable:
    suffix = path.suffix.lower()
    if suffix not in readers:
        raise QuadpipeError.single(
            "unknown-format",
            f"no {what} reader for {suffix or 'files without a suffix'!r}",
            file=str(path),
            hint=f"supported: {', '.join(sorted(readers))}",
        )
    if not path.is_file():
        raise QuadpipeError.single("file-not-found", f"{what} file {str(path)!r} does not exist", file=str(path))
    return readers[suffix]


def read_raw_skeleton(path: str | Path) -> RawSkeleton:
    """Read any supported skeleton file, without assigning roles."""
    path = Path(path)
    return _reader_for(path, skeleton_readers(), "skeleton")(path)


def load_skeleton(path: str | Path, role_map: str | Path | None = None) -> Skeleton:
    """Read a skeleton file and assemble it, with roles from a role map, the file, or a guess.

    Args:
        path: the skeleton file; its suffix picks the reader.
        role_map: a YAML role map (units, up axis, `name pattern -> role`); when None,
            roles come from the file, and joints without one get a guessed role.

    Returns:
        The skeleton; its warnings include the role map's unused patterns and guessed
        chains that skipped joints.

    Raises:
        QuadpipeError: a bad file or role map, or roles that could not be placed (the
            message says what was guessed).
    """
    resolution = resolve_roles(read_raw_skeleton(path), role_map)
    skeleton = assemble(resolution.raw, resolution.roles)
    return replace(skeleton, warnings=resolution.warnings + skeleton.warnings)


def load_limits(path: str | Path) -> JointLimits:
    """Read a joint-limit table (CSV or TSV, thesis columns)."""
    path = Path(path)
    return _reader_for(path, limits_readers(), "limits table")(path)


def write_guessed_role_map(skeleton_path: str | Path, out_path: str | Path) -> RoleGuess:
    """Guess the roles of a skeleton file and write them as a role map (even when incomplete).

    Returns:
        The guess, so that the caller can report what is missing.
    """
    raw = read_raw_skeleton(skeleton_path)
    guess = guess_roles(raw)
    write_role_map(out_path, guess.roles, source=raw.source, missing=guess.missing)
    return guess
