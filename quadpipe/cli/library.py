"""Commands over the built-in library and skeleton files: animals, roles, convert, inspect,
controllers, scenes."""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from quadpipe.cli.options import (
    FormatOpt,
    LimitsOpt,
    MassOpt,
    OutputFormat,
    RestFrameOpt,
    RolesOpt,
    SourceArg,
    check_animal_name,
)
from quadpipe.cli.output import print_table, print_warnings

if TYPE_CHECKING:
    from quadpipe.animals.library import AnimalSource
    from quadpipe.animals.model import BuiltAnimal


MJCF_SUFFIXES = (".xml", ".mjcf")
"""Suffixes of the MJCF files `convert` writes."""

ROLE_MAP_SUFFIXES = (".yaml", ".yml")
"""Suffixes of the role maps `roles -o` writes."""


def announce_animal(source: AnimalSource) -> None:
    """Before simulating a skeleton file: its warnings and notes (synthesised roles, the mass
    rule), and one line with its joints, pelvis height and the mass used. Nothing for an
    animal name or config."""
    from quadpipe.animals.library import load_animal
    from quadpipe.importers import skeleton_readers

    if Path(source.source).suffix.lower() not in skeleton_readers():
        return
    animal = load_animal(source)
    print_warnings(animal.warnings)
    rig = animal.skeleton.rig
    joints = "the 39 roles" if rig is None else f"{len(rig.joints)} joints ({len(rig.extras)} extra)"
    typer.echo(f"{animal.name}: {joints}, HP {animal.pelvis_height * 100:.1f} cm, mass {animal.mass_kg:.3g} kg")


def built_animal(
    source: str, limits: Path | None, roles: Path | None, mass: float | None, rest_frame: int | None = None
) -> BuiltAnimal:
    """Resolve and build an animal, printing its warnings. A name that is not built in is refused
    before the animal library (numpy) is imported, the model builder (MuJoCo) only once the
    animal has loaded."""
    check_animal_name(source)
    from quadpipe.animals.library import resolve_animal

    animal = resolve_animal(source, limits=limits, role_map=roles, mass_kg=mass, rest_frame=rest_frame)
    print_warnings(animal.warnings)
    from quadpipe.animals.model import build_animal

    return build_animal(animal)


def animals(fmt: FormatOpt = OutputFormat.text) -> None:
    """List the built-in animals: pelvis height, mass, bones, degrees of freedom.

    Example: quadpipe animals --format json
    """
    from quadpipe.animals import report
    from quadpipe.core import configs

    rows = [report.animal_row(built_animal(name, None, None, None)) for name in configs.available("animals")]
    rows.sort(key=lambda row: -row["hp_cm"])
    if fmt is OutputFormat.json:
        typer.echo(json.dumps(rows, indent=2))
        return
    print_table(
        "Animals",
        ["name", "HP (cm)", "mass (kg)", "bones", "DOF", "radius (cm)", "step (s)"],
        [
            [
                r["name"],
                r["hp_cm"],
                r["mass_kg"],
                r["bones"],
                r["dof"],
                r["radius_cm"],
                f"1/{round(1 / r['timestep_s'])}",
            ]
            for r in rows
        ],
    )


def roles(
    skeleton: Annotated[
        Path | None, typer.Argument(help="A skeleton file (.ma, .bvh, .xml) whose roles to guess.")
    ] = None,
    output: Annotated[Path | None, typer.Option("-o", "--output", help="Write the guess as a role map YAML.")] = None,
    rest_frame: RestFrameOpt = None,
) -> None:
    """List the 39 roles; with a skeleton file, show (and write) the roles guessed for its joints.

    A guess that misses roles or fails anatomy (legs not under the trunk, a left leg on the
    right...) ends with one error listing every problem (exit 1), after the table and the
    role map, which stay for you to complete.

    Example: quadpipe roles rig.ma -o rig_roles.yaml   (then: quadpipe inspect rig.ma --roles rig_roles.yaml)
    """
    from quadpipe.anatomy.roles import PARENT, ROLES, kind_of

    if skeleton is None:
        print_table("Roles", ["role", "parent", "kind"], [[role, PARENT[role] or "-", kind_of(role)] for role in ROLES])
        return
    from quadpipe.anatomy.role_guess import guess_roles
    from quadpipe.anatomy.rolemap import write_role_map
    from quadpipe.core.errors import QuadpipeError
    from quadpipe.importers import read_raw_skeleton

    if output is not None:
        from quadpipe.core.atomic import check_writable
        from quadpipe.core.outputs import check_distinct, check_suffix

        check_distinct([("-o", output)], [("the skeleton", skeleton)])
        check_suffix("-o", output, ROLE_MAP_SUFFIXES, "a role map (YAML)")
        check_writable(output)
    raw = read_raw_skeleton(skeleton, rest_frame=rest_frame)
    print_warnings(raw.warnings)
    guess = guess_roles(raw)
    placed = guess.placement()
    print_table(
        f"Roles guessed for {skeleton}", ["role", "joint"], [[role, placed.get(role, "(not placed)")] for role in ROLES]
    )
    if output is not None:
        write_role_map(output, guess.roles, source=raw.source, missing=guess.missing, synthesised=guess.synthesised)
        typer.echo(f"wrote {output} ({len(guess.roles)} joints placed, {len(guess.missing)} roles missing)")
    issues = guess.issues(raw)
    if issues:
        raise QuadpipeError(issues)


def convert(
    source: SourceArg,
    output: Annotated[Path, typer.Option("-o", "--output", help="MJCF file to write (.xml).")],
    limits: LimitsOpt = None,
    roles: RolesOpt = None,
    mass: MassOpt = None,
    floor: Annotated[bool, typer.Option("--floor/--no-floor", help="Include a floor and a light.")] = True,
    rest_frame: RestFrameOpt = None,
) -> None:
    """Build an animal's physical model and write it as MJCF (opens in `python -m mujoco.viewer`).

    Example: quadpipe convert dog -o dog.xml
    """
    from quadpipe.core.atomic import check_writable, write_text
    from quadpipe.core.outputs import check_distinct, check_suffix

    inputs = [("the source file", Path(source)), ("the --limits file", limits), ("the --roles file", roles)]
    check_distinct([("-o", output)], [(option, path) for option, path in inputs if path is not None])
    check_suffix("-o", output, MJCF_SUFFIXES, "MJCF (XML)")
    check_writable(output)
    built = built_animal(source, limits, roles, mass, rest_frame)
    from quadpipe.world.placement import Placement, world_mjcf

    write_text(output, world_mjcf([Placement(built.animal.name, built)], floor=floor))
    typer.echo(
        f"wrote {output} ({built.animal.name}: {len(built.animal.skeleton.bones)} bones, {built.animal.mass_kg:g} kg)"
    )


def inspect(
    source: SourceArg,
    limits: LimitsOpt = None,
    roles: RolesOpt = None,
    mass: MassOpt = None,
    fmt: FormatOpt = OutputFormat.text,
    rest_frame: RestFrameOpt = None,
) -> None:
    """Show an animal's bones: roles, file names, lengths, radii, masses and joint limits.

    Limits read "twist min..max ±swing1 ±swing2" in degrees.

    Example: quadpipe inspect horse   |   quadpipe inspect rig.bvh --roles rig_roles.yaml
    """
    built = built_animal(source, limits, roles, mass, rest_frame)
    from quadpipe.animals import report

    summary, bones = report.animal_row(built), report.bone_rows(built)
    if fmt is OutputFormat.json:
        typer.echo(json.dumps({"animal": summary, "bones": bones}, indent=2))
        return
    typer.echo(
        f"{summary['name']}: HP {summary['hp_cm']} cm, {summary['mass_kg']} kg, {summary['bones']} bones, "
        f"{summary['dof']} DOF, radius {summary['radius_cm']} cm, step 1/{round(1 / summary['timestep_s'])} s"
    )
    print_table(
        "Bones",
        ["role", "name", "parent", "length (cm)", "radius (cm)", "mass (kg)", "DOF", "limits (deg)"],
        [
            [
                b["role"],
                b["name"],
                b["parent"] or "-",
                b["length_cm"],
                b["radius_cm"],
                b["mass_kg"],
                b["dof"],
                "-" if b["limits_deg"] is None else "{:g}..{:g} ±{:g} ±{:g}".format(*b["limits_deg"]),
            ]
            for b in bones
        ],
    )


def controllers(
    name: Annotated[
        str | None, typer.Argument(help="A controller (built-in name or file) whose tunables to show.")
    ] = None,
) -> None:
    """List the built-in controllers; given one, show its tunables: value, range and what each changes.

    Example: quadpipe controllers walk
    """
    from quadpipe.controllers.language import load_controller
    from quadpipe.core import configs

    if name is None:
        rows = [[name, load_controller(name).description] for name in configs.available("controllers")]
        print_table("Controllers", ["name", "description"], rows)
        return
    spec = load_controller(name)
    typer.echo(f"{spec.name}: {spec.description}")
    rows = [
        [tunable.name, tunable.value, " to ".join(map(str, tunable.limits or ())), tunable.description]
        for tunable in spec.tunables.values()
    ]
    print_table(
        f"Tunables of {spec.name} (set with --set NAME=VALUE)", ["tunable", "value", "range", "description"], rows
    )


def scenes() -> None:
    """List the built-in scenes with their descriptions.

    Example: quadpipe scenes
    """
    from quadpipe.world import available_scenes, load_scene

    print_table(
        "Scenes", ["name", "description"], [[name, load_scene(name).description] for name in available_scenes()]
    )
