"""Body shape data: a species' girths and silhouette, from `configs/bodies/<species>.yaml`.

Girths are circumferences in centimetres, as measured on live animals with a tape (heart girth
behind the elbows, cannon, forearm, neck...), each with its source in the file. A cross-section
is an ellipse of the given girth whose depth (vertical, or fore-aft for a leg) is
`depth_to_width` times its width. An animal without a body file (a user's skeleton) gets the
dog's shape scaled to its pelvis height and mass (`scaled_profile`).
"""

from __future__ import annotations

import math
from pathlib import Path

from pydantic import BaseModel, ConfigDict, Field

from quadpipe.core import configs
from quadpipe.core.yamlio import load_yaml, validate_document

BODIES = "bodies"
"""The config kind (folder under configs/) holding body files."""

DEFAULT_SPECIES = "dog"
"""Whose body shape an animal without a body file borrows, scaled."""


class Ear(BaseModel):
    """An ear: a flap swept from its base on the skull to its tip."""

    model_config = ConfigDict(extra="forbid")

    length_cm: float = Field(gt=0, description="Base to tip.")
    widths_cm: tuple[float, float, float] = Field(description="Width at the base, the middle and the tip.")
    thickness_cm: float = Field(gt=0, description="Thickness of the flap.")
    elevation_deg: float = Field(description="Tip direction above the horizontal (negative: hanging).")
    spread_deg: float = Field(description="Tip direction out from the midline, seen from above.")
    back_deg: float = Field(0.0, description="Tip direction tilted back, towards the tail.")
    position: float = Field(0.15, ge=0, le=1, description="Where along the head bone the ear sits.")


class Proboscis(BaseModel):
    """A trunk hanging from the muzzle (elephant): girths from base to tip, bound to the head."""

    model_config = ConfigDict(extra="forbid")

    length_cm: float = Field(gt=0)
    girths_cm: tuple[float, float] = Field(description="Girth at the base and at the tip.")
    forward_deg: float = Field(0.0, description="Lean of the hanging trunk forwards from vertical.")


class BodyProfile(BaseModel):
    """Schema of `configs/bodies/<species>.yaml`: the shape of the body around the skeleton."""

    model_config = ConfigDict(extra="forbid")

    species: str = Field(description="The animal this shape is for (its config name).")
    coat_rgb: tuple[float, float, float] = Field(description="Plain body colour, linear RGB 0-1.")
    chest_girth_cm: float = Field(gt=0, description="Heart girth, just behind the elbows.")
    trunk_girth_ratios: tuple[float, float, float, float, float, float] = Field(
        description="Trunk girth over the hips, the three loin/belly joints, the chest and the withers, per chest girth."
    )
    trunk_depth_to_width: float = Field(gt=0, description="Trunk cross-section depth over width.")
    back_above_spine: float = Field(0.12, description="How far the back rises above the spine, per trunk depth.")
    neck_girths_cm: tuple[float, float] = Field(description="Neck girth at its base and at the throat.")
    neck_depth_to_width: float = Field(1.0, gt=0)
    head_girths_cm: tuple[float, float, float] = Field(
        description="Head girth at the skull, the cheeks and the muzzle."
    )
    head_depth_to_width: float = Field(1.0, gt=0)
    head_drop: float = Field(0.3, description="How far the head hangs below its bone, per head depth.")
    ear: Ear
    proboscis: Proboscis | None = None
    foreleg_girths_cm: tuple[float, float, float, float] = Field(
        description="Foreleg girth at the upper arm, forearm, cannon (metacarpus) and foot."
    )
    hindleg_girths_cm: tuple[float, float, float, float] = Field(
        description="Hind leg girth at the thigh, gaskin (lower thigh), cannon (metatarsus) and foot."
    )
    leg_depth_to_width: float = Field(1.1, gt=0)
    tail_girths_cm: tuple[float, float, float] = Field(description="Tail girth at the base, the middle and the tip.")


def body_profile(species: str, pelvis_height: float, mass_kg: float) -> BodyProfile:
    """The body shape of `species`: its own file if there is one, else the dog's, scaled."""
    path = configs.config_root() / BODIES / f"{species}{configs.CONFIG_SUFFIX}"
    if path.is_file():
        return load_profile(path)
    return scaled_profile(load_profile(_default_path()), pelvis_height, mass_kg)


def load_profile(path: Path) -> BodyProfile:
    """A body file, validated (errors point at the file's line).

    Raises:
        QuadpipeError: the file is not valid.
    """
    return validate_document(BodyProfile, load_yaml(path))


def _default_path() -> Path:
    return configs.config_root() / BODIES / f"{DEFAULT_SPECIES}{configs.CONFIG_SUFFIX}"


DEFAULT_PELVIS_HEIGHT_M, DEFAULT_MASS_KG = 0.6556, 30.0
"""The default species' pelvis height and mass (configs/animals/dog.yaml)."""


def scaled_profile(profile: BodyProfile, pelvis_height: float, mass_kg: float) -> BodyProfile:
    """`profile` for an animal of another size: lengths scale with the pelvis height, and
    girths also with the square root of the mass per cubed height, so the volume follows the mass."""
    length = pelvis_height / DEFAULT_PELVIS_HEIGHT_M
    girth = length * math.sqrt(mass_kg / (DEFAULT_MASS_KG * length**3))

    def scaled(values: tuple[float, ...], factor: float) -> tuple[float, ...]:
        return tuple(v * factor for v in values)

    ear = profile.ear.model_copy(
        update={
            "length_cm": profile.ear.length_cm * length,
            "widths_cm": scaled(profile.ear.widths_cm, length),
            "thickness_cm": profile.ear.thickness_cm * length,
        }
    )
    update = {
        "chest_girth_cm": profile.chest_girth_cm * girth,
        "ear": ear,
        **{
            name: scaled(getattr(profile, name), girth)
            for name in ("neck_girths_cm", "head_girths_cm", "foreleg_girths_cm", "hindleg_girths_cm", "tail_girths_cm")
        },
    }
    return profile.model_copy(update=update)
