"""Commands that run simulations: simulate, bake, batch, preview."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from quadpipe.animals.sizing import FRAME_RATE
from quadpipe.cli.options import (
    AnimalOpt,
    ControllerOpt,
    DiagramOpt,
    DirectionOpt,
    FpsOpt,
    GaitReportOpt,
    LimitsOpt,
    Look,
    LookOpt,
    MassOpt,
    MetricsOpt,
    RolesOpt,
    SceneOpt,
    SecondsOpt,
    SeedOpt,
    SetOpt,
    Skeleton,
    SkeletonOpt,
    VariationOpt,
    animal_source,
    look_name,
    parameter_places,
    parse_parameters,
    variation_of,
)
from quadpipe.cli.output import print_warnings, write_gait_files

if TYPE_CHECKING:
    from quadpipe.animals.library import AnimalSource
    from quadpipe.bodies import Look as LookName
    from quadpipe.controllers.runtime.variation import Variation
    from quadpipe.exporters import SkeletonChoice
    from quadpipe.preview.base import Preview


def simulate(
    animal: AnimalOpt = "dog",
    controller: ControllerOpt = "walk",
    scene: SceneOpt = "flat",
    seconds: SecondsOpt = 10.0,
    output: Annotated[Path, typer.Option("-o", "--output", help="Clip to write (.npz, or any bake format).")] = Path(
        "run.npz"
    ),
    metrics: MetricsOpt = None,
    parameters: SetOpt = None,
    fps: FpsOpt = FRAME_RATE,
    gait_report: GaitReportOpt = None,
    diagram: DiagramOpt = None,
    look: LookOpt = Look.body,
    limits: LimitsOpt = None,
    roles: RolesOpt = None,
    mass: MassOpt = None,
    skeleton: SkeletonOpt = Skeleton.rig,
    direction: DirectionOpt = None,
    variation: VariationOpt = 0.0,
    seed: SeedOpt = 0,
) -> None:
    """Simulate an animal under a controller and write the clip and its metrics.

    Example: quadpipe simulate --animal dog --controller walk --seconds 10 -o run.npz --diagram walk.png --variation 0.03
    |   quadpipe simulate -a rig.bvh --roles rig_roles.yaml --mass 25 -c walk -o rig_walk.bvh
    """
    bake(
        [output], animal, controller, scene, seconds, metrics, parameters, fps, gait_report, diagram, look,
        limits, roles, mass, skeleton, direction, variation, seed,
    )  # fmt: skip


def bake(
    outputs: Annotated[list[Path], typer.Option("-o", "--output", help="File to write; repeat for several formats.")],
    animal: AnimalOpt = "dog",
    controller: ControllerOpt = "walk",
    scene: SceneOpt = "flat",
    seconds: SecondsOpt = 10.0,
    metrics: MetricsOpt = None,
    parameters: SetOpt = None,
    fps: FpsOpt = FRAME_RATE,
    gait_report: GaitReportOpt = None,
    diagram: DiagramOpt = None,
    look: LookOpt = Look.body,
    limits: LimitsOpt = None,
    roles: RolesOpt = None,
    mass: MassOpt = None,
    skeleton: SkeletonOpt = Skeleton.rig,
    direction: DirectionOpt = None,
    variation: VariationOpt = 0.0,
    seed: SeedOpt = 0,
) -> None:
    """Simulate once and bake the motion into every requested file; the suffix picks the format.

    Formats: .glb .gltf (glTF 2.0), .usda .usdc .usdz (OpenUSD), .bvh, .npz (raw clip). A skeleton
    file (-a rig.ma --roles rig_roles.yaml) is baked onto its own joints (--skeleton roles: the 39 roles).
    Example: quadpipe bake --animal horse --controller trot --scene hill -o horse.glb -o horse.usdc --gait-report horse.gait.json
    """
    _bake_and_report(
        BakeOptions(
            animal=animal_source(animal, limits, roles, mass),
            controller=controller,
            scene=scene,
            seconds=seconds,
            outputs=tuple(outputs),
            metrics=metrics,
            parameters=tuple(parameters or ()),
            fps=fps,
            gait_report=gait_report,
            diagram=diagram,
            look=look_name(look),
            skeleton=skeleton.value,
            direction=direction,
            variation=variation_of(variation, seed),
        )
    )


@dataclass(frozen=True)
class BakeOptions:
    """What `simulate` and `bake` are asked for: the run, the files it writes, and how."""

    animal: AnimalSource
    controller: str
    scene: str
    seconds: float
    outputs: tuple[Path, ...]
    """The clip files (at least one); the suffix picks the format."""
    metrics: Path | None
    """The metrics JSON (None: beside the first output)."""
    parameters: tuple[str, ...]
    """The `--set NAME=VALUE` options, as given."""
    fps: float
    gait_report: Path | None
    diagram: Path | None
    look: LookName
    skeleton: SkeletonChoice
    direction: Path | None
    variation: Variation | None


def _bake_and_report(options: BakeOptions) -> None:
    """`simulate` and `bake`: check every output path first, bake, print the figures, write the gait
    files: every file, or none (they are renamed into place together at the end). A skeleton
    file's notes and mass are printed first (`announce_animal`)."""
    from quadpipe.batch.bake import METRICS_SUFFIX, bake
    from quadpipe.cli.library import announce_animal
    from quadpipe.core.atomic import transaction
    from quadpipe.core.limits import check_run

    check_run(options.seconds, options.fps, names=("--seconds", "--fps"))
    metrics_path = options.metrics or options.outputs[0].with_suffix(METRICS_SUFFIX)
    metrics_named = ("--metrics", options.metrics) if options.metrics else ("the default --metrics", metrics_path)
    inputs = list(zip(INPUT_OPTIONS, [str(options.animal), options.controller, options.scene])) + (
        [("--direction", str(options.direction))] if options.direction else []
    )
    _check_bake_outputs(options.outputs, metrics_named, options.gait_report, options.diagram, inputs)
    announce_animal(options.animal)
    with transaction():
        result = bake(
            options.animal,
            options.controller,
            seconds=options.seconds,
            outputs=options.outputs,
            metrics_path=metrics_path,
            scene=options.scene,
            parameters=parse_parameters(options.parameters),
            places=parameter_places(options.parameters),
            fps=options.fps,
            look=options.look,
            skeleton=options.skeleton,
            direction=options.direction,
            variation=options.variation,
        )
        print_warnings(result.warnings)
        typer.echo(
            f"wrote {', '.join(map(str, options.outputs))} and {metrics_path}: {result.metrics['frames']} frames"
        )
        for name, figures in result.metrics["animals"].items():
            typer.echo(
                f"  {name}: {figures['distance_hp']:.2f} HP travelled, pelvis {figures['pelvis_height_min_hp']:.2f}-"
                f"{figures['pelvis_height_max_hp']:.2f} HP{', FELL' if figures['fell'] else ''}"
            )
        if options.gait_report is not None or options.diagram is not None:
            from quadpipe.analysis import analyze_clip

            write_gait_files(analyze_clip(result.clip), options.gait_report, options.diagram)


INPUT_OPTIONS = ("--animal", "--controller", "--scene")
"""The options of `simulate` and `bake` that may name input files."""


def _check_bake_outputs(
    outputs: Sequence[Path],
    metrics: tuple[str, Path],
    gait_report: Path | None,
    diagram: Path | None,
    inputs: list[tuple[str, str]],
) -> None:
    """Before simulating: every output a distinct file, apart from the inputs, of the right suffix, writable."""
    from quadpipe.core.atomic import check_writable
    from quadpipe.core.outputs import check_distinct, check_suffix
    from quadpipe.exporters import check_output_path

    named = [("-o", output) for output in outputs] + [metrics]
    named += [(option, path) for option, path in (("--gait-report", gait_report), ("--diagram", diagram)) if path]
    check_distinct(named, [(f"the {option} file", Path(name)) for option, name in inputs])
    for output in outputs:
        check_output_path(output)
    for option, path in named[len(outputs) :]:
        check_writable(path)
        if option == "--diagram":
            from quadpipe.analysis import check_diagram_path

            check_diagram_path(path)
        else:
            check_suffix(option, path, (".json",), "JSON")


def batch(
    plan: Annotated[
        Path | None, typer.Argument(help="A batch plan (.yaml); the options below replace its values.")
    ] = None,
    animals: Annotated[
        list[str] | None,
        typer.Option("--animal", "-a", help="Animals: names or files, repeated or comma-separated, or 'all'."),
    ] = None,
    controllers: Annotated[
        list[str] | None, typer.Option("--controller", "-c", help="Controllers: names or files, or 'all'.")
    ] = None,
    scenes: Annotated[
        list[str] | None, typer.Option("--scene", help="Scenes: names or files, or 'all' (default: flat).")
    ] = None,
    seconds: Annotated[
        float | None, typer.Option("--seconds", "-s", help="Simulated time of every job (default: 10).")
    ] = None,
    formats: Annotated[
        list[str] | None,
        typer.Option("--format", "-f", help="Formats to write: glb, usdc, bvh, npz... (default: glb)."),
    ] = None,
    output: Annotated[
        Path | None, typer.Option("-o", "--output", help="Folder of the files (default: out/batch).")
    ] = None,
    workers: Annotated[
        int | None, typer.Option("--workers", "-j", min=1, help="Worker processes (default: one per CPU core).")
    ] = None,
    force: Annotated[bool, typer.Option("--force", help="Redo jobs whose files are all there already.")] = False,
    scheduler: Annotated[
        str | None,
        typer.Option("--scheduler", help="Run on a Dask cluster: its scheduler's address (tcp://host:8786)."),
    ] = None,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No progress bars; only the summary.")] = False,
    variation: Annotated[
        float | None, typer.Option("--variation", help="Natural stride-to-stride variation of every job (default: 0).")
    ] = None,
    seed: Annotated[int | None, typer.Option("--seed", help="Seed of --variation (default: 0).")] = None,
    roles: RolesOpt = None,
    mass: MassOpt = None,
) -> None:
    """Bake every animal x controller x scene of a plan in parallel, locally or on a Dask cluster.

    Each job writes OUTPUT/<animal>_<controller>_<scene>.<format> for every format, and a
    .metrics.json. Jobs whose files are all there are skipped (--force redoes them); a failing job
    does not stop the others, and the exit code is 1 if any failed. See docs/batch.md.
    Example: quadpipe batch configs/batches/walks.yaml -j 4   |   quadpipe batch -a dog,horse -c spine_walk -f glb -f usdc -s 5
    |   quadpipe batch -a rig.bvh --roles rig_roles.yaml --mass 25 -c walk,leg_by_leg -f bvh
    """
    from rich.console import Console

    from quadpipe.batch import plan_from, run_batch, summary_table

    chosen = plan_from(
        plan,
        animals=animals,
        controllers=controllers,
        scenes=scenes,
        seconds=seconds,
        formats=formats,
        output=output,
        variation=variation,
        seed=seed,
        roles=roles,
        mass=mass,
    )
    report = run_batch(chosen, workers=workers, force=force, scheduler=scheduler, progress=not quiet)
    Console().print(summary_table(report))
    raise typer.Exit(report.exit_code)


def preview(
    clip: Annotated[
        Path | None, typer.Argument(help="A baked clip (.npz) to replay; without it, simulate live.")
    ] = None,
    animal: AnimalOpt = "dog",
    controller: ControllerOpt = "walk",
    scene: SceneOpt = "flat",
    parameters: SetOpt = None,
    direction: DirectionOpt = None,
    limits: LimitsOpt = None,
    roles: RolesOpt = None,
    mass: MassOpt = None,
) -> None:
    """Open a window: watch the animal simulate live while you edit its controller (saved edits reload), or replay a clip.

    Keys: space pause, . step, r reset, m slow motion, b/x throw a ball/box, arrows move the goal, 1-9 force a state,
    F1-F6 overlays, c free camera, h help.
    Example: quadpipe preview --animal dog --controller my_walk.yaml --scene hill   |   quadpipe preview run.npz
    """
    from quadpipe.preview.display import check_display
    from quadpipe.preview.window import open_window

    model: Preview
    if clip is not None:  # bad arguments are refused before anything looks for a display
        from quadpipe.preview import load_replay

        model, title = load_replay(clip), f"quadpipe preview: {clip}"
    else:
        from quadpipe.preview import LivePreview

        source = animal_source(animal, limits, roles, mass)
        model = LivePreview(
            source, controller, scene, parse_parameters(parameters), parameter_places(parameters), direction=direction
        )
        title = f"quadpipe preview: {animal} / {controller} / {scene}"
    check_display()
    open_window(model, title)
