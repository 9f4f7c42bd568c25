"""Importers: skeleton files and joint-limit tables into the format-free core model.

Each module handles one file format; the tables below (`quadpipe.core.formats`) register its
reader by file suffix, and import the module only when a file of that format is read. To add a
format, write a module with a reader returning a `RawSkeleton` and add an entry to
`SKELETON_FORMATS`.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

from quadpipe.anatomy.anatomy_check import check_anatomy
from quadpipe.anatomy.limits import JointLimits
from quadpipe.anatomy.rig import assemble_rig
from quadpipe.anatomy.role_guess import RoleGuess, guess_roles
from quadpipe.anatomy.rolemap import resolve_roles, write_role_map
from quadpipe.anatomy.skeleton import RawSkeleton, Skeleton, check_coordinates, check_structure, reroot
from quadpipe.core.errors import QuadpipeError
from quadpipe.core.formats import FileFormat, FormatTable
from quadpipe.core.textfiles import missing_file
from quadpipe.importers.end_sites import check_end_sites

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


def read_raw_skeleton(path: str | Path, *, rest_frame: int | None = None, units: str | None = None) -> RawSkeleton:
    """Read any supported skeleton file, without assigning roles; its coordinates must be sane
    and its end sites make sense (`check_end_sites`).

    Args:
        path: the skeleton file; its suffix picks the reader.
        rest_frame: take frame N of the file's motion (BVH) as the rest pose.
        units: the file's length unit, for formats that do not declare one (BVH).

    Raises:
        QuadpipeError: a bad file; `no-motion` for a rest frame or unit asked of a format
            that has no motion or declares its own unit.
    """
    path = Path(path)
    reader = _reader_for(path, SKELETON_FORMATS, "skeleton")
    options = {key: value for key, value in (("rest_frame", rest_frame), ("units", units)) if value is not None}
    unknown = sorted(set(options) - set(inspect.signature(reader).parameters))
    if unknown:
        what = {"rest_frame": "no motion to take --rest-frame from", "units": "their own unit"}
        raise QuadpipeError.single(
            "no-motion",
            f"{path.suffix or path.name} files have {' and declare '.join(what[o] for o in unknown)}",
            file=str(path),
            hint="--rest-frame and units apply to BVH files; leave them out for this file",
        )
    return check_end_sites(check_coordinates(reader(path, **options)))


def load_skeleton(
    path: str | Path, role_map: str | Path | None = None, *, rest_frame: int | None = None, units: str | None = None
) -> Skeleton:
    """Read a skeleton file and assemble it, with roles from a role map, the file, or a guess.

    Whatever the file's root (a centre-of-gravity joint, Biped's `Bip01`), the skeleton is
    re-rooted at the joint playing the pelvis; the roles must pass `check_anatomy` (legs
    under the trunk, sides and fore/hind as the names say).

    Args:
        path: the skeleton file; its suffix picks the reader.
        role_map: a YAML role map (units, up axis, `name pattern -> role`); when None,
            roles come from the file, and joints without one get a guessed role.
        rest_frame: take frame N of the file's motion (BVH) as the rest pose.
        units: the file's length unit, for formats that do not declare one (BVH).

    Returns:
        The skeleton; its warnings include the role map's unused patterns and guessed
        chains that skipped joints. A rig whose joints are not simply the 39 roles (chains,
        synthesised roles, extra bones: `quadpipe.anatomy.rig`) comes with its `rig` binding.

    Raises:
        QuadpipeError: a bad file or role map, or roles that could not be placed or fail
            anatomy (every problem in one error, with what was guessed).
    """
    raw = read_raw_skeleton(path, rest_frame=rest_frame, units=units)
    resolution = resolve_roles(raw, role_map)
    first_roles = {name: role if isinstance(role, str) else role[0] for name, role in resolution.roles.items()}
    roles = {j.name: j.role for j in resolution.raw.joints if j.role} | first_roles  # a chain starts at its joint
    problems = check_anatomy(resolution.raw, roles)
    if problems:
        raise QuadpipeError(problems)
    check_structure(resolution.raw)  # no loop before re-rooting walks up the parents
    pelvis = next(name for name, role in roles.items() if role == "pelvis")
    skeleton = assemble_rig(reroot(resolution.raw, pelvis), resolution.roles, file_raw=resolution.raw)
    reader_warnings = tuple(
        w for w in raw.warnings if not (w.code == "bvh-units-guessed" and resolution.raw.units != raw.units)
    )
    return replace(skeleton, warnings=reader_warnings + resolution.warnings + skeleton.warnings)


def load_limits(path: str | Path) -> JointLimits:
    """Read a joint-limit table (CSV or TSV, thesis columns)."""
    path = Path(path)
    return _reader_for(path, LIMITS_FORMATS, "limits table")(path)


def write_guessed_role_map(
    skeleton_path: str | Path, out_path: str | Path, *, rest_frame: int | None = None
) -> RoleGuess:
    """Guess the roles of a skeleton file and write them as a role map (even when incomplete).

    Returns:
        The guess, so that the caller can report what is missing.
    """
    raw = read_raw_skeleton(skeleton_path, rest_frame=rest_frame)
    guess = guess_roles(raw)
    write_role_map(out_path, guess.roles, source=raw.source, missing=guess.missing)
    return guess
