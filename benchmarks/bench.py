"""quadpipe benchmarks: controller cost against bare physics, crowds, bake, start-up, exporters, render.

Run from the repository root:

    .venv/bin/python benchmarks/bench.py                        # everything (several minutes)
    .venv/bin/python benchmarks/bench.py --quick                # a small version, under a minute (CI)
    .venv/bin/python benchmarks/bench.py --only crowds startup  # some sections
    .venv/bin/python benchmarks/bench.py --compare old.json     # run, then old vs new side by side
    .venv/bin/python benchmarks/bench.py --compare old.json new.json   # compare two files, no run

Every figure is the median of several repetitions and is measured in the same run as its
reference: a controlled physics step beside a bare MuJoCo step of the very same model, the
crowd variants beside bare stepping of the same crowd, the bake subprocess beside the same work
in-process, `quadpipe --help` beside a bare `python -c pass`. Results print as tables and go to
a JSON file (default `out/bench.json`) with the machine's description. See benchmarks/README.md.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import math
import os
import platform
import shutil
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import mujoco

    from quadpipe.animals.model import BuiltAnimal
    from quadpipe.clip.model import Clip
    from quadpipe.sim.simulation import Simulation
    from quadpipe.world import SceneSpec

REPO = Path(__file__).resolve().parent.parent
"""The repository root (commands run there, relative paths resolve there)."""

DEFAULT_JSON = REPO / "out" / "bench.json"
"""Where results go without `--json` (out/ is ignored by git)."""

REPORT_SCHEMA = 1
"""Version of the JSON layout (`schema` key)."""

BENCH_SCENE = "flat"
"""Scene of the per-animal measurements: flat ground, a goal ahead."""

CROSS_ANIMAL, CROSS_CONTROLLER = "dog", "spine_walk"
"""Without `all_pairs`: every controller runs on this animal, every animal under this controller."""

CROWD_SPECIES = "dog"
CROWD_CONTROLLER = "spine_walk"
"""The crowd: dogs walking with the spine-driven gait."""

CROWD_COLUMNS = 5
"""Dogs side by side in a crowd row (as `configs/scenes/crowd.yaml`), when the count allows."""

CROWD_YAML = """\
schema: 1
name: bench_crowd_{count}
description: {count} dogs in a {rows} x {columns} grid walking to a goal ahead (benchmarks/bench.py).
animals:
  - {{name: dog, species: {species}, grid: {{rows: {rows}, columns: {columns}, spacing: [3 HP, 1.2 HP]}}, at: [0, 0], heading: 0 deg}}
goals:
  goal: [20 HP, 0, 0]
"""
"""A crowd scene: a grid of dogs, spaced as in `configs/scenes/crowd.yaml`."""

BAKE_ANIMAL, BAKE_CONTROLLER = "dog", "spine_walk"
BAKE_FORMATS = (".glb", ".usdc")
"""The bake measured: a dog walk baked to glTF and USD."""

RENDER_WIDTH, RENDER_HEIGHT = 640, 480
"""Headless render frame size, pixels."""

WARM_UP_STEPS = 5
"""Physics steps run before timing a model (first-call caches), not timed."""

WARM_UP_CLIP_S = 0.2
"""Length of the untimed in-process bake run first (imports and first-call caches), seconds."""

WORKER_TIMEOUT_S = 900.0
"""Longest wait for a crowd worker process at a synchronisation point, seconds."""

SUBPROCESS_TIMEOUT_S = 600.0
"""Longest a timed command (bake, --help) may run, seconds."""

PIPE_COLUMNS = 160
"""Table width when the output is not a terminal (rich would use 80)."""

CHANGE_FRACTION = 0.05
"""`--compare` calls a figure better or worse only when it moved by more than this fraction."""

SPLIT_WORLDS = 2
"""Both cores of the reference machine: crowds are split into this many worlds."""

V_ONE_THREAD = "one world, one thread"
V_TWO_THREADS = "two worlds, two threads"
V_TWO_PROCESSES = "two worlds, two processes"
V_BARE_ONE = "bare: one world, mj_step"
V_BARE_ROLLOUT = "bare: two worlds, rollout 2 threads"
"""Crowd variants: three with the controller, two of bare physics."""

CONTROLLED_VARIANTS = (V_ONE_THREAD, V_TWO_THREADS, V_TWO_PROCESSES)


@dataclass(frozen=True)
class Plan:
    """How much of each benchmark to run.

    Attributes:
        name: `quick` or `full`.
        all_pairs: every animal with every controller; False: every controller on the dog
            and every animal with `spine_walk` (building a runtime takes longer than a quick run).
        repeats: repetitions of each per-animal measurement (the median is quoted).
        controller_seconds: simulated seconds per repetition, per animal and controller.
        crowd_sizes: numbers of dogs in the crowd benchmark.
        crowd_repeats: repetitions of each crowd variant.
        crowd_seconds: simulated seconds per crowd repetition.
        clip_seconds: length of the baked and exported dog walk.
        bake_runs: bake subprocesses timed.
        startup_runs: `quadpipe --help` (and `python -c pass`) runs timed.
        export_repeats: exports timed per format.
        render_repeats: `render_fps` measurements.
        render_frames: frames rendered per measurement.
        batch_animals: animals of the batch benchmark (None: all).
        batch_seconds: simulated seconds of each batch job.
        controller_animals: the animals of the `controllers` section (None: all; `--animals`).
        cpu_time: the `controllers` section counts this thread's CPU time instead of wall time
            (`--cpu-time`: on a machine loaded beyond its cores, wall time is mostly waiting).
        unfolded: each `controllers` repetition also times the program as lowered, not folded
            (`--unfolded-too`: the folding's gain, measured interleaved in the same run).
    """

    name: str
    all_pairs: bool
    repeats: int
    controller_seconds: float
    crowd_sizes: tuple[int, ...]
    crowd_repeats: int
    crowd_seconds: float
    clip_seconds: float
    bake_runs: int
    startup_runs: int
    export_repeats: int
    render_repeats: int
    render_frames: int
    batch_animals: tuple[str, ...] | None
    batch_seconds: float
    controller_animals: tuple[str, ...] | None = None
    cpu_time: bool = False
    unfolded: bool = False


FULL = Plan(
    "full",
    all_pairs=True,
    repeats=5,
    controller_seconds=1.0,
    crowd_sizes=(1, 10, 50, 100),
    crowd_repeats=3,
    crowd_seconds=1.0,
    clip_seconds=10.0,
    bake_runs=3,
    startup_runs=10,
    export_repeats=5,
    render_repeats=3,
    render_frames=60,
    batch_animals=None,
    batch_seconds=10.0,
)
QUICK = Plan(
    "quick",
    all_pairs=False,
    repeats=2,
    controller_seconds=0.1,
    crowd_sizes=(1, 10),
    crowd_repeats=2,
    crowd_seconds=0.1,
    clip_seconds=2.0,
    bake_runs=1,
    startup_runs=3,
    export_repeats=2,
    render_repeats=2,
    render_frames=10,
    batch_animals=("dog", "cat"),
    batch_seconds=0.5,
)


# --------------------------------------------------------------------------- results


@dataclass
class Figure:
    """One measured quantity: the median of its samples.

    Attributes:
        value: the median.
        unit: what it counts (`us/step`, `s`, `x realtime`, ...).
        better: `lower` or `higher`.
        samples: every repetition's value.
    """

    value: float
    unit: str
    better: str
    samples: list[float]


def figure(samples: Sequence[float], unit: str, better: str = "lower") -> Figure:
    """The median of `samples` with its unit."""
    values = [float(s) for s in samples]
    return Figure(statistics.median(values), unit, better, values)


def paired(numerators: Sequence[float], denominators: Sequence[float]) -> list[float]:
    """Ratios of samples taken side by side (repetition i over repetition i)."""
    return [n / d for n, d in zip(numerators, denominators)]


@dataclass
class Row:
    """One line of a section's table: what was measured (labels), its figures and status."""

    labels: dict[str, Any]
    figures: dict[str, Figure] = field(default_factory=dict)
    status: str = "ok"


@dataclass
class Section:
    """One benchmark's results."""

    title: str
    rows: list[Row]
    notes: list[str] = field(default_factory=list)
    wall_s: float = 0.0


@dataclass
class Context:
    """What sections share: the plan, a scratch folder, and the walk clip once simulated."""

    plan: Plan
    folder: Path
    clip: Clip | None = None

    def walk_clip(self) -> Clip:
        """The dog walk of `plan.clip_seconds` (simulated on first use)."""
        if self.clip is None:
            from quadpipe.sim.simulation import simulate

            self.clip = simulate(BAKE_ANIMAL, BAKE_CONTROLLER, seconds=self.plan.clip_seconds, scene=BENCH_SCENE).clip
        return self.clip


def timed(action: Callable[[], Any], clock: Callable[[], float] = time.perf_counter) -> float:
    """Seconds `action()` takes on `clock` (wall time unless told)."""
    start = clock()
    action()
    return clock() - start


def step_clock(plan: Plan) -> Callable[[], float]:
    """The clock of the `controllers` section: this thread's CPU time or wall time (`Plan.cpu_time`)."""
    return time.thread_time if plan.cpu_time else time.perf_counter


def error_text(exc: BaseException) -> str:
    """A one-line status for a failed measurement (the issue code for input errors)."""
    from quadpipe.core.errors import QuadpipeError

    if isinstance(exc, QuadpipeError) and exc.issues:
        return f"error {exc.issues[0].code}: {exc.issues[0].message}"
    return f"error {type(exc).__name__}: {exc}"


# --------------------------------------------------------------------------- worlds


@dataclass
class World:
    """A compiled scene that can be stepped again and again from the same start.

    Its `Simulation` releases a controller's runtime before the next run (the runtime writes
    its damping into the model), so every run, controlled or bare, starts from the same model.
    """

    sim: Simulation

    @classmethod
    def build(cls, scene: SceneSpec, species: BuiltAnimal) -> World:
        """Build and compile `scene` with `species` for its animals."""
        from quadpipe.sim.simulation import Simulation
        from quadpipe.world import build_scene

        return cls(Simulation(build_scene(scene, species)))

    @property
    def model(self) -> mujoco.MjModel:
        """The compiled world."""
        return self.sim.model

    @property
    def data(self) -> mujoco.MjData:
        """Its state."""
        return self.sim.data

    def steps(self, seconds: float) -> int:
        """Physics steps in `seconds` of simulated time."""
        return max(1, round(seconds / self.model.opt.timestep))

    def reset(self) -> None:
        """Back to the start with no controller: compiled damping, initial state, kinematics computed."""
        self.sim.use_controller(None)
        self.sim.reset()

    def controlled_run(self, controller: str, folded: bool = True) -> Simulation:
        """The simulation from the start under a freshly built runtime of `controller` (as `simulate`
        builds it; `folded` False: its program as lowered, not folded, driving the simulation instead)."""
        self.reset()
        compiled, _ = self.sim.compile_controller(controller)
        runtime = self.sim.use_controller(compiled)
        if not folded:
            from quadpipe.controllers.runtime.runtime import ControllerRuntime

            unfolded = ControllerRuntime(compiled, self.model, self.sim.placements, folded=False)
            self.sim.controllers = [unfolded if c is runtime else c for c in self.sim.controllers]
        return self.sim

    def step_bare(self, steps: int) -> None:
        """`steps` bare MuJoCo steps, in one call (no Python between steps)."""
        import mujoco

        mujoco.mj_step(self.model, self.data, nstep=steps)

    def status(self) -> str:
        """`ok`, `blew-up` (non-finite state or a bad-acceleration warning) or how many fell."""
        import mujoco

        from quadpipe.sim import health as physics
        from quadpipe.sim.metrics import FALL_HEIGHT_HP

        if not physics.is_finite(self.data) or self.data.warning[mujoco.mjtWarning.mjWARN_BADQACC].number:
            return "blew-up"
        placements = self.sim.placements
        fallen = sum(
            self.data.xpos[self.model.body(f"{p.name}/pelvis").id][2] < FALL_HEIGHT_HP * p.built.animal.pelvis_height
            for p in placements
        )
        if not fallen:
            return "ok"
        return "fell" if len(placements) == 1 else f"{fallen}/{len(placements)} fell"


def step_run(run: Simulation, steps: int) -> None:
    """`steps` steps of a simulation, exactly as the simulation loop takes them."""
    for _ in range(steps):
        run.step()


def worst_status(statuses: Sequence[str]) -> str:
    """The status to report for several repetitions: the first that is not `ok`."""
    return next((s for s in statuses if s != "ok"), "ok")


# --------------------------------------------------------------------------- controllers


def bench_controllers(ctx: Context) -> Section:
    """Per animal and shipped controller: microseconds per step with it and bare, overhead, real time."""
    from quadpipe.animals.library import load_animal
    from quadpipe.animals.model import build_animal
    from quadpipe.world import load_scene

    rows = []
    for animal, controllers in controller_pairs(ctx.plan.all_pairs, ctx.plan.controller_animals).items():
        try:
            world = World.build(load_scene(BENCH_SCENE), build_animal(load_animal(animal)))
        except Exception as exc:  # an animal that cannot be built is recorded, the others still run
            rows += [Row({"animal": animal, "controller": c}, status=error_text(exc)) for c in controllers]
            continue
        rows += [controller_row(world, animal, controller, ctx.plan) for controller in controllers]
    return Section(
        "controller cost per physics step: with it (runtime.apply + mj_step1/2) vs bare mj_step",
        rows,
        [
            f"{ctx.plan.controller_seconds:g} s simulated per repetition, {ctx.plan.repeats} repetitions, scene `{BENCH_SCENE}`;"
            " overhead = with / bare - 1; own = time inside the controller's `apply` per step (in the `with` run),"
            " less the clock reads' own part (own_clock: as many windows timed around nothing, right after the run),"
            " own_share = own / bare; realtime = simulated s per wall s",
            "clock: this thread's CPU time (--cpu-time)" if ctx.plan.cpu_time else "clock: wall time",
            *(
                ["*_unfolded: the same controller's program as lowered, not folded, timed in each repetition"]
                if ctx.plan.unfolded
                else []
            ),
        ],
    )


def controller_pairs(all_pairs: bool, only: Sequence[str] | None = None) -> dict[str, list[str]]:
    """Animal -> the shipped controllers to time on it (all, or the cross through dog and spine_walk),
    for the animals of `only` (None: every animal)."""
    from quadpipe.core import configs

    animals, controllers = configs.available("animals"), configs.available("controllers")
    animals = [animal for animal in animals if only is None or animal in only]
    if all_pairs:
        return {animal: controllers for animal in animals}
    return {animal: controllers if animal == CROSS_ANIMAL else [CROSS_CONTROLLER] for animal in animals}


def controller_row(world: World, animal: str, controller: str, plan: Plan) -> Row:
    """Time one controller on one animal, each repetition beside a bare run from the same start.

    Controllers that blow the simulation up or let the animal fall are still timed; the row's
    status says so. Errors (a controller that does not fit the animal) are recorded.
    """
    labels = {"animal": animal, "controller": controller}
    steps = world.steps(plan.controller_seconds)
    clock = step_clock(plan)
    variants = (True, False) if plan.unfolded else (True,)
    controlled: dict[bool, list[float]] = {folded: [] for folded in variants}
    own: dict[bool, list[float]] = {folded: [] for folded in variants}
    bare: list[float] = []
    floors: list[float] = []
    statuses: list[str] = []
    try:
        step_run(world.controlled_run(controller), WARM_UP_STEPS)
        for _ in range(plan.repeats):
            for folded in variants:
                run = world.controlled_run(controller, folded)
                timers = timed_controllers(run, clock)
                controlled[folded].append(timed(lambda run=run: step_run(run, steps), clock))
                floor = sum(timer.clock_floor(steps) for timer in timers)
                own[folded].append(sum(timer.seconds for timer in timers) - floor)
                floors.append(floor)
                statuses.append(world.status())
            world.reset()
            bare.append(timed(lambda: world.step_bare(steps), clock))
    except Exception as exc:  # measure anyway: one failing controller must not stop the benchmark
        return Row(labels, status=error_text(exc))
    simulated = steps * world.model.opt.timestep
    figures = step_figures(controlled[True], own[True], bare, steps, simulated)
    if plan.unfolded:
        unfolded = step_figures(controlled[False], own[False], bare, steps, simulated)
        figures |= {f"{name}_unfolded": unfolded[name] for name in ("with", "overhead", "own", "own_share")}
    figures["own_clock"] = figure([1e6 * s / steps for s in floors], "us/step")
    return Row(labels, figures, worst_status(statuses))


class TimedController:
    """A controller whose `apply` adds the seconds it takes on `clock` to `seconds`."""

    def __init__(self, controller: Any, clock: Callable[[], float]):
        self.controller, self.clock, self.seconds = controller, clock, 0.0

    def apply(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """The controller's `apply`, timed."""
        start = self.clock()
        self.controller.apply(model, data)
        self.seconds += self.clock() - start

    def clock_floor(self, windows: int) -> float:
        """Seconds that `windows` windows timed as `apply` times one, around nothing, add up:
        the part of the two clock reads inside each window (a `thread_time` read is a system
        call, ~0.7-1.4 µs on the shared machine), to take off `seconds`."""
        seconds = 0.0
        for _ in range(windows):
            start = self.clock()
            seconds += self.clock() - start
        return seconds


def timed_controllers(run: Simulation, clock: Callable[[], float]) -> list[TimedController]:
    """Time every `apply` of `run`'s controllers from now on (the controller's own cost, without
    the physics of the motion it makes); the timers, whose `seconds` add up what they measured.
    The two clock reads per step count in the run's `with` (~0.1 µs of wall time, ~1.5-3 µs of
    `thread_time`); their part inside the timed windows is measured after the run and taken off
    `own` (`TimedController.clock_floor`)."""
    timers = [TimedController(controller, clock) for controller in run.controllers]
    run.controllers = list(timers)
    return timers


def step_figures(
    controlled: Sequence[float], own: Sequence[float], bare: Sequence[float], steps: int, simulated: float
) -> dict[str, Figure]:
    """Per-step costs, overhead and real-time factors from paired wall times."""
    return {
        "with": figure([1e6 * s / steps for s in controlled], "us/step"),
        "bare": figure([1e6 * s / steps for s in bare], "us/step"),
        "overhead": figure([r - 1.0 for r in paired(controlled, bare)], "x bare"),
        "own": figure([1e6 * s / steps for s in own], "us/step"),
        "own_share": figure(paired(own, bare), "x bare"),
        "realtime": figure([simulated / s for s in controlled], "x realtime", "higher"),
        "bare_realtime": figure([simulated / s for s in bare], "x realtime", "higher"),
    }


# --------------------------------------------------------------------------- crowds


def crowd_grid(count: int) -> tuple[int, int]:
    """(rows, columns) of a crowd of `count` dogs: rows of up to CROWD_COLUMNS that divide it."""
    columns = math.gcd(count, CROWD_COLUMNS)
    return count // columns, columns


def write_crowd_scene(count: int, folder: Path) -> Path:
    """Write a scene file of `count` dogs in a grid; return its path."""
    rows, columns = crowd_grid(count)
    path = folder / f"crowd_{count}.yaml"
    path.write_text(CROWD_YAML.format(count=count, rows=rows, columns=columns, species=CROWD_SPECIES))
    return path


def crowd_world(scene_path: Path) -> World:
    """The compiled crowd of a scene file written by `write_crowd_scene`."""
    from quadpipe.animals.library import load_animal
    from quadpipe.animals.model import build_animal
    from quadpipe.world import load_scene

    return World.build(load_scene(scene_path), build_animal(load_animal(CROWD_SPECIES)))


def bench_crowds(ctx: Context) -> Section:
    """Crowds of walking dogs: one world on one thread, two half worlds on two threads or two
    processes, against bare stepping of the whole crowd and of the halves (rollout threads)."""
    rows = []
    notes = [
        f"{ctx.plan.crowd_seconds:g} s simulated per repetition, {ctx.plan.crowd_repeats} repetitions;"
        f" vs_bare = wall time / bare one-world wall time of the same repetition"
    ]
    for count in ctx.plan.crowd_sizes:
        size_rows = crowd_rows(count, ctx)
        rows += size_rows
        notes.append(f"{count} dogs: fastest with the controller: {fastest_variant(size_rows)}")
    return Section(f"Crowds of {CROWD_SPECIES}s walking ({CROWD_CONTROLLER}), using both cores", rows, notes)


def fastest_variant(rows: Sequence[Row]) -> str:
    """The controlled variant with the highest real-time factor among `rows`."""
    measured = [r for r in rows if r.labels["variant"] in CONTROLLED_VARIANTS and "realtime" in r.figures]
    if not measured:
        return "none measured"
    best = max(measured, key=lambda r: r.figures["realtime"].value)
    return f"{best.labels['variant']} ({best.figures['realtime'].value:.3g} x realtime)"


@dataclass
class VariantSamples:
    """Wall times and statuses of the crowd variants, and the variants that failed."""

    walls: dict[str, list[float]] = field(default_factory=dict)
    statuses: dict[str, list[str]] = field(default_factory=dict)
    errors: dict[str, str] = field(default_factory=dict)

    def attempt(self, variant: str, action: Callable[[], Any]) -> Any:
        """`action()`, or None with `variant` marked failed if it raises (or had failed before)."""
        if variant in self.errors:
            return None
        try:
            return action()
        except Exception as exc:  # one failing variant must not stop the others
            self.errors[variant] = error_text(exc)
            return None

    def measure(self, variant: str, action: Callable[[], tuple[float, str]]) -> None:
        """Record one repetition of `variant`: `action` returns its wall time and status."""
        result = self.attempt(variant, action)
        if result is not None:
            wall, status = result
            self.walls.setdefault(variant, []).append(wall)
            self.statuses.setdefault(variant, []).append(status)


def crowd_rows(count: int, ctx: Context) -> list[Row]:
    """Every variant for one crowd size, repetitions interleaved (so load drift hits all alike)."""
    plan = ctx.plan
    whole = crowd_world(write_crowd_scene(count, ctx.folder))
    steps = whole.steps(plan.crowd_seconds)
    split = count >= SPLIT_WORLDS and count % SPLIT_WORLDS == 0
    halves = (
        [crowd_world(write_crowd_scene(count // SPLIT_WORLDS, ctx.folder)) for _ in range(SPLIT_WORLDS)]
        if split
        else []
    )
    samples = VariantSamples()
    workers = (
        WorkerPair(write_crowd_scene(count // SPLIT_WORLDS, ctx.folder), steps, plan.crowd_repeats) if split else None
    )
    try:
        warm_up([whole, *halves])
        if workers is not None:
            samples.attempt(V_TWO_PROCESSES, workers.ready)
        for _ in range(plan.crowd_repeats):
            samples.measure(V_ONE_THREAD, lambda: one_thread(whole, steps))
            samples.measure(V_BARE_ONE, lambda: bare_one(whole, steps))
            if split:
                samples.measure(V_TWO_THREADS, lambda: two_threads(halves, steps))
                samples.measure(V_BARE_ROLLOUT, lambda: bare_rollout(halves, steps))
                samples.measure(V_TWO_PROCESSES, workers.repetition)
    finally:
        if workers is not None:
            workers.close()
    simulated = steps * whole.model.opt.timestep
    return [
        crowd_row(count, variant, samples, simulated, steps)
        for variant in (*CONTROLLED_VARIANTS, V_BARE_ONE, V_BARE_ROLLOUT)
    ]


def crowd_row(count: int, variant: str, samples: VariantSamples, simulated: float, steps: int) -> Row:
    """One crowd variant's row: real-time factor, wall per step, ratio to bare one-world stepping."""
    labels = {"dogs": count, "variant": variant}
    if variant in samples.errors:
        return Row(labels, status=samples.errors[variant])
    if variant not in samples.walls:
        return Row(labels, status=f"not run: {count} dog(s) cannot be split in {SPLIT_WORLDS} equal worlds")
    walls = samples.walls[variant]
    figures = {
        "realtime": figure([simulated / w for w in walls], "x realtime", "higher"),
        "step": figure([1e6 * w / steps for w in walls], "us/step"),
    }
    if V_BARE_ONE in samples.walls:
        figures["vs_bare"] = figure(paired(walls, samples.walls[V_BARE_ONE]), "x bare")
    return Row(labels, figures, worst_status(samples.statuses[variant]))


def warm_up(worlds: Sequence[World]) -> None:
    """A few controlled and bare steps on each world, untimed (first-call caches)."""
    for world in worlds:
        step_run(world.controlled_run(CROWD_CONTROLLER), WARM_UP_STEPS)
        world.reset()
        world.step_bare(WARM_UP_STEPS)


def one_thread(world: World, steps: int) -> tuple[float, str]:
    """The whole crowd in one world, stepped with its controller on this thread."""
    run = world.controlled_run(CROWD_CONTROLLER)
    wall = timed(lambda: step_run(run, steps))
    return wall, world.status()


def bare_one(world: World, steps: int) -> tuple[float, str]:
    """The whole crowd, bare `mj_step` from the same start."""
    world.reset()
    wall = timed(lambda: world.step_bare(steps))
    return wall, world.status()


def two_threads(worlds: Sequence[World], steps: int) -> tuple[float, str]:
    """Two half crowds, each with its controller, stepped on two threads at once.

    MuJoCo releases the GIL inside `mj_step1/2`; the controllers' Python does not, so the
    threads overlap only in the physics.
    """
    runs = [world.controlled_run(CROWD_CONTROLLER) for world in worlds]
    barrier = threading.Barrier(len(runs) + 1)
    with ThreadPoolExecutor(len(runs)) as pool:
        futures = [pool.submit(_step_after, barrier, run, steps) for run in runs]
        barrier.wait()
        start = time.perf_counter()
        for future in futures:
            future.result()
        wall = time.perf_counter() - start
    return wall, worst_status([world.status() for world in worlds])


def _step_after(barrier: threading.Barrier, run: Simulation, steps: int) -> None:
    barrier.wait()
    step_run(run, steps)


def bare_rollout(worlds: Sequence[World], steps: int) -> tuple[float, str]:
    """Two half crowds, bare, stepped by `mujoco.rollout` on two threads (no Python per step)."""
    import mujoco
    import numpy as np
    from mujoco import rollout

    full = mujoco.mjtState.mjSTATE_FULLPHYSICS
    size = mujoco.mj_stateSize(worlds[0].model, full)
    initial = np.empty((len(worlds), size))
    for index, world in enumerate(worlds):
        world.reset()
        mujoco.mj_getState(world.model, world.data, initial[index], full)
    states = np.empty((len(worlds), steps, size))
    models, datas = [w.model for w in worlds], [w.data for w in worlds]
    wall = timed(lambda: rollout.rollout(models, datas, initial, nstep=steps, state=states))
    finite = bool(np.isfinite(states[:, -1]).all())
    return wall, "ok" if finite else "blew-up"


class WorkerPair:
    """Two worker processes, each stepping a half crowd with its controller, timed together.

    The workers build their worlds (untimed), then meet this process at a barrier before and
    after each repetition; the wall time between the two meetings is the repetition's.
    """

    def __init__(self, scene_path: Path, steps: int, repeats: int):
        import multiprocessing

        context = multiprocessing.get_context("spawn")
        self.barrier = context.Barrier(SPLIT_WORLDS + 1)
        self.results = context.Queue()
        self.processes = [
            context.Process(
                target=crowd_worker, args=(str(scene_path), steps, repeats, self.barrier, self.results), daemon=True
            )
            for _ in range(SPLIT_WORLDS)
        ]
        for process in self.processes:
            process.start()

    def ready(self) -> None:
        """Wait until both workers have built their worlds."""
        self._meet()

    def repetition(self) -> tuple[float, str]:
        """Let both workers run one repetition; its wall time and their worst status."""
        self._meet()
        start = time.perf_counter()
        self._meet()
        wall = time.perf_counter() - start
        return wall, worst_status([self.results.get(timeout=WORKER_TIMEOUT_S) for _ in self.processes])

    def _meet(self) -> None:
        """Wait at the barrier with both workers; raise with their messages if one failed."""
        try:
            self.barrier.wait(WORKER_TIMEOUT_S)
        except threading.BrokenBarrierError:
            problems = []
            while not self.results.empty():
                problems.append(str(self.results.get(timeout=1.0)))
            raise RuntimeError("a crowd worker process failed: " + ("; ".join(problems) or "no message")) from None

    def close(self) -> None:
        """Stop the workers (they are done, or failed)."""
        self.barrier.abort()
        for process in self.processes:
            process.join(timeout=10.0)
            if process.is_alive():
                process.terminate()


def crowd_worker(scene_path: str, steps: int, repeats: int, barrier: Any, results: Any) -> None:
    """Worker process: build a half crowd, then step it once per repetition between two barriers."""
    try:
        world = crowd_world(Path(scene_path))
        warm_up([world])
        barrier.wait(WORKER_TIMEOUT_S)
        for _ in range(repeats):
            run = world.controlled_run(CROWD_CONTROLLER)
            barrier.wait(WORKER_TIMEOUT_S)
            step_run(run, steps)
            barrier.wait(WORKER_TIMEOUT_S)
            results.put(world.status())
    except threading.BrokenBarrierError:
        return
    except Exception as exc:  # reported to the parent, which records the variant as failed
        results.put(error_text(exc))
        barrier.abort()


# --------------------------------------------------------------------------- bake and start-up


def quadpipe_command() -> list[str]:
    """How to start the CLI: the venv's `quadpipe` script beside this Python, else `python -m quadpipe`."""
    script = Path(sys.executable).parent / "quadpipe"
    return [str(script)] if script.is_file() else [sys.executable, "-m", "quadpipe"]


def run_command(command: Sequence[str]) -> None:
    """Run a command from the repository root, quietly; raise with its stderr if it fails."""
    done = subprocess.run(list(command), cwd=REPO, capture_output=True, text=True, timeout=SUBPROCESS_TIMEOUT_S)
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(command)} exited {done.returncode}: {done.stderr.strip()[-500:]}")


def bench_bake(ctx: Context) -> Section:
    """The whole `quadpipe bake` of a dog walk to .glb and .usdc as a shell command, beside the
    same simulation and exports done in this process."""
    from quadpipe.exporters import export_clip
    from quadpipe.sim.simulation import simulate

    seconds = ctx.plan.clip_seconds
    outputs = [ctx.folder / f"bake{suffix}" for suffix in BAKE_FORMATS]
    command = [
        *quadpipe_command(),
        "bake",
        "--animal",
        BAKE_ANIMAL,
        "--controller",
        BAKE_CONTROLLER,
        "--scene",
        BENCH_SCENE,
        "--seconds",
        f"{seconds:g}",
    ]
    for output in outputs:
        command += ["-o", str(output)]

    def in_process() -> None:
        ctx.clip = simulate(BAKE_ANIMAL, BAKE_CONTROLLER, seconds=seconds, scene=BENCH_SCENE).clip
        for output in outputs:
            export_clip(ctx.clip, output.with_stem("in_process"))

    labels = {"bake": f"{BAKE_ANIMAL} {BAKE_CONTROLLER} {seconds:g} s -> {' '.join(BAKE_FORMATS)}"}
    try:
        warm = simulate(BAKE_ANIMAL, BAKE_CONTROLLER, seconds=WARM_UP_CLIP_S, scene=BENCH_SCENE).clip
        for output in outputs:
            export_clip(warm, output.with_stem("warm_up"))
        shell, local = [], []
        for _ in range(ctx.plan.bake_runs):
            shell.append(timed(lambda: run_command(command)))
            local.append(timed(in_process))
    except Exception as exc:  # recorded: the other sections still run
        return Section("Bake", [Row(labels, status=error_text(exc))])
    figures = {
        "command": figure(shell, "s"),
        "in_process": figure(local, "s"),
        "outside_work": figure([whole - inside for whole, inside in zip(shell, local)], "s"),
    }
    note = "command: the whole bake from the shell, start-up included; in_process: the same simulation and exports in this process"
    return Section("Bake (subprocess)", [Row(labels, figures)], [note])


def bench_startup(ctx: Context) -> Section:
    """`quadpipe --help` start-up time beside a bare `python -c pass`."""
    help_command = [*quadpipe_command(), "--help"]
    python_command = [sys.executable, "-c", "pass"]
    labels = {"command": "quadpipe --help"}
    try:
        cli, python = [], []
        for _ in range(ctx.plan.startup_runs):
            cli.append(timed(lambda: run_command(help_command)))
            python.append(timed(lambda: run_command(python_command)))
    except Exception as exc:  # recorded: the other sections still run
        return Section("Start-up", [Row(labels, status=error_text(exc))])
    figures = {
        "wall": figure(cli, "s"),
        "python": figure(python, "s"),
        "above_python": figure([c - p for c, p in zip(cli, python)], "s"),
    }
    return Section("Start-up", [Row(labels, figures)], ["python: `python -c pass`, the floor any Python CLI pays"])


# --------------------------------------------------------------------------- exporters and render


def bench_exporters(ctx: Context) -> Section:
    """Milliseconds to write one recorded dog walk in every supported format."""
    from quadpipe.exporters import export_clip, supported_formats

    clip = ctx.walk_clip()
    formats = supported_formats()
    folder = ctx.folder / "exports"
    folder.mkdir(exist_ok=True)
    times: dict[str, list[float]] = {f.suffix: [] for f in formats if f.available}
    errors: dict[str, str] = {f.suffix: f"unavailable: {f.install_hint}" for f in formats if not f.available}
    for _ in range(ctx.plan.export_repeats):
        for suffix in list(times):
            try:
                times[suffix].append(timed(lambda suffix=suffix: export_clip(clip, folder / f"clip{suffix}")))
            except Exception as exc:  # recorded: the other formats still run
                errors[suffix] = error_text(exc)
                del times[suffix]
    rows = []
    for fmt in formats:
        labels = {"format": fmt.suffix, "clip_s": round(clip.duration, 3)}
        if fmt.suffix in errors:
            rows.append(Row(labels, status=errors[fmt.suffix]))
            continue
        figures = {
            "export": figure([1e3 * t for t in times[fmt.suffix]], "ms"),
            "size": figure([(folder / f"clip{fmt.suffix}").stat().st_size / 1024.0], "KiB"),
        }
        if ".npz" in times:
            figures["vs_npz"] = figure(paired(times[fmt.suffix], times[".npz"]), "x npz")
        rows.append(Row(labels, figures))
    note = f"one {clip.duration:g} s clip of {len(clip.animals)} animal(s), {clip.frame_count} frames; vs_npz: time over the raw .npz dump"
    return Section("Exporters", rows, [note])


def bench_render(ctx: Context) -> Section:
    """Headless rendering speed of the dog walk at 640x480 (`quadpipe.render.render_fps`)."""
    from quadpipe.render import gl_backend, render_fps

    clip = ctx.walk_clip()
    labels = {"size": f"{RENDER_WIDTH}x{RENDER_HEIGHT}", "frames": ctx.plan.render_frames}
    try:
        labels["backend"] = gl_backend()
        rates = [
            render_fps(clip, frames=ctx.plan.render_frames, width=RENDER_WIDTH, height=RENDER_HEIGHT)
            for _ in range(ctx.plan.render_repeats)
        ]
    except Exception as exc:  # recorded: no OpenGL here must not stop the other sections
        return Section("Headless render", [Row(labels, status=error_text(exc))])
    figures = {
        "fps": figure(rates, "frames/s", "higher"),
        "realtime": figure([r / clip.fps for r in rates], "x realtime", "higher"),
    }
    note = f"default overlays, display model built outside the timing; realtime = fps / the clip's {clip.fps:g} fps"
    return Section("Headless render", [Row(labels, figures)], [note])


def bench_batch(ctx: Context) -> Section:
    """`quadpipe batch` of animals x every shipped controller to .glb, on 2 workers beside 1."""
    from quadpipe.batch import BatchPlan, Outcome, run_batch
    from quadpipe.core import configs

    animals = list(ctx.plan.batch_animals or configs.available("animals"))
    controllers = configs.available("controllers")
    labels = {
        "batch": f"{len(animals)} animals x {len(controllers)} controllers, {ctx.plan.batch_seconds:g} s each -> .glb"
    }
    walls, outcomes = {}, {}
    try:
        for workers in (2, 1):
            plan = BatchPlan(
                animals=animals,
                controllers=controllers,
                seconds=ctx.plan.batch_seconds,
                formats=["glb"],
                output=str(ctx.folder / f"batch_j{workers}"),
            )
            start = time.perf_counter()
            report = run_batch(plan, workers=workers, force=True, progress=False)
            walls[workers] = time.perf_counter() - start
            outcomes[workers] = report.count(Outcome.ok)
    except Exception as exc:  # recorded: the other sections still run
        return Section("Batch", [Row(labels, status=error_text(exc))])
    figures = {
        "j2_wall": figure([walls[2]], "s"),
        "j1_wall": figure([walls[1]], "s"),
        "speedup": figure([walls[1] / walls[2]], "x", "higher"),
        "jobs_ok": figure([outcomes[2]], "jobs", "higher"),
    }
    note = "jobs that blow up or fail count as done (they are reported in the batch's summary, not here)"
    return Section("Batch", [Row(labels, figures)], [note])


SECTIONS: dict[str, Callable[[Context], Section]] = {
    "controllers": bench_controllers,
    "crowds": bench_crowds,
    "bake": bench_bake,
    "startup": bench_startup,
    "exporters": bench_exporters,
    "render": bench_render,
    "batch": bench_batch,
}
"""Every benchmark, in the order they run."""


# --------------------------------------------------------------------------- machine


def machine_info() -> dict[str, Any]:
    """What the figures were measured on: CPU, cores, OS, versions, commit, load."""
    import mujoco
    import numpy

    import quadpipe

    return {
        "cpu": cpu_model(),
        "logical_cores": os.cpu_count(),
        "usable_cores": len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count(),
        "os": platform.platform(),
        "python": platform.python_version(),
        "mujoco": mujoco.__version__,
        "numpy": numpy.__version__,
        "quadpipe": quadpipe.__version__,
        **git_state(),
        "mujoco_gl": os.environ.get("MUJOCO_GL", ""),
        "load_average_start": list(os.getloadavg()),
    }


def cpu_model() -> str:
    """The CPU's model name (from /proc/cpuinfo on Linux)."""
    cpuinfo = Path("/proc/cpuinfo")
    if cpuinfo.is_file():
        for line in cpuinfo.read_text().splitlines():
            if line.startswith("model name"):
                return line.partition(":")[2].strip()
    return platform.processor() or platform.machine()


def measured_tree() -> Path:
    """The checkout whose `quadpipe` these figures time: the first on the path, which is
    another tree's when this script runs with `PYTHONPATH` set to it (comparing two commits)."""
    spec = importlib.util.find_spec("quadpipe")
    return Path(spec.origin).resolve().parent.parent if spec is not None and spec.origin else REPO


def git_state() -> dict[str, Any]:
    """The measured tree's commit and whether it has changes (read-only git calls)."""
    if shutil.which("git") is None:
        return {"git_commit": None, "git_dirty": None}
    env = dict(os.environ, GIT_OPTIONAL_LOCKS="0")
    tree = measured_tree()
    head = subprocess.run(["git", "rev-parse", "HEAD"], cwd=tree, capture_output=True, text=True, env=env)
    status = subprocess.run(["git", "status", "--porcelain"], cwd=tree, capture_output=True, text=True, env=env)
    ok = head.returncode == 0 and status.returncode == 0
    return {"git_commit": head.stdout.strip() if ok else None, "git_dirty": bool(status.stdout.strip()) if ok else None}


# --------------------------------------------------------------------------- running and printing


def run_benchmarks(plan: Plan, names: Sequence[str]) -> dict[str, Any]:
    """Run the named sections, printing each table as it finishes; the whole report as a dict."""
    from rich.console import Console

    console = Console(width=None if sys.stdout.isatty() else PIPE_COLUMNS)
    report: dict[str, Any] = {
        "schema": REPORT_SCHEMA,
        "mode": plan.name,
        "plan": asdict(plan),
        "started": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "machine": machine_info(),
        "sections": {},
    }
    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="quadpipe-bench-") as folder:
        ctx = Context(plan, Path(folder))
        for name in names:
            console.print(f"[bold]running {name}[/bold] ...")
            began = time.perf_counter()
            try:
                section = SECTIONS[name](ctx)
            except Exception as exc:  # recorded as the section's result: the other sections still run
                section = Section(name, [Row({"section": name}, status=error_text(exc))])
            section.wall_s = time.perf_counter() - began
            report["sections"][name] = asdict(section)
            print_section(console, name, report["sections"][name])
    report["wall_s"] = time.perf_counter() - start
    report["machine"]["load_average_end"] = list(os.getloadavg())
    return report


def number(value: float) -> str:
    """A figure for a table: three significant digits, no exponent for everyday magnitudes."""
    if value != 0 and (abs(value) >= 1e6 or abs(value) < 1e-3):
        return f"{value:.3g}"
    digits = max(0, 2 - math.floor(math.log10(abs(value)))) if value else 0
    return f"{value:.{digits}f}"


def print_section(console: Any, name: str, section: dict[str, Any]) -> None:
    """One section as a table: labels, status, then every figure (median) with its unit."""
    from rich.table import Table

    rows = section["rows"]
    label_names = list(dict.fromkeys(key for row in rows for key in row["labels"]))
    units = {n: f["unit"] for row in rows for n, f in row["figures"].items()}
    table = Table(title=f"{name}: {section['title']} ({section['wall_s']:.1f} s)", title_justify="left")
    for label in label_names:
        table.add_column(label)
    for figure_name, unit in units.items():
        table.add_column(f"{figure_name}\n{unit}", justify="right")
    table.add_column("status")
    for row in rows:
        cells = [str(row["labels"].get(label, "")) for label in label_names]
        cells += [number(row["figures"][n]["value"]) if n in row["figures"] else "-" for n in units]
        table.add_row(*cells, row["status"])
    console.print(table)
    for note in section["notes"]:
        console.print(f"  {note}")


def flat_figures(report: dict[str, Any]) -> dict[str, dict[str, Any]]:
    """Every figure of a report by a readable key: `section | labels | figure`."""
    flat = {}
    for name, section in report["sections"].items():
        for row in section["rows"]:
            labels = " ".join(str(value) for value in row["labels"].values())
            for figure_name, fig in row["figures"].items():
                flat[f"{name} | {labels} | {figure_name}"] = fig
    return flat


def verdict(ratio: float, better: str) -> str:
    """`better`, `worse` or `~` (within CHANGE_FRACTION) for a new/old ratio."""
    if abs(ratio - 1.0) <= CHANGE_FRACTION:
        return "~"
    improved = ratio < 1.0 if better == "lower" else ratio > 1.0
    return "better" if improved else "worse"


def print_comparison(old: dict[str, Any], new: dict[str, Any]) -> None:
    """Old vs new, figure by figure, with new/old ratios; figures in only one side are listed."""
    from rich.console import Console
    from rich.table import Table

    console = Console(width=None if sys.stdout.isatty() else PIPE_COLUMNS)
    before, after = flat_figures(old), flat_figures(new)
    table = Table(
        title=f"old ({old['mode']}, {old['started']}) vs new ({new['mode']}, {new['started']})", title_justify="left"
    )
    for header, justify in (
        ("figure", "left"),
        ("unit", "left"),
        ("old", "right"),
        ("new", "right"),
        ("new/old", "right"),
        ("", "left"),
    ):
        table.add_column(header, justify=justify)
    for key in [k for k in after if k in before]:
        was, now = before[key]["value"], after[key]["value"]
        ratio = now / was if was else math.inf
        table.add_row(
            key, after[key]["unit"], number(was), number(now), f"{ratio:.2f}", verdict(ratio, after[key]["better"])
        )
    console.print(table)
    for side, keys in (
        ("only in old", [k for k in before if k not in after]),
        ("only in new", [k for k in after if k not in before]),
    ):
        if keys:
            console.print(f"{side}: {len(keys)} figures (e.g. {keys[0]})")
    for key in ("cpu", "git_commit", "mujoco"):
        if old["machine"].get(key) != new["machine"].get(key):
            console.print(f"note: {key} differs: {old['machine'].get(key)} -> {new['machine'].get(key)}")


def load_report(path: Path) -> dict[str, Any]:
    """A JSON report written by this script."""
    report = json.loads(Path(path).read_text())
    if report.get("schema") != REPORT_SCHEMA:
        raise SystemExit(f"{path}: not a quadpipe benchmark report of schema {REPORT_SCHEMA}")
    return report


def pool_reports(reports: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """One report of several runs of the same sections (alternated with another tree's runs, to
    compare two trees at the same moments): every figure's samples of every run together, its
    value their median (ratios stay the per-repetition ratios of each run). The first report's
    plan and machine; each run's start, commit and load in `pooled_from`."""
    pooled = json.loads(json.dumps(reports[0]))
    for name, section in pooled["sections"].items():
        for row in section["rows"]:
            for key, value in row["figures"].items():
                value["samples"] = [
                    sample
                    for report in reports
                    for other in report["sections"][name]["rows"]
                    if other["labels"] == row["labels"] and key in other["figures"]
                    for sample in other["figures"][key]["samples"]
                ]
                value["value"] = statistics.median(value["samples"])
        section["notes"].append(
            f"pooled: the samples of {len(reports)} runs (pooled_from); value = median of all samples"
        )
    machines = [report["machine"] for report in reports]
    pooled["pooled_from"] = [
        {"started": report["started"]} | {key: machine.get(key) for key in POOLED_MACHINE_KEYS}
        for report, machine in zip(reports, machines)
    ]
    return pooled


POOLED_MACHINE_KEYS = ("git_commit", "git_dirty", "load_average_start", "load_average_end")
"""What `pool_reports` keeps of each run's machine."""


def parse_args(argv: Sequence[str] | None) -> argparse.Namespace:
    """The command line (see the module docstring)."""
    parser = argparse.ArgumentParser(description="quadpipe benchmarks (see benchmarks/README.md).")
    parser.add_argument("--quick", action="store_true", help="a small version of every benchmark (under a minute)")
    parser.add_argument(
        "--json", type=Path, default=DEFAULT_JSON, help="where to write the results (default out/bench.json)"
    )
    parser.add_argument(
        "--only",
        nargs="+",
        choices=list(SECTIONS),
        metavar="SECTION",
        help=f"run only these sections: {', '.join(SECTIONS)}",
    )
    parser.add_argument(
        "--animals",
        nargs="+",
        metavar="ANIMAL",
        help="time the controllers section on these animals only (e.g. --animals dog)",
    )
    parser.add_argument(
        "--cpu-time",
        action="store_true",
        help="the controllers section counts this thread's CPU time, not wall time (a machine loaded beyond its cores)",
    )
    parser.add_argument(
        "--compare",
        nargs="+",
        type=Path,
        metavar="JSON",
        help="OLD: run, then print old vs new; OLD NEW: compare two reports without running",
    )
    parser.add_argument(
        "--unfolded-too",
        action="store_true",
        help="the controllers section also times each program unfolded, interleaved (the folding's gain)",
    )
    parser.add_argument(
        "--pool",
        nargs="+",
        type=Path,
        metavar="JSON",
        help="no run: pool these reports' samples (runs of one tree) into one, written to --json",
    )
    args = parser.parse_args(argv)
    if args.compare and len(args.compare) > 2:
        parser.error("--compare takes OLD, or OLD NEW")
    return args


def main(argv: Sequence[str] | None = None) -> int:
    """Run the benchmarks (or only compare two reports); return the exit status."""
    args = parse_args(argv)
    if args.pool:
        from quadpipe.core.atomic import write_text

        write_text(args.json, json.dumps(pool_reports([load_report(path) for path in args.pool]), indent=1) + "\n")
        print(f"wrote {args.json} (pooled from {len(args.pool)} reports)")
        return 0
    if args.compare and len(args.compare) == 2:
        print_comparison(load_report(args.compare[0]), load_report(args.compare[1]))
        return 0
    old = load_report(args.compare[0]) if args.compare else None
    plan = QUICK if args.quick else FULL
    plan = replace(
        plan,
        controller_animals=tuple(args.animals) if args.animals else None,
        cpu_time=args.cpu_time,
        unfolded=args.unfolded_too,
    )
    report = run_benchmarks(plan, args.only or list(SECTIONS))
    from quadpipe.core.atomic import write_text

    args.json.parent.mkdir(parents=True, exist_ok=True)
    write_text(args.json, json.dumps(report, indent=1) + "\n")
    print(f"wrote {args.json} ({report['wall_s']:.1f} s)")
    if old is not None:
        print_comparison(old, report)
    return 0


if __name__ == "__main__":
    sys.exit(main())
