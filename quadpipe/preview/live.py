"""The live preview: an animal simulated under a controller in a scene, on the preview clock.

`LivePreview` runs a `quadpipe.sim.simulation.Simulation` (with a pool of throwable bodies
added to its world). It watches the controller's files (and the scene's) by modification time:
a valid controller edit is compiled and swapped into the running simulation (same MuJoCo
state, cycle phases and machine states kept); an invalid one keeps the last good controller
running and exposes its error, with file:line, in `error` and the notices. A scene edit
rebuilds the world and restarts it. Actions throw balls and boxes from the camera, move the
controller's goal, and force the states of its state machines.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import mujoco
import numpy as np

from quadpipe.animals import sizing
from quadpipe.core import configs
from quadpipe.core.errors import Location, QuadpipeError
from quadpipe.preview.base import ActionHandler, Preview, ignoring_eye
from quadpipe.preview.clock import Clock
from quadpipe.preview.overlays import (
    LIVE_OVERLAYS,
    balance_layer,
    contacts_layer,
    forces_layer,
    goal_layer,
    segments_layer,
)
from quadpipe.preview.scenery import HIDDEN_BELOW_HP, OverlayLayer, Pose, model_scenery, pose_of
from quadpipe.preview.throws import POOL_SIZE, ThrowKind, ThrowPool, add_throw_pool, throw_at_trunk
from quadpipe.world.goals import vector_text

if TYPE_CHECKING:
    from quadpipe.animals.library import AnimalSource
    from quadpipe.controllers.language.compiler import CompiledController
    from quadpipe.controllers.runtime.runtime import ControllerRuntime
    from quadpipe.sim.simulation import Simulation
    from quadpipe.world import SceneSetup, SceneSpec

GOAL_PARAMETERS = ("goal", "target")
"""Controller parameters the goal actions move, the first one the controller declares."""

GOAL_STEP_HP = 1.0
"""How far one goal action moves the goal, pelvis heights."""

GOAL_FAR_HP = 50.0
"""A goal farther than this from the animal (pelvis heights; the flat scene's is 500 HP ahead)
is brought near before a goal action moves it, so that one step turns the animal at once."""

GOAL_NEAR_HP = 20.0
"""Where a far goal is brought: this far from the animal, on the same bearing (pelvis heights)."""

STATE_KEYS = 9
"""Actions `state_1` ... `state_9` force that state of the controller's first state machine."""


class FileWatcher:
    """Tells when any of some files changed (modification time or size), polled."""

    def __init__(self, paths: Sequence[str | Path]):
        self.watch(paths)

    def watch(self, paths: Sequence[str | Path]) -> None:
        """Watch these files from now on (their current state is the reference)."""
        self.paths = [Path(p) for p in paths]
        self._seen = [self._signature(p) for p in self.paths]

    def changed(self) -> bool:
        """Whether a file changed since the last call (or since `watch`)."""
        now = [self._signature(p) for p in self.paths]
        changed, self._seen = now != self._seen, now
        return changed

    @staticmethod
    def _signature(path: Path) -> tuple[int, int] | None:
        try:
            status = os.stat(path)
        except OSError:
            return None
        return status.st_mtime_ns, status.st_size


class _GoalEnv(dict):
    """A minimal expression env to evaluate a goal parameter: time and body points."""

    def __init__(self, runtime: ControllerRuntime, data: mujoco.MjData):
        super().__init__()
        self.runtime, self.data = runtime, data

    def __missing__(self, key: str) -> np.ndarray:
        from quadpipe.quantities import expressions

        kind, _, rest = key.partition(":")
        if key == expressions.TIME_VARIABLE:
            value = np.full(self.runtime.n, self.data.time)
        elif kind == "point":
            value = self.runtime.point(self.data, rest)
        elif kind == "velocity":
            value = self.runtime.point_velocity(self.data, rest)
        elif key == expressions.HEADING_FRAME_KEY:
            value = self.runtime.heading_frames(self.data)
        else:
            raise KeyError(key)
        self[key] = value
        return value


@dataclass
class _World:
    """One built world: the scene, its simulation, the throw pool, the first animal's pelvis height."""

    scene: SceneSpec
    sim: Simulation
    pool: ThrowPool
    hp: float

    @property
    def setup(self) -> SceneSetup:
        """The scene built for its animals."""
        return self.sim.setup


class LivePreview(Preview):
    """An animal simulated live under a controller, its files watched for edits.

    Args:
        animal: animal name, config or skeleton file, or an `AnimalSource` (a skeleton file with its options).
        controller: controller name or YAML path.
        scene: scene name or YAML path (None: `flat`).
        parameters: controller parameter overrides (values as written in YAML).
        places: where each of `parameters` was given (`--set ...`), for messages.
        pool_size: throwable bodies of each kind.
        direction: a direction file (docs/direction.md) that replaces the scene's
            `direction:`; watched for edits like the scene.

    Raises:
        QuadpipeError: the animal, controller, scene or direction cannot be loaded (at the start; later
            edits never raise, they set `error`).
    """

    overlay_names = LIVE_OVERLAYS

    def __init__(
        self,
        animal: str | AnimalSource,
        controller: str,
        scene: str | None = None,
        parameters: Mapping[str, str] | None = None,
        places: Mapping[str, Location] | None = None,
        pool_size: int = POOL_SIZE,
        direction: str | Path | None = None,
    ):
        from quadpipe.animals.library import load_animal
        from quadpipe.animals.model import build_animal
        from quadpipe.sim.simulation import DEFAULT_SCENE
        from quadpipe.world import SCENE_KIND

        self.controller = controller
        self.overrides: dict[str, str] = dict(parameters or {})
        self.places = dict(places or {})
        self.goal_overrides: dict[str, str] = {}
        self.reload_error: str | None = None
        self.blow_up: str | None = None
        self.pool_size = pool_size
        self.built = build_animal(load_animal(animal))
        self.scene_path = configs.find_config(SCENE_KIND, scene or DEFAULT_SCENE)
        self.direction_path = Path(direction) if direction is not None else None
        self.world = self._build_world(self._load_scene())
        compiled, sources = self._compile(self.world)
        self.world.sim.use_controller(compiled)
        super().__init__(Clock(self.model.opt.timestep, self._steps_per_frame(self.model)))
        self.controller_files = FileWatcher(sources)
        self.scene_file = FileWatcher([self.scene_path, *([self.direction_path] if self.direction_path else [])])
        self.scenery_version = 0
        self.scenery, self._body_ids = model_scenery(self.model, self.world.hp)
        mujoco.mj_forward(self.model, self.data)

    # -------------------------------------------------------------- building

    def _load_scene(self) -> SceneSpec:
        from quadpipe.world import load_scene

        return load_scene(self.scene_path)

    def _build_world(self, scene: SceneSpec) -> _World:
        """The scene built for the animal (playing the direction file, if one was given), a
        throw pool added, compiled into a simulation (no controller yet)."""
        from quadpipe.sim.simulation import Simulation
        from quadpipe.world import build_scene
        from quadpipe.world.direction import load_direction

        direction = load_direction(self.direction_path) if self.direction_path is not None else None
        setup = build_scene(scene, self.built, direction)
        first = setup.placements[0].built.animal
        names = add_throw_pool(setup.spec, first.pelvis_height, first.mass_kg, self.pool_size)
        sim = Simulation(setup)
        return _World(scene, sim, ThrowPool(sim.model, names), first.pelvis_height)

    def _compile(self, world: _World) -> tuple[CompiledController, tuple[str, ...]]:
        """The controller's current files compiled for `world`, and the files it was read from.

        Goals moved by the goal actions are offered over the scene's; the other overrides win.

        Raises:
            QuadpipeError: the files do not validate, or an override does not fit them.
        """
        given = {name: value for name, value in self.overrides.items() if name not in self.goal_overrides}
        return world.sim.compile_controller(self.controller, given, goals=self.goal_overrides, places=self.places)

    @staticmethod
    def _steps_per_frame(model: mujoco.MjModel) -> int:
        return round(1.0 / (sizing.FRAME_RATE * model.opt.timestep))

    @property
    def runtime(self) -> ControllerRuntime:
        """The controller runtime now driving the animals."""
        runtime = self.world.sim.runtime
        assert runtime is not None, "a live preview always drives its animals with a compiled controller"
        return runtime

    @property
    def model(self) -> mujoco.MjModel:
        """The compiled world."""
        return self.world.sim.model

    @property
    def data(self) -> mujoco.MjData:
        """Its state."""
        return self.world.sim.data

    @property
    def time(self) -> float:
        """Simulated time, seconds."""
        return float(self.data.time)

    @property
    def error(self) -> str | None:
        """The last failed reload's errors (file:line: ...) and a blow-up, if any."""
        return "\n".join(text for text in (self.reload_error, self.blow_up) if text) or None

    # -------------------------------------------------------------- running

    def advance(self, wall_dt: float) -> int:
        """Reload edited files, then step physics so that simulated time follows `wall_dt` wall seconds.

        Returns:
            the number of physics steps taken.
        """
        self.check_files()
        steps = self.clock.advance(wall_dt)
        if self.blow_up:
            return 0
        from quadpipe.sim.simulation import SimulationBlowUp

        sim = self.world.sim
        for _ in range(steps):
            sim.step()
        if steps:
            try:
                sim.check_health(round(self.time * sizing.FRAME_RATE))
            except SimulationBlowUp as exc:
                self.blow_up = exc.format() + "\n  reset to start again"
                self.notify(self.blow_up)
                self.clock.paused = True
        return steps

    def reset(self) -> None:
        """Back to t = 0: the start pose, a fresh runtime of the current controller, thrown bodies parked."""
        self.world.pool.park_all(self.model)
        self.world.sim.reset()
        self.clock.reset()
        self.blow_up = None

    # -------------------------------------------------------------- hot reload

    def check_files(self) -> None:
        """Reload the scene or the controller if its files changed since the last check."""
        if self.scene_file.changed():
            self.reload_scene()
        elif self.controller_files.changed():
            self.reload_controller()

    def reload_controller(self) -> bool:
        """Compile the controller's files again and swap the result into the running simulation.

        Returns:
            True if it was swapped in; False if the files do not validate (the last good
            controller keeps running and `error` says why, with file:line).
        """
        try:
            compiled, sources = self._compile(self.world)
        except QuadpipeError as exc:
            self._fail(exc.format())
            return False
        runtime = self.world.sim.use_controller(compiled, carry_over=True)
        self.controller_files.watch(sources)
        self.reload_error = None
        self.notify(f"reloaded controller {runtime.name!r}")
        return True

    def reload_scene(self) -> bool:
        """Load the scene file again and rebuild the world with it, restarting at t = 0.

        Returns:
            True if rebuilt; False if the scene or the controller does not fit it (the old
            world keeps running and `error` says why).
        """
        try:
            world = self._build_world(self._load_scene())
            compiled, sources = self._compile(world)
        except QuadpipeError as exc:
            self._fail(exc.format())
            return False
        world.sim.use_controller(compiled).adopt(self.runtime)
        self.world = world
        self.controller_files.watch(sources)
        self.clock = Clock(
            self.model.opt.timestep, self._steps_per_frame(self.model), self.clock.paused, self.clock.slow
        )
        self.scenery, self._body_ids = model_scenery(self.model, world.hp)
        self.scenery_version += 1
        mujoco.mj_forward(self.model, self.data)
        self.reload_error, self.blow_up = None, None
        self.notify(f"reloaded scene {world.scene.name!r}: the world was rebuilt and restarted")
        return True

    def _fail(self, text: str) -> None:
        self.reload_error = text
        self.notify(text)

    # -------------------------------------------------------------- actions

    def actions(self) -> dict[str, tuple[str, ActionHandler]]:
        """Clock and overlay actions, throws, goal moves and state switches (see `Preview.actions`)."""
        actions = super().actions()
        actions["throw_ball"] = ("throw a ball at the animal from the camera", lambda eye: self.throw("ball", eye))
        actions["throw_box"] = ("throw a box at the animal from the camera", lambda eye: self.throw("box", eye))
        for name, (dx, dy) in {
            "goal_forward": (1, 0),
            "goal_back": (-1, 0),
            "goal_left": (0, 1),
            "goal_right": (0, -1),
        }.items():
            actions[name] = (
                f"move the goal {GOAL_STEP_HP:g} HP {name[5:]}",
                ignoring_eye(self.nudge_goal, (dx, dy)),
            )
        for k in range(1, STATE_KEYS + 1):
            actions[f"state_{k}"] = (
                f"force state {k} of the first state machine",
                ignoring_eye(self.force_state_number, k),
            )
        return actions

    def throw(self, kind: ThrowKind, eye: np.ndarray | None = None) -> int:
        """Throw a ball or a box at the first animal's trunk from the camera at `eye`.

        It starts at the camera (within `MAX_THROW_DISTANCE_HP` of the target), aimed where
        the trunk will be when it gets there, at the animal's `froude_speed(2.5)`.

        Returns:
            the thrown body's id.
        """
        body, speed = throw_at_trunk(self.runtime, self.model, self.data, self.world.pool, kind, eye, self.world.hp)
        self.notify(f"threw a {kind} at {speed:.1f} m/s")
        return body

    def goal_parameter(self) -> str | None:
        """The controller parameter the goal actions move (`goal` or `target`), or None."""
        return next((name for name in GOAL_PARAMETERS if name in self.runtime.compiled.parameters), None)

    def goal_point(self) -> np.ndarray | None:
        """Where the goal is now, for the first animal (None: no goal, or one that reads sensors)."""
        name = self.goal_parameter()
        if name is None:
            return None
        try:
            return np.asarray(
                self.runtime.compiled.parameters[name](_GoalEnv(self.runtime, self.data)), dtype=float
            ).reshape(-1, 3)[0]
        except KeyError:
            return None

    def move_goal(self, point: np.ndarray | Sequence[float]) -> bool:
        """Set the goal parameter to a fixed world point, recompiling the controller with it.

        Returns:
            True if moved; False if the controller has no goal (a notice says so).
        """
        name = self.goal_parameter()
        if name is None:
            self.notify(f"controller {self.runtime.name!r} has no {' or '.join(GOAL_PARAMETERS)} parameter to move")
            return False
        self.goal_overrides[name] = vector_text(np.asarray(point, dtype=float))
        return self.reload_controller()

    def nudge_goal(self, direction: tuple[float, float]) -> bool:
        """Move the goal `GOAL_STEP_HP` along world x and y times `direction` (from where it is now;
        a goal beyond `GOAL_FAR_HP` first comes to `GOAL_NEAR_HP` from the animal, same bearing).

        Returns:
            True if moved; False if there is no goal, or one that depends on sensors (a notice says so).
        """
        current = self.goal_point()
        if current is None:
            self.notify(f"controller {self.runtime.name!r} has no goal point that can be moved")
            return False
        return self.move_goal(self._near(current) + GOAL_STEP_HP * self.world.hp * np.array([*direction, 0.0]))

    def _near(self, goal: np.ndarray) -> np.ndarray:
        """The goal, or where a far one comes to: `GOAL_NEAR_HP` from the animal on its bearing."""
        animal = self.focus()
        offset = goal - animal
        offset[2] = 0.0
        distance = float(np.linalg.norm(offset))
        if distance <= GOAL_FAR_HP * self.world.hp:
            return goal
        return np.array([*(animal[:2] + offset[:2] * (GOAL_NEAR_HP * self.world.hp / distance)), goal[2]])

    def machines(self) -> dict[str, list[str]]:
        """The controller's state machines and their states, in order."""
        return {name: list(machine.states) for name, machine in self.runtime.compiled.machines.items()}

    def force_state(self, machine: str, state: str) -> None:
        """Put a state machine in a state now, for every animal.

        Raises:
            KeyError: no such machine or state.
        """
        self.runtime.force_state(machine, state)
        self.notify(f"{machine}: {state}")

    def force_state_number(self, number: int) -> None:
        """Force the `number`-th state (from 1) of the first state machine, if there is one."""
        machines = self.machines()
        if not machines:
            self.notify(f"controller {self.runtime.name!r} has no state machine")
            return
        machine, states = next(iter(machines.items()))
        if number > len(states):
            self.notify(f"{machine} has {len(states)} states: {', '.join(states)}")
            return
        self.force_state(machine, states[number - 1])

    # -------------------------------------------------------------- drawing

    def pose(self) -> Pose:
        """Every scenery body's pose now; parked bodies are hidden."""
        positions = self.data.xpos[self._body_ids]
        return pose_of(positions, self.data.xquat[self._body_ids], -HIDDEN_BELOW_HP * self.world.hp)

    def focus(self) -> np.ndarray:
        """The first animal's pelvis, where a following camera looks."""
        return self.runtime.point(self.data, "pelvis.start")[0].copy()

    def overlays(self) -> list[OverlayLayer]:
        """The shown overlay layers at the current state."""
        runtime, model, data, placements = self.runtime, self.model, self.data, self.world.setup.placements
        makers = {
            "segments": lambda: segments_layer(runtime, data),
            "balance": lambda: balance_layer(runtime, model, data, placements),
            "forces": lambda: forces_layer(runtime, placements),
            "contacts": lambda: contacts_layer(data, self.world.hp),
            "goal": lambda: goal_layer(self.goal_point()),
        }
        return [makers[name]() for name in self.overlay_names if name in self.shown]

    def status_line(self) -> str:
        """Time, clock state, controller, machine states, and whether there is an error."""
        parts = [self._clock_text(self.time), f"controller {self.runtime.name}"]
        parts += [f"{machine}: {self.runtime.state_of(machine)[0]}" for machine in self.runtime.compiled.machines]
        if self.error:
            parts.append("ERROR (see below)")
        return "  |  ".join(parts)
