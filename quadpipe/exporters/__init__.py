"""Exporters: a baked `Clip` into files that Blender, Maya, usdview, game engines and three.js load.

Each module writes one family of formats; `CLIP_FORMATS` registers its writers by file suffix
(`quadpipe.core.formats`, in the spirit of trimesh's `exchange`), with the pip package a format
needs when it is optional. Modules are imported only when their format is written, and a format
whose package is missing is listed as unavailable with its install hint, failing only when it is
used. To add a format, write a module and add an entry to `CLIP_FORMATS`.

Every write is atomic (`quadpipe.core.atomic`): a failed export never leaves a partial file
behind, nor a `.gltf` without its `.bin`.

`blender_script()` is the source of `blender_import.py`, the script that imports clips into
Blender at their frame rate and range (`quadpipe blender-script`; docs/dcc.md).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Literal

import numpy as np

from quadpipe.bodies import Look, dress
from quadpipe.clip.model import Clip
from quadpipe.core.atomic import check_writable, transaction
from quadpipe.core.errors import QuadpipeError
from quadpipe.core.formats import FileFormat, FormatTable

USD_PACKAGE, USD_MODULE = "usd-core", "pxr"
"""The optional package the OpenUSD formats need, and the module it installs."""

CLIP_FORMATS = FormatTable(
    (
        FileFormat(
            (".glb",),
            f"{__name__}.gltf",
            "export_glb",
            "glTF 2.0 binary: skinned meshes, joint hierarchy, animation, props, terrain",
        ),
        FileFormat(
            (".gltf",),
            f"{__name__}.gltf",
            "export_gltf",
            "glTF 2.0 JSON with its .bin buffer beside it (same content as .glb)",
        ),
        FileFormat(
            (".usda",),
            f"{__name__}.usd",
            "export_usda",
            "OpenUSD text layer: UsdSkel animals, animated props, terrain",
            USD_PACKAGE,
            USD_MODULE,
        ),
        FileFormat(
            (".usdc",),
            f"{__name__}.usd",
            "export_usdc",
            "OpenUSD binary (crate) layer: same content as .usda",
            USD_PACKAGE,
            USD_MODULE,
        ),
        FileFormat(
            (".usdz",),
            f"{__name__}.usd",
            "export_usdz",
            "OpenUSD package: the .usdc layer in a zip, for AR Quick Look and sharing",
            USD_PACKAGE,
            USD_MODULE,
        ),
        FileFormat(
            (".bvh",),
            f"{__name__}.bvh",
            "export_bvh",
            "BVH motion capture: one animal's skeleton (cm, y up) and joint rotations per frame",
        ),
        FileFormat(
            (".npz",),
            f"{__name__}.npz",
            "export_npz",
            "Raw clip for analysis: every pose array, loadable with numpy or quadpipe",
        ),
    )
)
"""Clip files quadpipe writes: suffix -> format (each writer takes the clip and the path)."""

SkeletonChoice = Literal["rig", "roles"]
"""Which joints a clip is written on: an imported rig's own (`rig`), or the 39 roles."""

RIG_SUFFIXES = frozenset({".glb", ".gltf", ".usda", ".usdc", ".usdz", ".bvh"})
"""The formats written on a rig's own joints with `skeleton="rig"` (the npz clip keeps the roles
that analysis and rendering read)."""

MESH_SUFFIXES = frozenset({".glb", ".gltf", ".usda", ".usdc", ".usdz"})
"""The formats that hold the animals' meshes: their bodies, or their bones for `look="bones"`."""

Exporter = Callable[[Clip, Path], None]

BLENDER_SCRIPT = "blender_import.py"
"""The Blender import script shipped in this package (it runs inside Blender, on `bpy` alone)."""


def blender_script() -> str:
    """The source of the script that imports clips into Blender at their frame rate and range
    (`quadpipe blender-script` writes it out; see `quadpipe.exporters.blender_import`)."""
    return resources.files(__name__).joinpath(BLENDER_SCRIPT).read_text(encoding="utf-8")


@dataclass(frozen=True)
class ExportFormat:
    """One writable file format.

    Attributes:
        suffix: file suffix, with its dot (`.glb`).
        description: what the file holds.
        available: whether the packages it needs are installed.
        install_hint: how to make it available (`pip install usd-core`), None when it is.
    """

    suffix: str
    description: str
    available: bool
    install_hint: str | None


def supported_formats() -> list[ExportFormat]:
    """Every format quadpipe can write, available or not, sorted by suffix."""
    return [
        ExportFormat(suffix, fmt.description, fmt.available, fmt.install_hint)
        for suffix, fmt in sorted(CLIP_FORMATS.items())
    ]


def export_clip(
    clip: Clip, path: str | Path, *, allow_partial: bool = False, look: Look = "body", skeleton: SkeletonChoice = "rig"
) -> Path:
    """Write `clip` to `path`, in the format its suffix names.

    Args:
        clip: the baked simulation.
        path: the output file; its folder must exist.
        allow_partial: export a clip whose simulation did not end well (metadata `status` other
            than "ok"), keeping the frames before the first non-finite pose. Without it such a
            clip is refused.
        look: the animals' meshes in glTF and USD: their skinned bodies (`body`, built from the
            skeleton and the species' girths unless the clip carries them; see
            `quadpipe.bodies`), or their bones' shapes (`bones`).
        skeleton: `rig` writes an animal imported from a rig on the rig's own joints (names,
            hierarchy, extra bones; `quadpipe.clip.retarget`), `roles` on the 39 roles. Animals
            whose skeleton is the 39 roles are written the same either way.

    Returns:
        The path written.

    Raises:
        QuadpipeError: `unknown-format` (listing the formats), `format-unavailable` (with the
            install hint), `bad-clip` (a blown-up or empty clip), `unwritable-output`.
    """
    path = Path(path)
    writer: Exporter = _format_for(path).load(path)
    clip = _exportable(clip, allow_partial, path)
    if path.suffix.lower() in MESH_SUFFIXES:
        clip = dress(clip, look)
    if skeleton == "rig" and path.suffix.lower() in RIG_SUFFIXES:
        from quadpipe.clip.retarget import on_rigs

        clip = on_rigs(clip)
    if path.is_dir():
        raise QuadpipeError.single(
            "unwritable-output",
            f"{str(path)!r} is a folder",
            file=str(path),
            hint="give a file name, e.g. clip" + path.suffix.lower(),
        )
    try:
        with transaction():
            writer(clip, path)
    except OSError as exc:
        raise QuadpipeError.single(
            "unwritable-output",
            f"cannot write {str(path)!r}: {exc.strerror or exc}",
            file=str(path),
            hint="check that the folder exists and is writable, and that the disk is not full",
        ) from None
    return path


def check_output_path(path: str | Path) -> None:
    """Fail early, before a long simulation, if `path` cannot be written as a clip.

    Raises:
        QuadpipeError: `unknown-format`, `format-unavailable`, or `unwritable-output` (a
            folder, or a file in a folder that does not exist or is not writable).
    """
    path = Path(path)
    _format_for(path).check_available(path)
    check_writable(path)


def _format_for(path: Path) -> FileFormat:
    """The clip format a path's suffix names.

    Raises:
        QuadpipeError: `unknown-format`, listing the formats (and how to get the unavailable ones).
    """
    fmt = CLIP_FORMATS.find(path)
    if fmt is None:
        suffix = path.suffix.lower()
        raise QuadpipeError.single(
            "unknown-format",
            f"quadpipe cannot write {suffix or 'files without a suffix'!r} clips ({str(path)!r})",
            file=str(path),
            hint=_formats_hint(supported_formats()),
        )
    return fmt


def _formats_hint(formats: list[ExportFormat]) -> str:
    hint = "supported: " + ", ".join(fmt.suffix for fmt in formats if fmt.available)
    unavailable = [fmt for fmt in formats if not fmt.available]
    if unavailable:
        hint += "; unavailable: " + ", ".join(f"{fmt.suffix} ({fmt.install_hint})" for fmt in unavailable)
    return hint


def _exportable(clip: Clip, allow_partial: bool, path: Path) -> Clip:
    """The clip to write: refuse empty or blown-up clips, or trim the latter with `allow_partial`."""
    status = clip.metadata.get("status", "ok")
    if clip.frame_count == 0:
        raise QuadpipeError.single(
            "bad-clip", "the clip has no frames", file=str(path), hint="simulate at least one frame"
        )
    finite = finite_frames(clip)
    if status == "ok" and finite == clip.frame_count:
        return clip
    if not allow_partial:
        why = (
            f"the simulation did not end well ({status})"
            if status != "ok"
            else f"frame {finite} holds NaN or infinite poses"
        )
        raise QuadpipeError.single(
            "bad-clip",
            f"refusing to export a broken clip: {why}",
            file=str(path),
            hint="fix the scene or controller, or export the frames before the failure (allow_partial=True; CLI: --allow-partial)",
        )
    if finite == 0:
        raise QuadpipeError.single(
            "bad-clip", "the clip's first frame is already broken: nothing to export", file=str(path)
        )
    return _first_frames(clip, finite)


def finite_frames(clip: Clip) -> int:
    """How many leading frames have finite poses for every animal and prop."""
    arrays = [a for track in clip.animals for a in (track.positions, track.rotations)]
    arrays += [a for track in clip.props for a in (track.positions, track.rotations)]
    good = np.ones(clip.frame_count, dtype=bool)
    for array in arrays:
        good &= np.isfinite(array.reshape(clip.frame_count, -1)).all(axis=1)
    return clip.frame_count if good.all() else int(np.argmin(good))


def _first_frames(clip: Clip, count: int) -> Clip:
    """A copy of `clip` keeping its first `count` frames (metadata says so)."""
    animals = [
        dataclasses.replace(
            track,
            positions=track.positions[:count],
            rotations=track.rotations[:count],
            foot_contacts=track.foot_contacts[:count],
        )
        for track in clip.animals
    ]
    props = [
        dataclasses.replace(track, positions=track.positions[:count], rotations=track.rotations[:count])
        for track in clip.props
    ]
    metadata = {**clip.metadata, "exported_frames": f"{count} of {clip.frame_count}"}
    sensors = {name: values[:count] for name, values in clip.sensors.items()}
    return dataclasses.replace(clip, animals=animals, props=props, sensors=sensors, metadata=metadata)
