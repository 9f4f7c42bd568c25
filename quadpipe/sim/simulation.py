"""The simulation: a world built for animals, a controller and a scene, stepped and recorded.

`Simulation` owns everything one run needs (the compiled model, its state, the placed
animals, the controller runtime, the scene's events) and is the one place that puts them
together: `simulate()` (the CLI, batches), the live preview and the benchmarks all use it.

The thesis steps physics at 1/120 s, 4 steps per displayed frame at 30 fps. Animals that need
smaller steps (see `quadpipe.animals.sizing`) split each of those steps into substeps; the controller
runs at every physics step. MuJoCo resets silently on a NaN: here any NaN, bad-acceleration
warning or body flung far away stops the run with a message naming the frame and the controller.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Protocol, overload

import mujoco
import numpy as np

from quadpipe.animals import sizing
from quadpipe.clip.model import Clip
from quadpipe.core.errors import Issue, Location, QuadpipeError
from quadpipe.core.limits import FAR_AWAY_HP, check_run
from quadpipe.sim import health as physics
from quadpipe.sim.metrics import clip_metrics
from quadpipe.sim.recording import Recorder
from quadpipe.world.placement import Placement
from quadpipe.world.timeline import DIRECTION_KEY, timelines_json

if TYPE_CHECKING:
    from quadpipe.animals.library import AnimalSource
    from quadpipe.controllers.language.compiler import CompiledController
    from quadpipe.controllers.runtime.runtime import ControllerRuntime
    from quadpipe.controllers.runtime.variation import Variation
    from quadpipe.world import SceneSetup

FPS_TOLERANCE = 1e-9
"""Relative difference below which a frame rate divides the physics rate."""

MIN_SUGGESTED_FPS = 10
"""Frame rates below this are not suggested when a frame rate is refused."""


class Controller(Protocol):
    """What the loop needs from a controller: a name, and forces applied before each step.

    A controller may also offer `frame_values(data) -> dict[str, array]`: values recorded into
    the clip's `sensors` once per frame, and `fault`: a description of a force it could not
    compute (NaN or infinite), which stops the simulation at the end of the frame.
    """

    name: str

    def apply(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """Write this step's forces (into `data.xfrc_applied` / `data.qfrc_applied`)."""


@dataclass
class SimulationBlowUp(QuadpipeError):
    """The simulation diverged (NaN, bad acceleration, a body flung away)."""


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


DEFAULT_SCENE = "flat"
"""The scene used when none is named: flat ground, a goal ahead."""


class Simulation:
    """A compiled world with its animals, their controller and the scene's events, ready to step.

    The one place where a run's pieces are put together and owned: `simulate` (the CLI,
    batches), the live preview and the benchmarks all step a `Simulation`.

    The controller runtime writes its springs' damping into `model.dof_damping` (see
    `quadpipe.controllers.runtime.runtime`); `use_controller` and `reset` release the runtime
    they replace before binding the next one, so every runtime starts from the compiled model.

    Args:
        setup: the scene built for its animals; its `spec` is compiled here.
        extra_controllers: more `Controller`s run after the runtime (tests push with these).
        metadata: kept in every recorded clip.
        variation: seeded stride-to-stride variation of the controllers' gaits (None: none).

    Attributes:
        setup: the scene built for its animals.
        model: the compiled world.
        data: its state.
        runtime: the controller runtime driving the animals (None: passive ragdolls); with
            several directed animals, the first group's (see `use_groups`).
        events: the scene's events (props set moving, throws), run before every physics step.
        controllers: run before every physics step, in order: the runtime, then the extra ones.
        far_m: a body farther than this from the origin has been flung away (a blow-up).
        warnings: what the run's inputs warn of, once each (a gait the species does not use, a
            directed path bending tighter than its animal can follow).
        variation: what every controller runtime it makes varies by (None: nothing).
    """

    def __init__(
        self,
        setup: SceneSetup,
        extra_controllers: Sequence[Controller] = (),
        metadata: dict[str, str] | None = None,
        variation: Variation | None = None,
    ):
        physics.keep_mujoco_quiet()
        self.setup = setup
        self.model = setup.spec.compile()
        self.data = mujoco.MjData(self.model)
        self._applied = (self.data.xfrc_applied, self.data.qfrc_applied)  # views made once: cheaper to clear
        self.metadata = dict(metadata or {})
        self.variation = variation
        if variation is not None and variation.active:
            self.metadata |= {"variation": f"{variation.amount:g}", "seed": str(variation.seed)}
        self.warnings: list[Issue] = list(setup.warnings)
        if self.warnings:
            self.metadata["warnings"] = "\n".join(issue.message for issue in self.warnings)
        self.extra_controllers = list(extra_controllers)
        self.runtime: ControllerRuntime | None = None
        self._runtimes: list[ControllerRuntime] = []
        self._groups: list[tuple[list[Placement], CompiledController]] = []
        self.controllers: list[Controller] = list(self.extra_controllers)
        self.events = setup.events(self.model)
        self.far_m = FAR_AWAY_HP * max(p.built.animal.pelvis_height for p in setup.placements)

    @classmethod
    def build(
        cls,
        animal: str | AnimalSource,
        controller: str | None,
        *,
        scene: str | None = None,
        parameters: Mapping[str, str] | None = None,
        extra_controllers: Sequence[Controller] = (),
        places: Mapping[str, Location] | None = None,
        direction: str | Path | None = None,
        variation: Variation | None = None,
    ) -> Simulation:
        """An animal (and the scene's other animals) under a controller, in a scene, at t = 0.

        Args:
            animal: animal name, config or skeleton file, or an `AnimalSource` (a skeleton file with its options).
            controller: controller name or path (None: a passive ragdoll).
            scene: scene name or path (None: `flat`).
            parameters: controller parameter overrides (YAML values: "2 HP", "[1, 0, 0]").
            extra_controllers: more `Controller`s run after the main one.
            places: where each of `parameters` was written (a batch plan's line), for messages.
            direction: a direction file, which replaces the scene's `direction:` (docs/direction.md).
            variation: seeded stride-to-stride variation of the gait (None: none).

        Raises:
            QuadpipeError: the animal, scene, direction or controller cannot be loaded, or do not fit.
        """
        from quadpipe.animals.library import load_animal
        from quadpipe.animals.model import build_animal
        from quadpipe.world import build_scene, load_scene
        from quadpipe.world.direction import load_direction

        built = build_animal(load_animal(animal))
        scene_spec = load_scene(scene or DEFAULT_SCENE)
        metadata = {"controller": controller or "none", "scene": scene_spec.name, "animal": built.animal.name}
        setup = build_scene(scene_spec, built, load_direction(direction) if direction is not None else None)
        if setup.timelines:
            metadata[DIRECTION_KEY] = timelines_json(setup.timelines)
        simulation = cls(setup, extra_controllers, metadata, variation)
        if controller and len(setup.parameter_groups()) > 1:
            simulation.use_groups(simulation.compile_groups(controller, parameters, places=places))
        elif controller:
            compiled, _ = simulation.compile_controller(controller, parameters, places=places)
            simulation.use_controller(compiled)
        return simulation

    @property
    def placements(self) -> Sequence[Placement]:
        """The animals, in scene order."""
        return self.setup.placements

    @property
    def time(self) -> float:
        """Simulated time, seconds."""
        return float(self.data.time)

    # ------------------------------------------------------------------ the controller

    def compile_controller(
        self,
        controller: str,
        parameters: Mapping[str, str] | None = None,
        goals: Mapping[str, str] | None = None,
        *,
        places: Mapping[str, Location] | None = None,
    ) -> tuple[CompiledController, tuple[str, ...]]:
        """A controller compiled for this world's animals, and the files it was read from.

        The controller is offered the scene's goals, and `goals` over them (it takes those it
        declares); `parameters` win over both, and `places` says where they were written.

        Raises:
            QuadpipeError: the files do not validate, or a parameter does not fit them.
        """
        from quadpipe.controllers.runtime.runtime import compile_for

        offered = self.setup.goal_parameters | dict(goals or {})
        places = self.setup.goal_places() | dict(places or {})
        compiled = compile_for(controller, self.placements, parameters, scene_parameters=offered, places=places)
        self._warn_of_gaits(compiled[0])
        return compiled

    def compile_groups(
        self,
        controller: str,
        parameters: Mapping[str, str] | None = None,
        *,
        places: Mapping[str, Location] | None = None,
    ) -> list[tuple[list[Placement], CompiledController]]:
        """A controller compiled once per group of animals that the scene offers its own
        parameters (`SceneSetup.parameter_groups`: each directed animal alone), with the
        group; `parameters` win over the scene's, and `places` says where they were written.

        Raises:
            QuadpipeError: the files do not validate, or a parameter does not fit them.
        """
        from quadpipe.controllers.runtime.runtime import compile_for

        places = self.setup.goal_places() | dict(places or {})
        groups = [
            (group, compile_for(controller, group, parameters, scene_parameters=offered, places=places)[0])
            for group, offered in self.setup.parameter_groups()
        ]
        self._warn_of_gaits(groups[0][1])
        return groups

    def use_groups(self, groups: Sequence[tuple[list[Placement], CompiledController]]) -> None:
        """Drive each group of animals with a fresh runtime of its compiled controller,
        replacing the current runtimes; `runtime` is the first group's."""
        from quadpipe.controllers.runtime.runtime import ControllerRuntime

        self._release()
        self._runtimes = [ControllerRuntime(compiled, self.model, group, self.variation) for group, compiled in groups]
        self._groups = list(groups)
        self.runtime = self._runtimes[0]
        self.controllers = [*self._runtimes, *self.extra_controllers]

    def _release(self) -> None:
        """Release every current runtime (the model's damping back to the compiled values)."""
        for runtime in self._runtimes:
            runtime.release()
        self._runtimes, self._groups = [], []

    def _warn_of_gaits(self, compiled: CompiledController) -> None:
        """Keep a warning, once per species, when the controller is a gait the species does not
        use (`gait_warning`), and once when their species carry their tails differently where
        it carries a tail (`carriage_warning`): in `warnings` and in the clips' metadata."""
        from quadpipe.animals.library import CARRIAGE_PARAMETERS, carriage_warning, gait_warning

        animals = [placement.built.animal for placement in self.placements]
        carries = not CARRIAGE_PARAMETERS.isdisjoint(compiled.parameters)
        issues = [
            *(gait_warning(animal, compiled.name) for animal in animals),
            carriage_warning(animals) if carries else None,
        ]
        for issue in issues:
            if issue is not None and issue not in self.warnings:
                self.warnings.append(issue)
        if self.warnings:
            self.metadata["warnings"] = "\n".join(issue.message for issue in self.warnings)

    @overload
    def use_controller(self, compiled: CompiledController, *, carry_over: bool = False) -> ControllerRuntime: ...
    @overload
    def use_controller(self, compiled: None, *, carry_over: bool = False) -> None: ...
    def use_controller(
        self, compiled: CompiledController | None, *, carry_over: bool = False
    ) -> ControllerRuntime | None:
        """Drive the animals with a fresh runtime of `compiled` (None: none), replacing the current one.

        The replaced runtime is released first (the model's damping back to the compiled values).

        Args:
            carry_over: the new runtime takes over the replaced one's running state (cycle
                phases, machine states, smoothed sensors: see `ControllerRuntime.adopt`) and its
                last forces, as a hot reload wants.

        Returns:
            the new runtime.
        """
        from quadpipe.controllers.runtime.runtime import ControllerRuntime

        previous = self.runtime
        self._release()
        runtime = None if compiled is None else ControllerRuntime(compiled, self.model, self.placements, self.variation)
        self._runtimes = [runtime] if runtime is not None else []
        if carry_over and runtime is not None and previous is not None:
            runtime.adopt(previous)
            runtime.last = previous.last  # the forces acting until the next step, for overlays
        self.runtime = runtime
        self.controllers = ([runtime] if runtime is not None else []) + self.extra_controllers
        return runtime

    def reset(self) -> None:
        """Back to t = 0: the initial state, the scene's events bound again, a fresh runtime of
        the current controller (compiled damping), kinematics computed."""
        compiled = None if self.runtime is None else self.runtime.compiled
        groups = self._groups
        mujoco.mj_resetData(self.model, self.data)
        self.events = self.setup.events(self.model)
        if groups:
            self.use_groups(groups)
        else:
            self.use_controller(compiled)
        mujoco.mj_forward(self.model, self.data)

    # ------------------------------------------------------------------ stepping

    def step(self) -> None:
        """One physics step: events, then `mj_step1`, controllers on the current state, `mj_step2`."""
        for event in self.events:
            event(self.model, self.data)
        mujoco.mj_step1(self.model, self.data)
        for applied in self._applied:
            applied.fill(0.0)
        for controller in self.controllers:
            controller.apply(self.model, self.data)
        mujoco.mj_step2(self.model, self.data)

    def record(
        self, seconds: float, *, on_frame: Callable[[float], None] | None = None, fps: float = sizing.FRAME_RATE
    ) -> Clip:
        """Simulate `seconds` and record one frame every 1/fps s (the first frame is the start).

        Args:
            seconds: simulated time.
            on_frame: called with the simulated time after every frame (progress, interruption).
            fps: recorded frames per second; must divide the physics rate (see `frame_steps`).

        Returns:
            the clip, its metadata `status: ok` and this simulation's `metadata`.

        Raises:
            SimulationBlowUp: on a NaN, a bad-acceleration warning or a body flung far away.
            QuadpipeError: `fps` does not divide the physics rate, or the run is over its limits.
        """
        frames = check_run(seconds, fps)
        steps = frame_steps(self.model.opt.timestep, fps)
        recorder = Recorder(self.model, self.placements, fps)
        mujoco.mj_forward(self.model, self.data)
        recorder.capture(self.data, self.frame_values())
        for frame in range(1, frames + 1):
            for _ in range(steps):
                self.step()
            self.check_health(frame, fps)
            recorder.capture(self.data, self.frame_values())
            if on_frame is not None:
                on_frame(self.data.time)
        return recorder.clip({"status": "ok", **self.metadata})

    def frame_values(self) -> dict[str, np.ndarray]:
        """The per-frame values the controllers offer (sensors, injected force and power)."""
        values: dict[str, np.ndarray] = {}
        for controller in self.controllers:
            offer = getattr(controller, "frame_values", None)
            if offer is not None:
                values.update(offer(self.data))
        return values

    def check_health(self, frame: int, fps: float = sizing.FRAME_RATE) -> None:
        """Raise `SimulationBlowUp` if a controller computed a non-finite force, the state is not
        finite, MuJoCo warned, or a body flew away."""
        data = self.data
        fault = next((f for c in self.controllers if (f := getattr(c, "fault", None))), None)
        if fault is not None:
            raise SimulationBlowUp.single(
                "non-finite-force",
                f"the simulation stopped at frame {frame} (t = {frame / fps:.2f} s): {fault}",
                hint="an expression of that element gave no number (a negative number raised to a fraction, "
                "exp of a large value): check its values, e.g. with clamp()",
            )
        problem = None
        if not physics.is_finite(data):
            problem = "positions or velocities became NaN or infinite"
        elif data.warning[mujoco.mjtWarning.mjWARN_BADQACC].number:
            problem = "MuJoCo reported a bad acceleration (the state diverged)"
        elif np.abs(data.xpos).max() > self.far_m:
            problem = "a body was flung more than 1000 pelvis heights away"
        if problem is None:
            return
        names = ", ".join(c.name for c in self.controllers) or "no controller"
        raise SimulationBlowUp.single(
            "simulation-blew-up",
            f"the simulation blew up at frame {frame} (t = {frame / fps:.2f} s) under {names}: {problem}",
            hint="forces are too strong for this animal or step: lower the controller's strengths, or check the scene",
        )


@dataclass
class Result:
    """A finished simulation: the clip, its metrics, the runtime (for inspection in tests) and
    what its inputs warned of (also in the metrics' and the clip metadata's `warnings`)."""

    clip: Clip
    metrics: dict
    runtime: ControllerRuntime | None
    warnings: tuple[Issue, ...] = ()


def simulate(
    animal: str | AnimalSource,
    controller: str | None,
    *,
    seconds: float,
    scene: str | None = None,
    parameters: dict[str, str] | None = None,
    extra_controllers: Sequence[Controller] = (),
    on_frame: Callable[[float], None] | None = None,
    fps: float = sizing.FRAME_RATE,
    places: Mapping[str, Location] | None = None,
    direction: str | Path | None = None,
    variation: Variation | None = None,
) -> Result:
    """Build an animal (and scene), run a controller on it, and return the clip and its metrics.

    Args:
        animal: animal name, config or skeleton file, or an `AnimalSource` (a skeleton file with its options).
        controller: controller name or path (None: a passive ragdoll).
        seconds: simulated time.
        scene: scene name or path (None: `flat`).
        parameters: controller parameter overrides (YAML values: "2 HP", "[1, 0, 0]").
        extra_controllers: more `Controller`s run after the main one (tests push with these).
        on_frame: called with the simulated time after every frame (progress, interruption).
        fps: recorded frames per second (30, the thesis's; a rat's walk needs more to be
            analysed: its stride lasts 0.17 s).
        places: where each of `parameters` was written (a batch plan's line), for messages.
        direction: a direction file replacing the scene's `direction:` (docs/direction.md).
        variation: seeded stride-to-stride variation of the gait (None: every stride alike).

    Raises:
        QuadpipeError: a time or frame rate out of the run limits (before anything is built),
            inputs that cannot be loaded, a simulation that blew up.
    """
    check_run(seconds, fps)
    simulation = Simulation.build(
        animal,
        controller,
        scene=scene,
        parameters=parameters,
        extra_controllers=extra_controllers,
        places=places,
        direction=direction,
        variation=variation,
    )
    clip = simulation.record(seconds, on_frame=on_frame, fps=fps)
    metrics = clip_metrics(clip)
    if simulation.warnings:
        metrics["warnings"] = [issue.message for issue in simulation.warnings]
    return Result(clip, metrics, simulation.runtime, tuple(simulation.warnings))
