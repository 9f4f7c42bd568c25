"""Commands that turn a clip into pictures or figures, or bring it into other tools: render,
analyze, blender-script."""

from __future__ import annotations

from enum import Enum
from pathlib import Path
from typing import Annotated

import typer

from quadpipe.cli.options import (
    AnimalOpt,
    ControllerOpt,
    DirectionOpt,
    FormatOpt,
    LimitsOpt,
    Look,
    LookOpt,
    MassOpt,
    OutputFormat,
    RolesOpt,
    SceneOpt,
    SecondsOpt,
    SeedOpt,
    SetOpt,
    VariationOpt,
    animal_source,
    look_name,
    parameter_places,
    parse_parameters,
    variation_of,
)
from quadpipe.cli.output import write_gait_files


class View(str, Enum):
    """Named camera views of `quadpipe render` (`quadpipe.render.camera.VIEWS`)."""

    three_quarter = "three-quarter"
    side = "side"
    rear = "rear"
    front = "front"
    top = "top"


def render(
    outputs: Annotated[
        list[Path], typer.Option("-o", "--output", help="Video or picture: .mp4, .gif, or .png (a contact sheet).")
    ],
    clip: Annotated[Path | None, typer.Argument(help="A baked clip (.npz); without it, simulate first.")] = None,
    animal: AnimalOpt = "dog",
    controller: ControllerOpt = "walk",
    scene: SceneOpt = "flat",
    seconds: SecondsOpt = 5.0,
    parameters: SetOpt = None,
    direction: DirectionOpt = None,
    width: Annotated[int, typer.Option(help="Frame width in pixels.")] = 640,
    height: Annotated[int, typer.Option(help="Frame height in pixels.")] = 480,
    overlays: Annotated[
        str, typer.Option(help="Overlays to draw: contacts,trail,path (a directed clip's path) or none.")
    ] = "contacts,trail,path",
    look: LookOpt = Look.body,
    limits: LimitsOpt = None,
    roles: RolesOpt = None,
    mass: MassOpt = None,
    view: Annotated[
        View, typer.Option("--view", help="Where the camera looks from, for an animal heading +x.")
    ] = View.three_quarter,
    variation: VariationOpt = 0.0,
    seed: SeedOpt = 0,
) -> None:
    """Render a clip headless (MuJoCo's renderer) to MP4, GIF, or a PNG contact sheet.

    Example: quadpipe render run.npz -o run.mp4 -o sheet.png --view side   |   quadpipe render --controller spine_walk --scene hill -o walk.mp4   |   quadpipe render --controller direct --direction shot.yaml -s 12 -o shot.mp4

    Without a clip, the animal is simulated first (`--direction` plays a direction file, and
    the `path` overlay draws it); a clip carries the direction it was baked with.
    """
    from quadpipe.core.atomic import check_writable, transaction
    from quadpipe.core.outputs import check_distinct
    from quadpipe.render import builtin_overlays, render_clip, view_camera
    from quadpipe.render.writers import render_format

    check_distinct([("-o", output) for output in outputs], [("the clip", clip)] if clip is not None else [])
    camera = view_camera(view.value)
    varied = variation_of(variation, seed)
    for output in outputs:
        render_format(output)
        check_writable(output)
    if clip is not None:
        from quadpipe.exporters.npz import load_clip

        baked = load_clip(clip)
    else:
        from quadpipe.cli.library import announce_animal
        from quadpipe.sim.simulation import simulate as run_simulation

        source = animal_source(animal, limits, roles, mass)
        announce_animal(source)
        baked = run_simulation(
            source,
            controller,
            seconds=seconds,
            scene=scene,
            parameters=parse_parameters(parameters),
            places=parameter_places(parameters),
            direction=direction,
            variation=varied,
        ).clip
    names = [] if overlays == "none" else [name.strip() for name in overlays.split(",") if name.strip()]
    with transaction():
        for output in outputs:
            render_clip(
                baked,
                output,
                width=width,
                height=height,
                camera=camera,
                overlays=builtin_overlays(baked, names),
                look=look_name(look),
            )
    for output in outputs:
        typer.echo(f"wrote {output}")


def analyze(
    clip: Annotated[Path, typer.Argument(help="A baked clip (.npz) from `quadpipe simulate` or `bake`.")],
    output: Annotated[Path | None, typer.Option("-o", "--output", help="Write the report as JSON.")] = None,
    diagram: Annotated[
        Path | None, typer.Option("--diagram", help="Draw a footfall (Hildebrand) diagram (.png).")
    ] = None,
    animal: Annotated[str | None, typer.Option("--animal", "-a", help="Analyse only this animal of the clip.")] = None,
    settle: Annotated[
        float | None,
        typer.Option(
            "--settle",
            min=0.0,
            help="Natural times sqrt(HP/g) at the start left out of the posture figures"
            " (default 4; at most half the clip).",
        ),
    ] = None,
    fmt: FormatOpt = OutputFormat.text,
) -> None:
    """Gait and posture analysis of a clip: footfalls, duty factors, phases, stride, speed, Froude
    number, gait name; joint flexion in stance, trunk, head and tail carriage, foot slip; for a
    directed clip, the path error, arrival times and speed error per beat, and the stands.

    Example: quadpipe analyze run.npz -o report.json --diagram footfalls.png
    """
    import dataclasses

    from quadpipe.core.outputs import check_distinct, check_suffix
    from quadpipe.exporters.npz import load_clip

    named = [(option, path) for option, path in (("-o", output), ("--diagram", diagram)) if path is not None]
    check_distinct(named, [("the clip", clip)])
    if output is not None:
        check_suffix("-o", output, (".json",), "the JSON report")
    if diagram is not None:
        from quadpipe.analysis import check_diagram_path

        check_diagram_path(diagram)
    baked = load_clip(clip)
    from quadpipe.analysis import analyze_clip, format_report, posture_report
    from quadpipe.analysis.direction import direction_reports

    report = dataclasses.replace(
        analyze_clip(baked, animal),
        posture=posture_report(baked, animal, *(() if settle is None else (settle,))),
        directions=direction_reports(baked),
    )
    typer.echo(report.to_json().rstrip("\n") if fmt == OutputFormat.json else format_report(report))
    write_gait_files(report, output, diagram)


def blender_script(
    output: Annotated[Path, typer.Option("-o", "--output", help="Where to write the script (.py).")] = Path(
        "quadpipe_import.py"
    ),
) -> None:
    """Write the Blender import script: it imports .glb/.gltf, .usd/.usda/.usdc/.usdz and .bvh clips
    with the scene set to the clip's frame rate and frame range (Blender's own importers keep 24
    fps). Run it from the command line, from Blender's Text Editor (then File > Import > quadpipe
    clip), or import it as a module (`quadpipe_import.import_clip(path)`). See docs/dcc.md.

    Example: quadpipe blender-script -o quadpipe_import.py && blender -P quadpipe_import.py -- walk.glb
    """
    from quadpipe.core.atomic import check_writable, write_text
    from quadpipe.core.outputs import check_suffix
    from quadpipe.exporters import blender_script as script_source

    check_suffix("-o", output, (".py",), "the Blender script")
    check_writable(output)
    write_text(output, script_source())
    typer.echo(f"wrote {output}")
