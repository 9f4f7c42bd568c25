"""The `quadpipe` command line: thin commands over library functions.

Every command's help ends with an example. Errors in the user's input print as
`file:line:col: error CODE: message` with a hint, and exit 1 without a traceback (add `--debug`
to see one). Heavy modules (mujoco, numpy, pxr, open3d) are imported inside the commands so that
`quadpipe --help` stays instant.
"""

from __future__ import annotations

import json
import sys
from enum import Enum
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from quadpipe.animals.sizing import FRAME_RATE

if TYPE_CHECKING:
    from quadpipe.analysis import GaitReport

app = typer.Typer(
    name="quadpipe",
    help="Animate quadrupeds by physics alone and bake the motion into clips.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    rich_markup_mode=None,
    context_settings={"help_option_names": ["-h", "--help"]},
)

_state = {"debug": False}

EXIT_INPUT_ERROR = 1
EXIT_INTERNAL_ERROR = 3
EXIT_INTERRUPTED = 130


class OutputFormat(str, Enum):
    """Output formats of the listing commands."""

    text = "text"
    json = "json"


def _version(value: bool) -> None:
    if value:
        from quadpipe import __version__

        typer.echo(f"quadpipe {__version__}")
        raise typer.Exit()


@app.callback()
def _main(
    debug: Annotated[bool, typer.Option("--debug", help="Show Python tracebacks on errors.")] = False,
    version: Annotated[
        bool | None, typer.Option("--version", callback=_version, is_eager=True, help="Print the version.")
    ] = None,
) -> None:
    """Animate quadrupeds by physics alone and bake the motion into clips."""
    _state["debug"] = debug


SourceArg = Annotated[
    str,
    typer.Argument(help="An animal name (dog), an animal config (.yaml) or a skeleton file (.xml, .ma, .bvh)."),
]
LimitsOpt = Annotated[
    Path | None, typer.Option("--limits", help="Joint-limit table for a bare skeleton (default: the thesis's).")
]
RolesOpt = Annotated[Path | None, typer.Option("--roles", help="Role map YAML for a skeleton's own bone names.")]
MassOpt = Annotated[float | None, typer.Option("--mass", help="Body mass in kg for a bare skeleton.")]


def _built(source: str, limits: Path | None, roles: Path | None, mass: float | None):
    from quadpipe.animals.library import resolve_animal
    from quadpipe.animals.model import build_animal

    animal = resolve_animal(source, limits=limits, role_map=roles, mass_kg=mass)
    _print_warnings(animal.warnings)
    return build_animal(animal)


def _print_warnings(issues) -> None:
    for issue in issues:
        typer.echo(issue.format(), err=True)


@app.command()
def animals(
    fmt: Annotated[OutputFormat, typer.Option("--format", help="Output format.")] = OutputFormat.text,
) -> None:
    """List the built-in animals: pelvis height, mass, bones, degrees of freedom.

    Example: quadpipe animals --format json
    """
    from quadpipe.animals import report
    from quadpipe.core import configs

    rows = [report.animal_row(_built(name, None, None, None)) for name in configs.available("animals")]
    rows.sort(key=lambda row: -row["hp_cm"])
    if fmt is OutputFormat.json:
        typer.echo(json.dumps(rows, indent=2))
        return
    _print_table(
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


@app.command()
def roles(
    skeleton: Annotated[
        Path | None, typer.Argument(help="A skeleton file (.ma, .bvh, .xml) whose roles to guess.")
    ] = None,
    output: Annotated[Path | None, typer.Option("-o", "--output", help="Write the guess as a role map YAML.")] = None,
) -> None:
    """List the 39 roles; with a skeleton file, show (and write) the roles guessed for its joints.

    Example: quadpipe roles rig.ma -o rig_roles.yaml   (then: quadpipe inspect rig.ma --roles rig_roles.yaml)
    """
    from quadpipe.anatomy.roles import PARENT, ROLES, kind_of

    if skeleton is None:
        _print_table(
            "Roles", ["role", "parent", "kind"], [[role, PARENT[role] or "-", kind_of(role)] for role in ROLES]
        )
        return
    from quadpipe.anatomy.rolemap import guess_roles, write_role_map
    from quadpipe.importers import read_raw_skeleton

    raw = read_raw_skeleton(skeleton)
    guess = guess_roles(raw)
    placed = {role: name for name, role in guess.roles.items()}
    _print_table(
        f"Roles guessed for {skeleton}", ["role", "joint"], [[role, placed.get(role, "(not placed)")] for role in ROLES]
    )
    if guess.missing:
        for note in guess.notes:
            typer.echo(f"note: {note}", err=True)
    if output is not None:
        write_role_map(output, guess.roles, source=raw.source, missing=guess.missing)
        typer.echo(f"wrote {output} ({len(guess.roles)} joints placed, {len(guess.missing)} roles missing)")


@app.command()
def convert(
    source: SourceArg,
    output: Annotated[Path, typer.Option("-o", "--output", help="MJCF file to write (.xml).")],
    limits: LimitsOpt = None,
    roles: RolesOpt = None,
    mass: MassOpt = None,
    floor: Annotated[bool, typer.Option("--floor/--no-floor", help="Include a floor and a light.")] = True,
) -> None:
    """Build an animal's physical model and write it as MJCF (opens in `python -m mujoco.viewer`).

    Example: quadpipe convert dog -o dog.xml
    """
    from quadpipe.core.atomic import write_text
    from quadpipe.world.placement import Placement, build_world

    built = _built(source, limits, roles, mass)
    spec = build_world([Placement(built.animal.name, built)], floor=floor)
    spec.compile()
    write_text(output, spec.to_xml())
    typer.echo(
        f"wrote {output} ({built.animal.name}: {len(built.animal.skeleton.bones)} bones, {built.animal.mass_kg:g} kg)"
    )


@app.command()
def inspect(
    source: SourceArg,
    limits: LimitsOpt = None,
    roles: RolesOpt = None,
    mass: MassOpt = None,
    fmt: Annotated[OutputFormat, typer.Option("--format", help="Output format.")] = OutputFormat.text,
) -> None:
    """Show an animal's bones: roles, file names, lengths, radii, masses and joint limits.

    Limits read "twist min..max ±swing1 ±swing2" in degrees.

    Example: quadpipe inspect horse   |   quadpipe inspect rig.bvh --roles rig_roles.yaml
    """
    from quadpipe.animals import report

    built = _built(source, limits, roles, mass)
    summary, bones = report.animal_row(built), report.bone_rows(built)
    if fmt is OutputFormat.json:
        typer.echo(json.dumps({"animal": summary, "bones": bones}, indent=2))
        return
    typer.echo(
        f"{summary['name']}: HP {summary['hp_cm']} cm, {summary['mass_kg']} kg, {summary['bones']} bones, "
        f"{summary['dof']} DOF, radius {summary['radius_cm']} cm, step 1/{round(1 / summary['timestep_s'])} s"
    )
    _print_table(
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


class ValidateFormat(str, Enum):
    """Report formats of `validate`."""

    text = "text"
    json = "json"
    github = "github"


@app.command()
def validate(
    files: Annotated[
        list[str], typer.Argument(help="Controller files, folders of them, or built-in controller names.")
    ],
    fmt: Annotated[
        ValidateFormat, typer.Option("--format", help="text, json, or github (annotations for CI).")
    ] = ValidateFormat.text,
) -> None:
    """Check controller files: syntax, schema, roles, units and references. Exit 1 on any error.

    Example: quadpipe validate configs/controllers/ --format github
    """
    from quadpipe.controllers.language import validate_files

    report, code = validate_files(files, fmt.value)
    if report:
        typer.echo(report)
    raise typer.Exit(code)


class SchemaKind(str, Enum):
    """Files that have a JSON Schema."""

    controller = "controller"
    scene = "scene"


@app.command()
def schema(kind: Annotated[SchemaKind, typer.Argument(help="Which file format.")]) -> None:
    """Print the JSON Schema of a file format, for editors (yaml-language-server) and CI.

    Example: quadpipe schema controller > controller.schema.json
    """
    if kind is SchemaKind.controller:
        from quadpipe.controllers.language import controller_json_schema

        typer.echo(json.dumps(controller_json_schema(), indent=2))
    else:
        from quadpipe.world import scene_json_schema

        typer.echo(json.dumps(scene_json_schema(), indent=2))


@app.command()
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
        _print_table("Controllers", ["name", "description"], rows)
        return
    spec = load_controller(name)
    typer.echo(f"{spec.name}: {spec.description}")
    rows = [
        [tunable.name, tunable.value, " to ".join(map(str, tunable.limits)), tunable.description]
        for tunable in spec.tunables.values()
    ]
    _print_table(
        f"Tunables of {spec.name} (set with --set NAME=VALUE)", ["tunable", "value", "range", "description"], rows
    )


@app.command()
def scenes() -> None:
    """List the built-in scenes with their descriptions.

    Example: quadpipe scenes
    """
    from quadpipe.world import available_scenes, load_scene

    _print_table(
        "Scenes", ["name", "description"], [[name, load_scene(name).description] for name in available_scenes()]
    )


AnimalOpt = Annotated[str, typer.Option("--animal", "-a", help="Animal name or config file.")]
ControllerOpt = Annotated[str, typer.Option("--controller", "-c", help="Controller name or file.")]
SceneOpt = Annotated[str, typer.Option("--scene", help="Scene name or file: terrain, props, throws, goals.")]
SecondsOpt = Annotated[float, typer.Option("--seconds", "-s", min=0.0, help="Simulated time.")]
SetOpt = Annotated[
    list[str] | None, typer.Option("--set", help="Override a controller parameter: NAME=VALUE (repeatable).")
]
MetricsOpt = Annotated[Path | None, typer.Option("--metrics", help="Metrics JSON (default: beside the first output).")]
FpsOpt = Annotated[
    float,
    typer.Option(
        "--fps", min=1.0, help="Recorded frames per second; must divide the physics rate (120 for most animals)."
    ),
]
GaitReportOpt = Annotated[
    Path | None,
    typer.Option("--gait-report", help="Also write the gait analysis (as `quadpipe analyze -o`) to this JSON file."),
]
DiagramOpt = Annotated[
    Path | None, typer.Option("--diagram", help="Also draw the footfall (Hildebrand) diagram to this PNG file.")
]


@app.command()
def simulate(
    animal: AnimalOpt = "dog",
    controller: ControllerOpt = "rigid",
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
) -> None:
    """Simulate an animal under a controller and write the clip and its metrics.

    Example: quadpipe simulate --animal dog --controller walk --seconds 10 -o run.npz --diagram walk.png
    """
    _run_and_write(animal, controller, scene, seconds, [output], metrics, parameters, fps, gait_report, diagram)


@app.command()
def bake(
    outputs: Annotated[list[Path], typer.Option("-o", "--output", help="File to write; repeat for several formats.")],
    animal: AnimalOpt = "dog",
    controller: ControllerOpt = "spine_walk",
    scene: SceneOpt = "flat",
    seconds: SecondsOpt = 10.0,
    metrics: MetricsOpt = None,
    parameters: SetOpt = None,
    fps: FpsOpt = FRAME_RATE,
    gait_report: GaitReportOpt = None,
    diagram: DiagramOpt = None,
) -> None:
    """Simulate once and bake the motion into every requested file; the suffix picks the format.

    Formats: .glb .gltf (glTF 2.0), .usda .usdc .usdz (OpenUSD), .bvh, .npz (raw clip).
    Example: quadpipe bake --animal horse --controller trot --scene hill -o horse.glb -o horse.usdc --gait-report horse.gait.json
    """
    _run_and_write(animal, controller, scene, seconds, outputs, metrics, parameters, fps, gait_report, diagram)


def _run_and_write(
    animal: str,
    controller: str,
    scene: str,
    seconds: float,
    outputs: list[Path],
    metrics: Path | None,
    parameters: list[str] | None,
    fps: float,
    gait_report: Path | None,
    diagram: Path | None,
) -> None:
    from quadpipe.batch.bake import METRICS_SUFFIX, bake
    from quadpipe.core.atomic import check_writable
    from quadpipe.exporters import check_output_path

    for output in outputs:
        check_output_path(output)
    for extra in (metrics, gait_report, diagram):
        if extra is not None:
            check_writable(extra)
    if diagram is not None:
        from quadpipe.analysis import check_diagram_path

        check_diagram_path(diagram)
    metrics_path = metrics or outputs[0].with_suffix(METRICS_SUFFIX)
    result = bake(
        animal,
        controller,
        seconds=seconds,
        outputs=outputs,
        metrics_path=metrics_path,
        scene=scene,
        parameters=_parameters(parameters),
        fps=fps,
    )
    typer.echo(f"wrote {', '.join(map(str, outputs))} and {metrics_path}: {result.metrics['frames']} frames")
    for name, figures in result.metrics["animals"].items():
        typer.echo(
            f"  {name}: {figures['distance_hp']:.2f} HP travelled, pelvis {figures['pelvis_height_min_hp']:.2f}-"
            f"{figures['pelvis_height_max_hp']:.2f} HP{', FELL' if figures['fell'] else ''}"
        )
    if gait_report is not None or diagram is not None:
        from quadpipe.analysis import analyze_clip

        _write_gait_report(analyze_clip(result.clip), gait_report, diagram)


@app.command()
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
) -> None:
    """Bake every animal x controller x scene of a plan in parallel, locally or on a Dask cluster.

    Each job writes OUTPUT/<animal>_<controller>_<scene>.<format> for every format, and a
    .metrics.json. Jobs whose files are all there are skipped (--force redoes them); a failing job
    does not stop the others, and the exit code is 1 if any failed. See docs/batch.md.
    Example: quadpipe batch configs/batches/walks.yaml -j 4   |   quadpipe batch -a dog,horse -c spine_walk -f glb -f usdc -s 5
    """
    from rich.console import Console

    from quadpipe.batch import plan_from, run_batch, summary_table

    chosen = plan_from(
        plan, animals=animals, controllers=controllers, scenes=scenes, seconds=seconds, formats=formats, output=output
    )
    report = run_batch(chosen, workers=workers, force=force, scheduler=scheduler, progress=not quiet)
    Console().print(summary_table(report))
    raise typer.Exit(report.exit_code)


@app.command()
def preview(
    clip: Annotated[
        Path | None, typer.Argument(help="A baked clip (.npz) to replay; without it, simulate live.")
    ] = None,
    animal: AnimalOpt = "dog",
    controller: ControllerOpt = "spine_walk",
    scene: SceneOpt = "flat",
    parameters: SetOpt = None,
) -> None:
    """Open a window: watch the animal simulate live while you edit its controller (saved edits reload), or replay a clip.

    Keys: space pause, . step, r reset, m slow motion, b/x throw a ball/box, arrows move the goal, 1-9 force a state,
    F1-F6 overlays, c free camera, h help.
    Example: quadpipe preview --animal dog --controller my_walk.yaml --scene hill   |   quadpipe preview run.npz
    """
    from quadpipe.preview.window import check_display, open_window

    check_display()
    if clip is not None:
        from quadpipe.preview import load_replay

        model, title = load_replay(clip), f"quadpipe preview: {clip}"
    else:
        from quadpipe.preview import LivePreview

        model = LivePreview(animal, controller, scene, _parameters(parameters))
        title = f"quadpipe preview: {animal} / {controller} / {scene}"
    open_window(model, title)


@app.command()
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
) -> None:
    """Render a clip headless (MuJoCo's renderer) to MP4, GIF, or a PNG contact sheet.

    Example: quadpipe render run.npz -o run.mp4 -o sheet.png   |   quadpipe render --controller spine_walk --scene hill -o walk.mp4
    """
    from quadpipe.render import builtin_overlays, render_clip

    if clip is not None:
        from quadpipe.exporters.npz import load_clip

        baked = load_clip(clip)
    else:
        from quadpipe.sim.simulation import simulate as run_simulation

        baked = run_simulation(
            animal, controller, seconds=seconds, scene=scene, parameters=_parameters(parameters)
        ).clip
    names = [] if overlays == "none" else [name.strip() for name in overlays.split(",") if name.strip()]
    for output in outputs:
        render_clip(baked, output, width=width, height=height, overlays=builtin_overlays(baked, names))
        typer.echo(f"wrote {output}")


@app.command()
def analyze(
    clip: Annotated[Path, typer.Argument(help="A baked clip (.npz) from `quadpipe simulate` or `bake`.")],
    output: Annotated[Path | None, typer.Option("-o", "--output", help="Write the report as JSON.")] = None,
    diagram: Annotated[
        Path | None, typer.Option("--diagram", help="Draw a footfall (Hildebrand) diagram (.png).")
    ] = None,
    animal: Annotated[str | None, typer.Option("--animal", "-a", help="Analyse only this animal of the clip.")] = None,
) -> None:
    """Gait analysis of a clip: footfalls, duty factors, phases, stride, speed, Froude number, gait name.

    Example: quadpipe analyze run.npz -o report.json --diagram footfalls.png
    """
    from quadpipe.analysis import analyze_clip, check_diagram_path, format_report
    from quadpipe.exporters.npz import load_clip

    if diagram is not None:
        check_diagram_path(diagram)
    report = analyze_clip(load_clip(clip), animal)
    typer.echo(format_report(report))
    _write_gait_report(report, output, diagram)


def _write_gait_report(report: GaitReport, report_path: Path | None, diagram: Path | None) -> None:
    """Write a gait analysis as JSON and its footfall diagram as PNG (either may be None)."""
    from quadpipe.analysis import draw_footfall_diagram
    from quadpipe.core.atomic import write_text

    if report_path is not None:
        write_text(report_path, json.dumps(report.to_dict(), indent=2, allow_nan=False) + "\n")
        typer.echo(f"wrote {report_path}")
    if diagram is not None:
        draw_footfall_diagram(report, diagram)
        typer.echo(f"wrote {diagram}")


def _parameters(pairs: list[str] | None) -> dict[str, str]:
    from quadpipe.core.errors import QuadpipeError

    result = {}
    for pair in pairs or []:
        name, sep, value = pair.partition("=")
        if not sep or not name.strip():
            raise QuadpipeError.single(
                "bad-parameter", f"--set {pair!r} is not NAME=VALUE", hint='e.g. --set "pedal_force=0.2 bw"'
            )
        result[name.strip()] = value.strip()
    return result


def _print_table(title: str, headers: list[str], rows: list[list]) -> None:
    from rich.console import Console
    from rich.table import Table

    table = Table(title=title)
    for header in headers:
        table.add_column(header)
    for row in rows:
        table.add_row(*(str(cell) for cell in row))
    Console().print(table)


def main() -> None:
    """Entry point: run the app, turning input errors into clean messages and exit codes."""
    from quadpipe.core.errors import QuadpipeError

    try:
        app()
    except QuadpipeError as exc:
        if _state["debug"]:
            raise
        typer.echo(exc.format(), err=True)
        sys.exit(EXIT_INPUT_ERROR)
    except KeyboardInterrupt:
        if _state["debug"]:
            raise
        typer.echo("interrupted", err=True)
        sys.exit(EXIT_INTERRUPTED)
    except Exception as exc:  # a bug in quadpipe, not in the user's input
        if _state["debug"]:
            raise
        typer.echo(
            f"internal error: {type(exc).__name__}: {exc}\n  hint: run again with --debug for the traceback, and report it",
            err=True,
        )
        sys.exit(EXIT_INTERNAL_ERROR)
