"""Arguments and options that several commands share, and the parsing of their values."""

from __future__ import annotations

from collections.abc import Sequence
from enum import Enum
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

if TYPE_CHECKING:
    from quadpipe.animals.library import AnimalSource
    from quadpipe.bodies import Look as LookName
    from quadpipe.controllers.runtime.variation import Variation
    from quadpipe.core.errors import Location


class OutputFormat(str, Enum):
    """Output formats of the listing commands."""

    text = "text"
    json = "json"


FormatOpt = Annotated[OutputFormat, typer.Option("--format", help="Output format.")]


class Look(str, Enum):
    """How animals are drawn in glTF, USD and renders (`quadpipe.bodies.LOOKS`)."""

    body = "body"
    bones = "bones"


def look_name(look: Look) -> LookName:
    """The `quadpipe.bodies.Look` an option value names."""
    return look.value


LookOpt = Annotated[
    Look, typer.Option("--look", help="Draw each animal's skinned body, or its bone capsules (glTF, USD, renders).")
]

SourceArg = Annotated[
    str,
    typer.Argument(help="An animal name (dog), an animal config (.yaml) or a skeleton file (.xml, .ma, .bvh)."),
]
LimitsOpt = Annotated[
    Path | None, typer.Option("--limits", help="Joint-limit table for a bare skeleton (default: the thesis's).")
]
RolesOpt = Annotated[Path | None, typer.Option("--roles", help="Role map YAML for a skeleton's own bone names.")]
RestFrameOpt = Annotated[
    int | None,
    typer.Option(
        "--rest-frame",
        min=0,
        help="Take frame N of the file's motion as the standing rest pose (BVH: from 0; Maya: a keyed frame).",
    ),
]


def _sane_mass(mass: float | None) -> float | None:
    """`--mass`, refused when it is not a sane body mass (see `quadpipe.core.limits.BODY_MASS_KG`)."""
    from quadpipe.core.limits import BODY_MASS_KG

    return None if mass is None else BODY_MASS_KG.check(mass, "--mass")


MassOpt = Annotated[
    float | None, typer.Option("--mass", callback=_sane_mass, help="Body mass in kg for a bare skeleton.")
]

AnimalOpt = Annotated[
    str, typer.Option("--animal", "-a", help="Animal name or config file, or a skeleton file (.ma, .bvh, .xml).")
]


class Skeleton(str, Enum):
    """Which joints a bake writes (`quadpipe.exporters.SkeletonChoice`)."""

    rig = "rig"
    roles = "roles"


SkeletonOpt = Annotated[
    Skeleton,
    typer.Option(
        "--skeleton",
        help="Write an imported rig's own joints (names, hierarchy, extra bones) or the 39 roles (glTF, USD, BVH).",
    ),
]


def animal_source(animal: str, limits: Path | None, roles: Path | None, mass: float | None) -> AnimalSource:
    """`-a` with the options that complete a skeleton file (refused, when loaded, for an animal name)."""
    from quadpipe.animals.library import AnimalSource

    return AnimalSource(animal, limits, roles, mass)


def check_animal_name(source: str) -> None:
    """Refuse an animal name that is not built in, as the animal library would (`unknown-animal`,
    naming the closest), without importing it and numpy: a source with no suffix is a name, or
    a config file's path.

    Raises:
        QuadpipeError: `unknown-animal`, or a missing file.
    """
    if not Path(source).suffix:
        from quadpipe.core import configs

        configs.find_config("animals", source)


ControllerOpt = Annotated[str, typer.Option("--controller", "-c", help="Controller name or file.")]
SceneOpt = Annotated[str, typer.Option("--scene", help="Scene name or file: terrain, props, throws, goals.")]
DirectionOpt = Annotated[
    Path | None,
    typer.Option(
        "--direction", help="Direction file (a path and beats, docs/direction.md); replaces the scene's direction."
    ),
]
SecondsOpt = Annotated[float, typer.Option("--seconds", "-s", help="Simulated time.")]
SetOpt = Annotated[
    list[str] | None, typer.Option("--set", help="Override a controller parameter: NAME=VALUE (repeatable).")
]
MetricsOpt = Annotated[Path | None, typer.Option("--metrics", help="Metrics JSON (default: beside the first output).")]
FpsOpt = Annotated[
    float,
    typer.Option("--fps", help="Recorded frames per second; must divide the physics rate (120 for most animals)."),
]
GaitReportOpt = Annotated[
    Path | None,
    typer.Option("--gait-report", help="Also write the gait analysis (as `quadpipe analyze -o`) to this JSON file."),
]
DiagramOpt = Annotated[
    Path | None, typer.Option("--diagram", help="Also draw the footfall (Hildebrand) diagram to this PNG file.")
]
VariationOpt = Annotated[
    float,
    typer.Option(
        "--variation",
        help="Natural stride-to-stride variation of the gait, 0 to 0.2 (0.03: stride times vary 3 %, left and right differ a little); 0: none.",
    ),
]
SeedOpt = Annotated[int, typer.Option("--seed", help="Seed of --variation: the same seed, the same clip.")]


def variation_of(amount: float, seed: int) -> Variation | None:
    """The `--variation` and `--seed` options, checked (None: no variation).

    Raises:
        QuadpipeError: `bad-variation`.
    """
    from quadpipe.controllers.runtime.variation import check_variation

    variation = check_variation(amount, seed, names=("--variation", "--seed"))
    return variation if variation.active else None


def parse_parameters(pairs: Sequence[str] | None) -> dict[str, str]:
    """The `--set NAME=VALUE` options as a dict.

    Raises:
        QuadpipeError: `bad-parameter` for an option that is not NAME=VALUE.
    """
    from quadpipe.core.errors import QuadpipeError

    result = {}
    for pair in pairs or []:
        name, sep, value = pair.partition("=")
        if not sep or not name.strip():
            raise QuadpipeError.single(
                "bad-parameter",
                "a parameter is given as NAME=VALUE",
                file=f"--set {pair}",
                hint='e.g. --set "pedal_force=0.2 bw"',
            )
        result[name.strip()] = value.strip()
    return result


def parameter_places(pairs: Sequence[str] | None) -> dict[str, Location]:
    """Where each `--set` value was given, for messages about it: `--set froude=2 m: error ...`."""
    from quadpipe.core.errors import Location as Given

    return {pair.partition("=")[0].strip(): Given(f"--set {pair}") for pair in pairs or []}
