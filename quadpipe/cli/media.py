"""Commands that turn a clip into pictures or figures: render, analyze."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from quadpipe.cli.options import (
    AnimalOpt,
    ControllerOpt,
    FormatOpt,
    Look,
    LookOpt,
    OutputFormat,
    SceneOpt,
    SecondsOpt,
    SetOpt,
    look_name,
    parameter_places,
    parse_parameters,
)
from quadpipe.cli.output import write_gait_files


def render(
    outputs: Annotated[
        list[Path], typer.Option("-o", "--output", help="Video or picture: .mp4, .gif, or .png (a contact sheet).")
    ],
    clip: Annotated[Path | None, typer.Argument(help="A baked clip (.npz); without it, simulate first.")] = None,
    animal: AnimalOpt = "dog",
    controller: ControllerOpt = "spine_walk",
    scene: SceneOpt = "flat",
    seconds: SecondsOpt = 5.0,
    parameters: SetOpt = None,
    width: Annotated[int, typer.Option(help="Frame width in pixels.")] = 640,
    height: Annotated[int, typer.Option(help="Frame height in pixels.")] = 480,
    overlays: Annotated[str, typer.Option(help="Overlays to draw: contacts,trail or none.")] = "contacts,trail",
    look: LookOpt = Look.body,
) -> None:
    """Render a clip headless (MuJoCo's renderer) to MP4, GIF, or a PNG contact sheet.

    Example: quadpipe render run.npz -o run.mp4 -o sheet.png   |   quadpipe render --controller spine_walk --scene hill -o walk.mp4
    """
    from quadpipe.core.atomic import check_writable, transaction
    from quadpipe.core.outputs import check_distinct
    from quadpipe.render import builtin_overlays, render_clip
    from quadpipe.render.writers import render_format

    check_distinct([("-o", output) for output in outputs], [("the clip", clip)] if clip is not None else [])
    for output in outputs:
        render_format(output)
        check_writable(output)
    if clip is not None:
        from quadpipe.exporters.npz import load_clip

        baked = load_clip(clip)
    else:
        from quadpipe.sim.simulation import simulate as run_simulation

        baked = run_simulation(
            animal,
            controller,
            seconds=seconds,
            scene=scene,
            parameters=parse_parameters(parameters),
            places=parameter_places(parameters),
        ).clip
    names = [] if overlays == "none" else [name.strip() for name in overlays.split(",") if name.strip()]
    with transaction():
        for output in outputs:
            render_clip(
                baked, output, width=width, height=height, overlays=builtin_overlays(baked, names), look=look_name(look)
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
    number, gait name; joint flexion in stance, trunk, head and tail carriage, foot slip.

    Example: quadpipe analyze run.npz -o report.json --diagram footfalls.png
    """
    import dataclasses

    from quadpipe.analysis import analyze_clip, check_diagram_path, format_report, posture_report
    from quadpipe.core.outputs import check_distinct, check_suffix
    from quadpipe.exporters.npz import load_clip

    named = [(option, path) for option, path in (("-o", output), ("--diagram", diagram)) if path is not None]
    check_distinct(named, [("the clip", clip)])
    if output is not None:
        check_suffix("-o", output, (".json",), "the JSON report")
    if diagram is not None:
        check_diagram_path(diagram)
    baked = load_clip(clip)
    report = dataclasses.replace(
        analyze_clip(baked, animal), posture=posture_report(baked, animal, *(() if settle is None else (settle,)))
    )
    typer.echo(report.to_json().rstrip("\n") if fmt == OutputFormat.json else format_report(report))
    write_gait_files(report, output, diagram)
