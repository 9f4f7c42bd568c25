"""The simulation loop: fixed steps, controllers, frames recorded into a clip, blow-ups caught.

The thesis steps physics at 1/120 s, 4 steps per displayed frame at 30 fps. Animals that need
smaller steps (see `quadpipe.animals.sizing`) split each of those steps into substeps; the controller
runs at every physics step. MuJoCo resets silently on a NaN: here any NaN, bad-acceleration
warning or body flung far away stops the run with a message naming the frame and the controller.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Protocol, Sequence

import mujoco
import numpy as np

from quadpipe.sim import health as physics
from quadpipe.animals import sizing
from quadpipe.clip.model import Clip
from quadpipe.core.errors import QuadpipeError
from quadpipe.sim.recording import Recorder
from quadpipe.world.placement import Placement

FPS_TOLERANCE = 1e-9
"""Relative difference below which a frame rate divides the physics rate."""

MIN_SUGGESTED_FPS = 10
"""Frame rates below this are not suggested when a frame rate is refused."""

FAR_AWAY_HP = 1000.0
"""A body farther than this many pelvis heights from the origin has been flung away: a blow-up."""


class Controller(Protocol):
    """What the loop needs from a controller: a name, and forces applied before each step.

    A controller may also offer `frame_values(data) -> dict[str, array]`: values recorded into
    the clip's `sensors` once per frame.
    """

    name: str

    def apply(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """Write this step's forces (into `data.xfrc_applied` / `data.qfrc_applied`)."""


@dataclass
class SimulationBlowUp(QuadpipeError):
    """The simulation diverged (NaN, bad acceleration, a body flung away)."""


@dataclass
class Run:
    """A prepared world, ready to step.

    Attributes:
        model: the compiled world.
        data: its state.
        placements: the animals in it.
        controllers: run before every physics step, in order.
        events: callables run before every physics step with (model, data) — scene events
            such as throws.
    """

    model: mujoco.MjModel
    data: mujoco.MjData
    placements: Sequence[Placement]
    controllers: list[Controller] = field(default_factory=list)
    events: list[Callable[[mujoco.MjModel, mujoco.MjData], None]] = field(default_factory=list)

    def step(self) -> None:
        """One physics step: events, then `mj_step1`, controllers on the current state, `mj_step2`."""
        for event in self.events:
            event(self.model, self.data)
        mujoco.mj_step1(self.model, self.data)
        self.data.xfrc_applied[:] = 0.0
        self.data.qfrc_applied[:] = 0.0
        for controller in self.controllers:
            controller.apply(self.model, self.data)
        mujoco.mj_step2(self.model, self.data)


def frame_steps(timestep: float, fps: float) -> int:
    """Physics steps per recorded frame: the physics rate divided by `fps`.

    Raises:
        QuadpipeError: `fps` does not divide the physics rate (1 / timestep), or exceeds it.
    """
    rate = 1.0 / timestep
    steps = round(rate / fps) if fps > 0 else 0
    if steps >= 1 and abs(rate / steps - fps) <= FPS_TOLERANCE * fps:
        return steps
    choices = [rate / k for k in range(1, round(rate) + 1) if (rate / k).is_integer() and rate / k >= MIN_SUGGESTED_FPS]
    raise QuadpipeError.single(
        "bad-fps",
        f"{fps:g} frames per second does not divide this simulation's {rate:g} physics steps per second",
        hint=f"record at one of {', '.join(f'{c:g}' for c in sorted(choices))} fps",
    )


def run_frames(
    run: Run,
    seconds: float,
    metadata: dict[str, str] | None = None,
    on_frame: Callable[[float], None] | None = None,
    fps: float = sizing.FRAME_RATE,
) -> Clip:
    """Simulate `seconds` and record one frame every 1/fps s (the first frame is the start).

    Args:
        run: the prepared world.
        seconds: simulated time.
        metadata: kept in the clip.
        on_frame: called with the simulated time after every frame (progress, interruption).
        fps: recorded frames per second; must divide the physics rate (see `frame_steps`).

    Raises:
        SimulationBlowUp: on a NaN, a bad-acceleration warning or a body flung far away.
        QuadpipeError: `fps` does not divide the physics rate.
    """
    steps = frame_steps(run.model.opt.timestep, fps)
    recorder = Recorder(run.model, run.placements, fps)
    frames = round(seconds * fps)
    far = FAR_AWAY_HP * max(p.built.animal.pelvis_height for p in run.placements)
    mujoco.mj_forward(run.model, run.data)
    recorder.capture(run.data, frame_values(run))
    for frame in range(1, frames + 1):
        for _ in range(steps):
            run.step()
        check_health(run, frame, far, fps)
        recorder.capture(run.data, frame_values(run))
        if on_frame is not None:
            on_frame(run.data.time)
    return recorder.clip({"status": "ok", **(metadata or {})})


def frame_values(run: Run) -> dict[str, np.ndarray]:
    """The per-frame values the controllers offer (sensors, injected force and power)."""
    values: dict[str, np.ndarray] = {}
    for controller in run.controllers:
        offer = getattr(controller, "frame_values", None)
        if offer is not None:
            values.update(offer(run.data))
    return values


def check_health(run: Run, frame: int, far: float, fps: float = sizing.FRAME_RATE) -> None:
    """Raise `SimulationBlowUp` if the state is not finite, MuJoCo warned, or a body flew away."""
    data = run.data
    problem = None
    if not physics.is_finite(data):
        problem = "positions or velocities became NaN or infinite"
    elif data.warning[mujoco.mjtWarning.mjWARN_BADQACC].number:
        problem = "MuJoCo reported a bad acceleration (the state diverged)"
    elif np.abs(data.xpos).max() > far:
        problem = "a body was flung more than 1000 pelvis heights away"
    if problem is None:
        return
    names = ", ".join(c.name for c in run.controllers) or "no controller"
    raise SimulationBlowUp.single(
        "simulation-blew-up",
        f"the simulation blew up at frame {frame} (t = {frame / fps:.2f} s) under {names}: {problem}",
        hint="forces are too strong for this animal or step: lower the controller's strengths, or check the scene",
    )


DEFAULT_SCENE = "flat"
"""The scene used when none is named: flat ground, a goal ahead."""

FALL_HEIGHT_HP = 0.4
"""An animal whose pelvis drops below this many pelvis heights has fallen."""


@dataclass
class Result:
    """A finished simulation: the clip, its metrics, and the runtime (for inspection in tests)."""

    clip: Clip
    metrics: dict
    runtime: object | None


def simulate(
    animal: str,
    controller: str | None,
    *,
    seconds: float,
    scene: str | None = None,
    parameters: dict[str, str] | None = None,
    extra_controllers: Sequence[Controller] = (),
    on_frame: Callable[[float], None] | None = None,
    fps: float = sizing.FRAME_RATE,
) -> Result:
    """Build an animal (and scene), run a controller on it, and return the clip and its metrics.

    Args:
        animal: animal name or config path.
        controller: controller name or path (None: a passive ragdoll).
        seconds: simulated time.
        scene: scene name or path (None: `flat`).
        parameters: controller parameter overrides (YAML values: "2 HP", "[1, 0, 0]").
        extra_controllers: more `Controller`s run after the main one (tests push with these).
        on_frame: called with the simulated time after every frame (progress, interruption).
        fps: recorded frames per second (30, the thesis's; a rat's walk needs more to be
            analysed: its stride lasts 0.17 s).
    """
    from quadpipe.animals.library import load_animal
    from quadpipe.animals.model import build_animal
    from quadpipe.controllers.runtime.runtime import build_runtime
    from quadpipe.world import build_scene, load_scene

    built = build_animal(load_animal(animal))
    scene_spec = load_scene(scene or DEFAULT_SCENE)
    setup = build_scene(scene_spec, built)
    model = setup.spec.compile()
    data = mujoco.MjData(model)
    runtime = (
        build_runtime(controller, model, setup.placements, parameters, scene_parameters=setup.goal_parameters)
        if controller
        else None
    )
    controllers = ([runtime] if runtime else []) + list(extra_controllers)
    run = Run(model, data, setup.placements, controllers, events=setup.events(model))
    metadata = {"controller": controller or "none", "scene": scene_spec.name, "animal": built.animal.name}
    clip = run_frames(run, seconds, metadata, on_frame, fps)
    return Result(clip, clip_metrics(clip), runtime)


def _injected(clip: Clip, track) -> dict:
    """Net external force and work the controller injected (couples cancel; pulls do not)."""
    force = clip.sensors.get(f"controller_force:{track.name}")
    power = clip.sensors.get(f"controller_power:{track.name}")
    if force is None or power is None:
        return {}
    weight = track.mass_kg * sizing.GRAVITY
    return {
        "net_force_mean_bw": float(np.linalg.norm(force, axis=1).mean() / weight),
        "net_force_max_bw": float(np.linalg.norm(force, axis=1).max() / weight),
        "work_j": float(power[1:].sum() / clip.fps),
        "work_j_per_kg_m": float(power[1:].sum() / clip.fps / track.mass_kg / max(np.linalg.norm(track.positions[-1, 0, :2] - track.positions[0, 0, :2]), 1e-9)),
    }


def clip_metrics(clip: Clip) -> dict:
    """Per-animal figures of a clip: distance, speed, pelvis heights, falls (lengths also in HP)."""
    animals = {}
    for track in clip.animals:
        hp = track.pelvis_height
        pelvis = track.positions[:, 0]
        travel = pelvis[-1, :2] - pelvis[0, :2]
        heights = pelvis[:, 2]
        fallen = heights < FALL_HEIGHT_HP * hp
        animals[track.name] = {
            "distance_m": float(np.linalg.norm(travel)),
            "distance_hp": float(np.linalg.norm(travel) / hp),
            "forward_hp": float(travel[0] / hp),
            "speed_m_s": float(np.linalg.norm(travel) / max(clip.duration, 1e-9)),
            "pelvis_height_min_hp": float(heights.min() / hp),
            "pelvis_height_max_hp": float(heights.max() / hp),
            "fell": bool(fallen.any()),
            "first_fall_s": float(np.argmax(fallen) / clip.fps) if fallen.any() else None,
            **_injected(clip, track),
        }
    return {"duration_s": clip.duration, "frames": clip.frame_count, "animals": animals}
