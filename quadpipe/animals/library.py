"""The animal library: `configs/animals/<name>.yaml` files, and animals made from bare files.

An animal config names a skeleton file and a limits table (paths relative to the config) and
carries the thesis's pelvis height and a real body mass:

    name: dog
    skeleton: ../skeletons/dog.xml
    limits: ../limits/thesis.tsv
    pelvis_height_cm: 65.56     # thesis Fig. 6
    mass_kg: 30.0               # Labrador, breed standard 25-36 kg
    gaits:                      # the species' repertoire: Froude ranges, cited
      walk: {froude: [0, 0.6]}
      trot: {froude: [0.35, 3]}
      gallop: {froude: [2, 5], sequence: rotary}
    walk_fold: 1                # share of the runners' swing fold at a walk (the elephant's small), cited
    upright: 1                  # galloped on straight legs by auto_gait and direct (the rat's 0: crouched)
    tail_lift_deg: 20           # each tail joint carried this far above its rest angle in motion, cited

The repertoire, the swing fold, the upright carriage and the tail's lift reach the controllers as parameters they may declare (see
`repertoire_parameters`), and a gait controller the species does not use runs with a warning
(`gait_warning`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Literal, get_args

from pydantic import BaseModel, ConfigDict, Field, model_validator

from quadpipe.anatomy.limits import JointLimit
from quadpipe.anatomy.skeleton import Skeleton
from quadpipe.core import configs
from quadpipe.core.errors import Issue, Location, QuadpipeError
from quadpipe.core.limits import BODY_MASS_KG, PELVIS_HEIGHT_CM
from quadpipe.core.textfiles import missing_file
from quadpipe.core.yamlio import Name, YamlDocument, load_yaml, validate_document

MASS_EXPONENT = 1.0 / 0.35
"""Body mass grows as size^(1/0.35) = size^2.86: across mammals from shrews to the elephant, limb
bone lengths grow as M^0.35 (Alexander, Jayes, Maloiy & Wathuta 1979, "Allometry of the limb
bones of mammals from shrews (Sorex) to elephant (Loxodonta)", J. Zool. 189: 305-314)."""

MASS_AT_ONE_METRE_KG = 226.0
"""The mass of a mammal whose pelvis stands 1 m high under that rule: the constant that best fits
(least squares in log mass) the nine built-in animals' cited masses and thesis pelvis heights
(the rat left out: the thesis's rat skeleton is not to scale). It predicts them within a factor
1.5 (rms); the dog, tall for its mass, comes out at 68 kg rather than 30."""

DEFAULT_WALK_FOLD = 1.0
DEFAULT_UPRIGHT = 1.0
"""The walk's swing fold, as a share of the runners' (`locomotion`'s `fold_angle`), of an animal
whose config gives none or made from bare files: the dog's, all of it."""

DEFAULT_TAIL_LIFT_DEG = 0.0
"""An animal whose config gives no tail lift carries its tail in its rest shape."""

MAX_TAIL_LIFT_DEG = 40.0
"""The most a tail joint can be lifted: the thesis's tail limit (configs/limits/thesis.tsv)."""

HP_MISMATCH_WARNING = 0.05
"""Warn when the skeleton's pelvis height differs from the config's by more than 5 %."""


GaitName = Literal["walk", "amble", "trot", "pace", "canter", "gallop", "bound", "half_bound"]
"""The gaits an animal config may list, slowest first (each but `half_bound` has a controller of its name)."""

GAIT_NAMES: tuple[str, ...] = get_args(GaitName)
"""The gait names, in `GaitName` order."""


class GaitUse(BaseModel):
    """One gait of a species' repertoire (`gaits:` in an animal config)."""

    model_config = ConfigDict(extra="forbid")

    froude: tuple[float, float] = Field(
        description="Froude numbers (v^2 / (g HP)) over which the species uses the gait, [from, to]; "
        "where two gaits' ranges overlap, `auto_gait` blends one into the other."
    )
    sequence: Literal["transverse", "rotary"] | None = Field(
        None,
        description="For a gallop: transverse (the fore pair lands in the hind pair's left/right order) or rotary.",
    )

    @model_validator(mode="after")
    def _ordered(self) -> GaitUse:
        low, high = self.froude
        if not 0 <= low < high < math.inf:
            raise ValueError(f"froude: [{low}, {high}] is not a range of finite Froude numbers from low to high")
        return self


def default_gaits() -> dict[GaitName, GaitUse]:
    """The repertoire of an animal whose config lists none, or made from bare files: a walk."""
    return {"walk": GaitUse(froude=(0.0, 0.6), sequence=None)}


class AnimalConfig(BaseModel):
    """Schema of `configs/animals/<name>.yaml`."""

    model_config = ConfigDict(extra="forbid")

    name: Name = Field(description="Name of the animal, as used on the command line.")
    skeleton: str = Field(description="Skeleton file (.xml, .ma, .bvh), relative to this file.")
    limits: str = Field(description="Joint-limit table (.tsv, .csv), relative to this file.")
    roles: str | None = Field(None, description="Role map YAML for skeletons whose names are not roles.")
    pelvis_height_cm: float = Field(description="The thesis's HP: pelvis height in centimetres.")
    mass_kg: float = Field(description="Real adult body mass in kilograms; the model weighs this.")
    description: str = Field("", description="One line for `quadpipe animals`.")
    gaits: dict[GaitName, GaitUse] = Field(
        default_factory=default_gaits,
        description="The species' gaits and the Froude numbers it uses them at (default: a walk).",
    )
    walk_fold: float = Field(
        DEFAULT_WALK_FOLD,
        ge=0.0,
        le=1.0,
        description="How far the gait controllers fold the elbow and carpus (knee and hock) in mid-swing at a "
        "walk, as a share of how far at running speeds (`fold_angle`, 90 deg): all of it for a dog or a horse, "
        "a third for an elephant, which swings its legs little bent.",
    )
    upright: float = Field(
        DEFAULT_UPRIGHT,
        ge=0.0,
        le=1.0,
        description="How far `auto_gait` and `direct` carry the species on straight, weight-bearing legs at a gallop "
        "(1), rather than on the crouched legs of a small mammal (0: Biewener 1989, Science 245:45); at a walk and a "
        "trot every species' legs bear weight, the crouched one's with `trot`'s values for it.",
    )
    tail_lift_deg: float = Field(
        DEFAULT_TAIL_LIFT_DEG,
        ge=0.0,
        le=MAX_TAIL_LIFT_DEG,
        description="How far the gait controllers carry each tail joint above its rest angle, degrees: a dog, a "
        "cat or a lion carries its tail out or up in motion, a horse or a cow lets it hang (0, its rest shape).",
    )


@dataclass(frozen=True)
class Animal:
    """Everything the model builder needs about one animal.

    Attributes:
        name: the animal's name.
        skeleton: the rest-pose skeleton, in metres.
        limits: joint limits for every jointed role.
        pelvis_height: HP in metres (drives radius, masses and contact softness).
        mass_kg: total body mass.
        source: the config or skeleton file it came from.
        warnings: non-fatal issues (unplaced joints, HP mismatch).
        gaits: the species' repertoire, slowest gait first (a walk for an animal made from bare files).
        gaits_at: where the repertoire was written (its config's `gaits:`), for messages.
        walk_fold: how far the legs fold in mid-swing at a walk, as a share of the runners' fold.
        walk_fold_at: where the walk's fold was written (its config's `walk_fold:`).
        upright: how far `auto_gait` and `direct` gallop it on straight, weight-bearing legs.
        upright_at: where that was written (its config's `upright:`).
        tail_lift_deg: how far each tail joint is carried above its rest angle in motion, degrees.
        tail_lift_at: where that was written (its config's `tail_lift_deg:`).
    """

    name: str
    skeleton: Skeleton
    limits: dict[str, JointLimit]
    pelvis_height: float
    mass_kg: float
    source: str
    warnings: tuple[Issue, ...] = ()
    gaits: Mapping[GaitName, GaitUse] = field(default_factory=default_gaits)
    gaits_at: Location | None = None
    walk_fold: float = DEFAULT_WALK_FOLD
    walk_fold_at: Location | None = None
    upright: float = DEFAULT_UPRIGHT
    upright_at: Location | None = None
    tail_lift_deg: float = DEFAULT_TAIL_LIFT_DEG
    tail_lift_at: Location | None = None


def load_animal(name_or_path: str | Path | AnimalSource) -> Animal:
    """Load a built-in animal by name, an animal config file or a skeleton file by path, or an
    `AnimalSource` (a skeleton file with its options; see `resolve_animal`).

    Raises:
        QuadpipeError: unknown name (listing the valid ones), bad config, bad skeleton or
            limits file.
    """
    from quadpipe.importers import load_limits, load_skeleton, skeleton_readers

    if isinstance(name_or_path, AnimalSource):
        given = name_or_path
        return resolve_animal(given.source, limits=given.limits, role_map=given.roles, mass_kg=given.mass_kg)
    if Path(str(name_or_path)).suffix.lower() in skeleton_readers():
        return resolve_animal(name_or_path)

    path = configs.find_config("animals", name_or_path)
    doc = load_yaml(path, "animal", AnimalConfig)
    config = validate_document(AnimalConfig, doc)
    PELVIS_HEIGHT_CM.check(config.pelvis_height_cm, "pelvis_height_cm", where=doc.locate(("pelvis_height_cm",)))
    BODY_MASS_KG.check(config.mass_kg, "mass_kg", where=doc.locate(("mass_kg",)))
    skeleton_path, limits_path = (
        _named_file(doc, key, what) for key, what in (("skeleton", "skeleton"), ("limits", "limits table"))
    )
    roles_path = _named_file(doc, "roles", "role map") if config.roles else None
    skeleton = load_skeleton(skeleton_path, roles_path)
    limits = load_limits(limits_path).resolve()
    hp = config.pelvis_height_cm / 100.0
    warnings = list(skeleton.warnings)
    if abs(skeleton.pelvis_height - hp) > HP_MISMATCH_WARNING * hp:
        warnings.append(
            Issue(
                "hp-mismatch",
                f"the skeleton's pelvis stands {skeleton.pelvis_height * 100:.1f} cm high, the config says {config.pelvis_height_cm} cm",
                doc.locate(("pelvis_height_cm",)),
                "sizes follow the config's value; fix whichever is wrong",
                severity="warning",
            )
        )
    gaits = {name: config.gaits[name] for name in get_args(GaitName) if name in config.gaits}
    return Animal(
        config.name,
        skeleton,
        limits,
        hp,
        config.mass_kg,
        str(path),
        tuple(warnings),
        gaits,
        doc.locate(("gaits",)),
        config.walk_fold,
        doc.locate(("walk_fold",)),
        config.upright,
        doc.locate(("upright",)),
        config.tail_lift_deg,
        doc.locate(("tail_lift_deg",)),
    )


def _named_file(doc: YamlDocument, key: str, what: str) -> Path:
    """The file an animal config names under `key` (relative to the config), which must exist.

    Raises:
        QuadpipeError: `file-not-found` at the config's line that names it.
    """
    name = str(doc.data[key])
    path = Path(doc.file).parent / name
    if not path.is_file():
        issue = missing_file(
            path, what, name=name, where=doc.locate((key,)), hint="the path is relative to this animal config's folder"
        )
        looked = f" (looked for {str(path)!r})" if issue.code == "file-not-found" else ""
        raise QuadpipeError([replace(issue, message=f"{key}: {issue.message}{looked}")])
    return path


def animal_from_files(
    skeleton_path: str | Path,
    limits_path: str | Path,
    role_map: str | Path | None = None,
    mass_kg: float | None = None,
    rest_frame: int | None = None,
) -> Animal:
    """Make an animal from a bare skeleton file and limits table (no config); `rest_frame`
    takes that frame of the file's motion as the rest pose (see `load_skeleton`).

    HP is read off the skeleton; without a mass, the animal weighs what the mammal body-size
    rule gives for its pelvis height (`mammal_mass`), and a note says so.
    """
    from quadpipe.importers import load_limits, load_skeleton

    skeleton = load_skeleton(skeleton_path, role_map, rest_frame=rest_frame)
    limits = load_limits(limits_path).resolve()
    hp = skeleton.pelvis_height
    warnings = skeleton.warnings
    if mass_kg is None:
        mass_kg = mammal_mass(hp)
        warnings += (mass_note(hp, mass_kg, str(skeleton_path)),)
    else:
        BODY_MASS_KG.check(mass_kg, "mass_kg")
    return Animal(skeleton.name, skeleton, limits, hp, mass_kg, str(skeleton_path), warnings)


def mammal_mass(pelvis_height: float) -> float:
    """Body mass in kg of a mammal whose pelvis stands `pelvis_height` metres high:
    `MASS_AT_ONE_METRE_KG * HP^MASS_EXPONENT` (see those constants for the sources)."""
    return MASS_AT_ONE_METRE_KG * pelvis_height**MASS_EXPONENT


def mass_note(pelvis_height: float, mass_kg: float, source: str) -> Issue:
    """The note that says which mass a skeleton without `--mass` was given, and by which rule."""
    return Issue(
        "default-mass",
        f"mass {mass_kg:.3g} kg for a pelvis height of {pelvis_height * 100:.1f} cm, by the mammal "
        f"body-size rule M = {MASS_AT_ONE_METRE_KG:g} kg x (HP / 1 m)^{MASS_EXPONENT:.2f} "
        "(limb lengths ~ M^0.35, Alexander et al. 1979, J. Zool. 189:305)",
        Location(source),
        "give the real mass with --mass KG",
        severity="note",
    )


@dataclass(frozen=True)
class AnimalSource:
    """An animal as the command line names it: a built-in name, an animal config, or a
    skeleton file with the options that complete it (`-a rig.ma --roles map.yaml --mass 25`).

    Attributes:
        source: the name or file.
        limits: limits table for a skeleton file (default: the thesis's).
        roles: role map for a skeleton file.
        mass_kg: body mass for a skeleton file (default: `mammal_mass`).
    """

    source: str
    limits: str | Path | None = None
    roles: str | Path | None = None
    mass_kg: float | None = None

    def __str__(self) -> str:
        return self.source


def default_limits_path() -> Path:
    """The thesis's limits table shipped with quadpipe."""
    return configs.config_root() / "limits" / "thesis.tsv"


def resolve_animal(
    source: str | Path,
    *,
    limits: str | Path | None = None,
    role_map: str | Path | None = None,
    mass_kg: float | None = None,
    rest_frame: int | None = None,
) -> Animal:
    """An animal from a built-in name, an animal config (.yaml) or a bare skeleton file.

    Args:
        source: `dog`, `configs/animals/dog.yaml`, or `rig.ma` / `rig.bvh` / `rig.xml`.
        limits: limits table for a bare skeleton (default: the thesis's table).
        role_map: role map for a bare skeleton.
        mass_kg: body mass for a bare skeleton (default: `mammal_mass` of its pelvis height).
        rest_frame: for a bare skeleton, the frame of its motion to take as the rest pose.
    """
    from quadpipe.importers import skeleton_readers

    suffix = Path(str(source)).suffix.lower()
    readers = skeleton_readers()
    if suffix in readers:
        return animal_from_files(source, limits or default_limits_path(), role_map, mass_kg, rest_frame)
    if suffix and suffix not in (configs.CONFIG_SUFFIX, ".yml"):
        raise QuadpipeError.single(
            "unknown-format",
            f"{str(source)!r} is neither an animal config nor a skeleton format quadpipe reads",
            file=str(source),
            hint=f"skeleton formats: {', '.join(sorted(readers))}; animal configs: .yaml; or an animal name",
        )
    options: dict[str, object] = {
        "--limits": limits,
        "--roles": role_map,
        "--mass": mass_kg,
        "--rest-frame": rest_frame,
    }
    _refuse_skeleton_options(source, options)
    return load_animal(source)


_CONFIG_KEY_OF_OPTION = {"--limits": "limits", "--roles": "roles", "--mass": "mass_kg", "--rest-frame": "skeleton"}
"""The animal config key that sets what each option for a bare skeleton sets."""


def _refuse_skeleton_options(source: str | Path, options: dict[str, object]) -> None:
    """Refuse the options for a bare skeleton (named as the command line names them) given with
    an animal name or config, which would otherwise be ignored.

    Raises:
        QuadpipeError: `unknown-animal` (no such animal), or `unused-option` naming the first
            option given.
    """
    given = [name for name, value in options.items() if value is not None]
    if given:
        path = configs.find_config("animals", source)
        raise QuadpipeError.single(
            "unused-option",
            f"{given[0]} applies to a skeleton file, not to the animal {str(source)!r}",
            hint=f"set `{_CONFIG_KEY_OF_OPTION[given[0]]}:` in a copy of {path} and give that file",
        )


WALK_FOLD_PARAMETER = "walk_fold"
"""The controller parameter the species' walking swing fold is offered as (configs/controllers/locomotion.yaml)."""

UPRIGHT_PARAMETER = "upright"
"""The controller parameter the species' upright carriage is offered as (configs/controllers/auto_gait.yaml)."""

TAIL_LIFT_PARAMETER = "tail_lift"
"""The controller parameter the species' tail lift is offered as (configs/controllers/locomotion.yaml)."""

CARRIAGE_PARAMETERS = frozenset({TAIL_LIFT_PARAMETER})
"""Species parameters that change only how an animal carries itself: where the species of one
scene disagree, the controller keeps its own value (the tail in its rest shape) with a warning
(`carriage_warning`), instead of refusing the scene as for the repertoire."""


def repertoire_parameters(animal: Animal) -> dict[str, str]:
    """The species' repertoire as controller parameter values (YAML text), offered to a
    controller that declares them (`auto_gait`, `gallop`, every gait), as a scene offers its goals.

    For every gait of `GAIT_NAMES`: `uses_<gait>` (1 or 0) and, for a gait it uses,
    `<gait>_froude_min` and `<gait>_froude_max`; `top_froude`, the top of the fastest;
    `gallop_rotary`, 1 for a rotary gallop (0 for a transverse one or none); `walk_fold`,
    how far its legs fold in mid-swing at a walk (a share of the runners' fold); and
    `upright`, how far `auto_gait` carries it on straight, weight-bearing legs; `tail_lift`,
    how far each tail joint is carried above its rest angle.
    """
    values = {f"uses_{name}": "1" if name in animal.gaits else "0" for name in GAIT_NAMES}
    for name, use in animal.gaits.items():
        values[f"{name}_froude_min"], values[f"{name}_froude_max"] = (f"{froude:g}" for froude in use.froude)
    values["top_froude"] = f"{max(use.froude[1] for use in animal.gaits.values()):g}"
    gallop = animal.gaits.get("gallop")
    values["gallop_rotary"] = "1" if gallop is not None and gallop.sequence == "rotary" else "0"
    values[WALK_FOLD_PARAMETER] = f"{animal.walk_fold:g}"
    values[UPRIGHT_PARAMETER] = f"{animal.upright:g}"
    values[TAIL_LIFT_PARAMETER] = f"{animal.tail_lift_deg:g} deg"
    return values


def repertoire_place(animal: Animal, name: str) -> Location | None:
    """Where the animal's config wrote the value of repertoire parameter `name`, for messages."""
    places = {
        WALK_FOLD_PARAMETER: animal.walk_fold_at,
        UPRIGHT_PARAMETER: animal.upright_at,
        TAIL_LIFT_PARAMETER: animal.tail_lift_at,
    }
    return places.get(name, animal.gaits_at)


def mixed_carriage(animals: Sequence[Animal]) -> set[str]:
    """The carriage parameters (`CARRIAGE_PARAMETERS`) the animals' species offer different
    values of: one controller runs them all, so it keeps its own value of each."""
    offers = [repertoire_parameters(animal) for animal in animals]
    return {name for name in CARRIAGE_PARAMETERS if len({offer[name] for offer in offers}) > 1}


def carriage_warning(animals: Sequence[Animal]) -> Issue | None:
    """A warning when the animals' species carry their tails differently (`mixed_carriage`):
    their tails keep their rest shapes (None otherwise)."""
    if not mixed_carriage(animals):
        return None
    odd = next(animal for animal in animals if animal.tail_lift_deg != animals[0].tail_lift_deg)
    listed = ", ".join(f"{animal.name} {animal.tail_lift_deg:g} deg" for animal in animals)
    return Issue(
        "mixed-carriage",
        f"the animals' species carry their tails differently ({listed}); one controller runs them all, "
        "so every tail keeps its rest shape",
        odd.tail_lift_at or Location(odd.source),
        f"set one lift for all of them (--set {TAIL_LIFT_PARAMETER}=VALUE), or run each species in its own scene",
        severity="warning",
    )


def gait_warning(animal: Animal, controller: str) -> Issue | None:
    """A warning when `controller` is the name of a gait the species does not use (None otherwise).

    The gait runs anyway: the warning says the motion does not read as the species'.
    """
    if controller not in GAIT_NAMES or controller in animal.gaits:
        return None
    return Issue(
        "gait-not-in-repertoire",
        f"the {animal.name} does not {controller} (its gaits: {', '.join(animal.gaits)}); running it anyway",
        animal.gaits_at or Location(animal.source),
        f"its gaits are listed under `gaits:` in {animal.source}; `auto_gait` picks among them by speed",
        severity="warning",
    )
