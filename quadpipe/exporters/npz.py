"""Raw clips (`.npz`): every array of a `Clip`, saved and loaded back exactly, for analysis.

A NumPy zip archive (`numpy.load` opens it; no pickles):

- `header`: a JSON string with the format name and version, fps, metadata, the names,
  species, roles, sizes and shapes of the animals, the props and the terrain, sensor names;
- `animal<i>.<field>`: `parents`, `rest_start`, `rest_end`, `positions` (F, B, 3) in metres,
  `rotations` (F, B, 4) as (w, x, y, z), `foot_contacts` (F, 4), for the i-th animal;
- `prop<i>.positions`, `prop<i>.rotations`, and `prop<i>.present` (F,) for a prop that is not
  in the scene on every frame (a thrown box before its throw); `sensor<k>` for the k-th sensor
  in the header.

All in quadpipe's frame: metres, +X forward, +Y left, +Z up. Archive members carry a fixed
timestamp, so the same clip gives the same bytes.
"""

from __future__ import annotations

import io
import json
import math
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from quadpipe.clip.model import AnimalTrack, Clip, PropTrack, Shape
from quadpipe.core.atomic import write_bytes
from quadpipe.core.errors import QuadpipeError
from quadpipe.core.limits import MAX_FPS
from quadpipe.core.textfiles import missing_file

FORMAT_NAME = "quadpipe-clip"
FORMAT_VERSION = 1

ZIP_TIMESTAMP = (1980, 1, 1, 0, 0, 0)
"""Every archive member's date: the earliest a zip can hold, so output does not depend on when."""

ANIMAL_SHAPES: dict[str, tuple[str | int, ...]] = {
    "parents": ("B",),
    "rest_start": ("B", 3),
    "rest_end": ("B", 3),
    "positions": ("F", "B", 3),
    "rotations": ("F", "B", 4),
    "foot_contacts": ("F", 4),
}
"""Each animal array's shape: F frames, B bones (the animal's roles)."""

PROP_SHAPES: dict[str, tuple[str | int, ...]] = {"positions": ("F", 3), "rotations": ("F", 4)}
"""Each prop array's shape: F frames."""

PRESENT_SHAPE: tuple[str | int, ...] = ("F",)
"""The shape of a prop's optional `present` array (absent from the archive: always present)."""

ANIMAL_ARRAYS = tuple(ANIMAL_SHAPES)
PROP_ARRAYS = tuple(PROP_SHAPES)

POSE_ARRAYS = ("rest_start", "rest_end", "positions", "rotations")
"""The arrays that must be finite: quadpipe never writes a clip with a NaN or infinite pose."""


def _shape_json(shape: Shape) -> dict[str, Any]:
    return {
        "kind": shape.kind,
        "size": list(shape.size),
        "pos": list(shape.pos),
        "quat": list(shape.quat),
        "rgba": list(shape.rgba),
    }


def _shape(data: dict[str, Any]) -> Shape:
    return Shape(data["kind"], tuple(data["size"]), tuple(data["pos"]), tuple(data["quat"]), tuple(data["rgba"]))


def _header(clip: Clip) -> dict[str, Any]:
    return {
        "format": FORMAT_NAME,
        "version": FORMAT_VERSION,
        "fps": float(clip.fps),
        "metadata": dict(clip.metadata),
        "animals": [
            {
                "name": track.name,
                "species": track.species,
                "roles": list(track.roles),
                "pelvis_height": float(track.pelvis_height),
                "mass_kg": float(track.mass_kg),
                "shapes": [[_shape_json(shape) for shape in shapes] for shapes in track.shapes],
            }
            for track in clip.animals
        ],
        "props": [{"name": p.name, "mass_kg": float(p.mass_kg), "shape": _shape_json(p.shape)} for p in clip.props],
        "terrain": [_shape_json(shape) for shape in clip.terrain],
        "sensors": list(clip.sensors),
    }


def _arrays(clip: Clip) -> dict[str, np.ndarray]:
    arrays = {"header": np.array(json.dumps(_header(clip)))}
    for i, track in enumerate(clip.animals):
        arrays.update({f"animal{i}.{name}": getattr(track, name) for name in ANIMAL_ARRAYS})
    for i, prop in enumerate(clip.props):
        arrays.update({f"prop{i}.{name}": getattr(prop, name) for name in PROP_ARRAYS})
        if prop.present is not None:
            arrays[f"prop{i}.present"] = np.asarray(prop.present, dtype=bool)
    arrays.update({f"sensor{k}": values for k, values in enumerate(clip.sensors.values())})
    return arrays


def npz_bytes(clip: Clip) -> bytes:
    """The archive's bytes."""
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", zipfile.ZIP_DEFLATED) as archive:
        for name, array in _arrays(clip).items():
            member = io.BytesIO()
            np.lib.format.write_array(member, np.asarray(array), allow_pickle=False)
            info = zipfile.ZipInfo(f"{name}.npy", date_time=ZIP_TIMESTAMP)
            info.compress_type = zipfile.ZIP_DEFLATED
            archive.writestr(info, member.getvalue())
    return buffer.getvalue()


def export_npz(clip: Clip, path: Path) -> None:
    """Raw clip for analysis: every pose array, loadable with numpy or quadpipe."""
    write_bytes(path, npz_bytes(clip))


def load_clip(path: str | Path) -> Clip:
    """Read a clip written by `export_npz`, equal to the one saved.

    Raises:
        QuadpipeError: `file-not-found`, or `bad-clip-file` for anything that is not a quadpipe
            clip archive of a version this quadpipe reads, or not a sound one (a frame rate that
            is not a positive number, no frames, arrays of mismatched shapes, non-finite poses).
    """
    path = Path(path)
    if not path.is_file():
        raise QuadpipeError([missing_file(path, "clip", suffixes=(".npz",))])
    if path.stat().st_size == 0:
        raise QuadpipeError.single(
            "bad-clip-file", f"{str(path)!r} is empty", file=str(path), hint="bake the clip again (an .npz output)"
        )
    try:
        with np.load(path, allow_pickle=False) as archive:
            header = json.loads(str(archive["header"][()]))
            _check_header(path, header)
            return _checked(path, _clip(header, archive))
    except (OSError, EOFError, ValueError, KeyError, TypeError, AttributeError, zipfile.BadZipFile) as exc:
        raise QuadpipeError.single(
            "bad-clip-file",
            f"{str(path)!r} is not a readable quadpipe clip: {exc}",
            file=str(path),
            hint="clip archives are written by `quadpipe` with an .npz output",
        ) from None


def _check_header(path: Path, header: dict[str, Any]) -> None:
    if not isinstance(header, dict) or header.get("format") != FORMAT_NAME or header.get("version") != FORMAT_VERSION:
        raise QuadpipeError.single(
            "bad-clip-file",
            f"{str(path)!r} says format {header.get('format')!r} version {header.get('version')!r}",
            file=str(path),
            hint=f"this quadpipe reads {FORMAT_NAME} version {FORMAT_VERSION}",
        )


def _checked(path: Path, clip: Clip) -> Clip:
    """`clip` when it is sound; otherwise a `bad-clip-file` error saying what is wrong."""
    problem = _clip_problem(clip)
    if problem is not None:
        raise QuadpipeError.single(
            "bad-clip-file",
            f"{str(path)!r} is a damaged clip: {problem}",
            file=str(path),
            hint="bake it again: quadpipe writes only whole clips with finite poses",
        )
    return clip


def _clip_problem(clip: Clip) -> str | None:
    """What makes a loaded clip unusable (None: nothing)."""
    fps = float(clip.fps)
    if not (math.isfinite(fps) and 0 < fps <= MAX_FPS):
        return f"its frame rate is {fps:g} frames per second"
    frames = clip.frame_count
    if frames == 0:
        return "it holds no frames"
    arrays = [
        (f"animal{i}.{name}", getattr(track, name), shape, len(track.roles))
        for i, track in enumerate(clip.animals)
        for name, shape in ANIMAL_SHAPES.items()
    ]
    arrays += [
        (f"prop{i}.{name}", getattr(track, name), shape, 0)
        for i, track in enumerate(clip.props)
        for name, shape in PROP_SHAPES.items()
    ]
    arrays += [
        (f"prop{i}.present", track.present, PRESENT_SHAPE, 0)
        for i, track in enumerate(clip.props)
        if track.present is not None
    ]
    for name, array, shape, bones in arrays:
        expected = tuple(frames if size == "F" else bones if size == "B" else size for size in shape)
        if array.shape != expected:
            return f"{name} has shape {array.shape}, where {expected} was expected ({frames} frames)"
        if name.rpartition(".")[2] in POSE_ARRAYS and not np.isfinite(array).all():
            return f"{name} holds NaN or infinite values"
    for k, (name, values) in enumerate(clip.sensors.items()):
        if values.ndim == 0 or values.shape[0] != frames:
            return f"sensor{k} ({name!r}) has shape {values.shape}, not {frames} frames"
    return None


def _clip(header: dict[str, Any], archive: Any) -> Clip:
    animals = [
        AnimalTrack(
            name=info["name"],
            species=info["species"],
            roles=tuple(info["roles"]),
            shapes=[[_shape(s) for s in shapes] for shapes in info["shapes"]],
            pelvis_height=info["pelvis_height"],
            mass_kg=info["mass_kg"],
            **{name: archive[f"animal{i}.{name}"] for name in ANIMAL_ARRAYS},
        )
        for i, info in enumerate(header["animals"])
    ]
    props = [
        PropTrack(
            name=info["name"],
            shape=_shape(info["shape"]),
            mass_kg=info["mass_kg"],
            present=archive.get(f"prop{i}.present"),
            **{name: archive[f"prop{i}.{name}"] for name in PROP_ARRAYS},
        )
        for i, info in enumerate(header["props"])
    ]
    return Clip(
        fps=header["fps"],
        animals=animals,
        props=props,
        terrain=[_shape(s) for s in header["terrain"]],
        sensors={name: archive[f"sensor{k}"] for k, name in enumerate(header["sensors"])},
        metadata=header["metadata"],
    )
