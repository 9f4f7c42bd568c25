"""Importers: skeleton files and joint-limit tables into the format-free core model.

Each module handles one file format; the tables below (`quadpipe.core.formats`) register its
reader by file suffix, and import the module only when a file of that format is read. To add a
format, write a module with a reader returning a `RawSkeleton` and add an entry to
`SKELETON_FORMATS`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

from quadpipe.anatomy.limits import JointLimits
from quadpipe.anatomy.role_guess import RoleGuess, guess_roles
from quadpipe.anatomy.rolemap import resolve_roles, write_role_map
from quadpipe.anatomy.skeleton import RawSkeleton, Skeleton, assemble, check_coordinates
from quadpipe.core.errors import QuadpipeError
from quadpipe.core.formats import FileFormat, FormatTable
from quadpipe.core.textfiles import missing_file

SKELETON_FORMATS = FormatTable(
    (
        FileFormat(
            (".xml",),
            f"{__name__}.quadpipe_xml",
            "read_skeleton",
            "quadpipe skeleton XML (the thesis's exchange format)",
        ),
        FileFormat((".ma",), f"{__name__}.maya_ascii", "read_skeleton", "Maya ASCII scene: its joints"),
        FileFormat((".bvh",), f"{__name__}.bvh", "read_skeleton", "BVH motion capture: its joint hierarchy"),
    )
)
"""Skeleton files: suffix -> reader returning a `RawSkeleton`."""

LIMITS_FORMATS = FormatTable(
    (FileFormat((".csv", ".tsv"), f"{__name__}.limits_table", "read_limits", "joint-limit table, thesis columns"),)
)
"""Joint-limit tables: suffix -> reader returning `JointLimits`."""


def skeleton_readers() -> FormatTable:
    """File suffix -> the skeleton format (its reader returns a `RawSkeleton`)."""
    return SKELETON_FORMATS


def _reader_for(path: Path, formats: FormatTable, what: str) -> Callable:
    fmt = formats.find(path)
    if fmt is None:
        suffix = path.suffix.lower()
        raise QuadpipeError.single(
            "unknown-format",
            f"no {what} reader for {suffix or 'files without a suffix'!r}",
            file=str(path),
            hint=f"supported: {', '.join(sorted(formats))}",
        )
    if not path.is_file():
        raise QuadpipeError([missing_file(path, what, suffixes=formats)])
    return fmt.load(path)


def read_raw_skeleton(path: str | Path) -> RawSkeleton:
    """Read any supported skeleton file, without assigning roles; its coordinates must be sane."""
    path = Path(path)
    return check_coordinates(_reader_for(path, SKELETON_FORMATS, "skeleton")(path))


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
    return _reader_for(path, LIMITS_FORMATS, "limits table")(path)


def write_guessed_role_map(skeleton_path: str | Path, out_path: str | Path) -> RoleGuess:
    """Guess the roles of a skeleton file and write them as a role map (even when incomplete).

    Returns:
        The guess, so that the caller can report what is missing.
    """
    raw = read_raw_skeleton(skeleton_path)
    guess = guess_roles(raw)
    write_role_map(out_path, guess.roles, source=raw.source, missing=guess.missing)
    return guess
