"""The live preview's model: a simulation (or a baked clip) on a wall clock, driven by named actions.

Everything a preview window shows and does is here, as plain numpy, so that it runs and is
tested without a display; `quadpipe.preview.window` only draws it and maps keys to actions.

- `Clock` turns wall time into fixed ticks: real time, paused, single steps, slow motion
  (x0.25), with a capped catch-up so that one slow frame does not make the next slower.
- `LivePreview` runs an animal under a controller in a scene. It watches the controller's
  files (and the scene's) by modification time: a valid controller edit is compiled and
  swapped into the running simulation (same MuJoCo state, cycle phases and machine states
  kept); an invalid one keeps the last good controller running and exposes its error, with
  file:line, in `error` and the notices. A scene edit rebuilds the world and restarts it.
  Actions throw balls and boxes from the camera (a pool of bodies parked under the floor,
  since a compiled MuJoCo model cannot grow bodies), move the controller's goal, and force
  the states of its state machines.
- `ReplayPreview` plays a baked `.npz` clip with the same clock and actions.
- Both give the window the same things: `scenery` (shapes per body, static shapes), `pose()`
  (every body's world pose), `overlays()` (lines, arrows and points with colours, by name,
  toggleable), `focus()` (where a following camera looks) and a `status_line()`.
"""

from __future__ import annotations

import abc
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Callable, Literal, Mapping, Sequence

import mujoco
import numpy as np

from quadpipe.core import configs
from quadpipe.animals import sizing
from quadpipe.anatomy import roles
from quadpipe.clip.model import Clip, Shape
from quadpipe.core.errors import QuadpipeError
from quadpipe.sim.recording import geom_shape
from quadpipe.world.goals import vector_text
from quadpipe.world.throws import PARK_DEPTH_HP, THROWN_RGBA

if TYPE_CHECKING:
    from quadpipe.controllers.runtime.runtime import ControllerRuntime
    from quadpipe.world import SceneSetup, SceneSpec
    from quadpipe.sim.simulation import Run

# --------------------------------------------------------------------------- constants

SLOW_MOTION_RATE = 0.25
"""Simulated seconds per wall second in slow motion."""

MAX_CATCH_UP_S = 0.1
"""Most wall time one `advance` makes up for, seconds: after a longer frame (a window dragged,
a breakpoint) the simulation drops the rest instead of spiralling into ever longer frames."""

POOL_SIZE = 4
"""Throwable bodies of each kind (ball, box) preallocated in a live world; the oldest is reused."""

POOL_PREFIX = "preview-"
"""Prefix of the pool's body names (`preview-ball0`): a hyphen, which scene names cannot hold."""

HIDDEN_BELOW_HP = PARK_DEPTH_HP / 2
"""A body deeper than this many pelvis heights under the floor is parked, and not drawn (pool
bodies wait `PARK_DEPTH_HP` under it, colliding with nothing and held against gravity, as the
scene's thrown objects do)."""

THROW_MASS_BM = 0.1
"""Mass of a thrown ball or box, in body masses of the first animal (the scenes' default)."""

BALL_RADIUS_HP = 0.1
BOX_SIDE_HP = 0.2
"""Sizes of the thrown ball (radius) and box (side), in pelvis heights."""

THROW_FROUDE = 2.5
"""A throw's speed is `froude_speed(2.5)` of the first animal (about 4 m/s for the dog)."""

MAX_THROW_DISTANCE_HP = 4.0
"""A throw starts from the camera, but no farther than this from its target (pelvis heights):
the object then appears on the line from the camera, so a throw hits as hard from any distance."""

DEFAULT_THROW_FROM = (0.0, 1.0, 0.5)
"""Direction a throw comes from without a camera position, in the animal's heading frame (its left, above)."""

THROW_TARGET_POINTS = ("pelvis.start", "thorax.start")
"""A throw aims at the middle of these body points (the trunk's middle)."""

GOAL_PARAMETERS = ("goal", "target")
"""Controller parameters the goal actions move, the first one the controller declares."""

GOAL_STEP_HP = 1.0
"""How far one goal action moves the goal, pelvis heights."""

BALANCE_HORIZON_S = 1.0
"""Horizon of the drawn balance vectors, gravity + velocity / horizon (the thesis's 1 s)."""

FORCE_ARROW_HP_PER_BW = 0.5
"""Length of a force arrow, in pelvis heights per body weight of the animal it acts on."""

CONTACT_NORMAL_HP = 0.3
"""Length of a drawn contact normal, pelvis heights."""

SEGMENT_RGBA = (0.58, 0.25, 0.85, 1.0)
BALANCE_RGBA = (1.0, 0.85, 0.1, 1.0)
CONTACT_RGBA = (0.2, 0.85, 0.3, 1.0)
GOAL_RGBA = (0.1, 0.8, 0.9, 1.0)
"""Overlay colours: control segments violet (as in the thesis's figures), balance vectors
yellow, contacts green, the goal cyan."""

FORCE_RGBA: dict[str, tuple[float, float, float, float]] = {
    "segment": (0.9, 0.15, 0.35, 1.0),
    "elastic": (0.35, 0.55, 1.0, 1.0),
    "cycle": (1.0, 0.5, 0.1, 1.0),
    "pull": (0.95, 0.2, 0.2, 1.0),
    "force_pair": (0.95, 0.35, 0.7, 1.0),
}
"""Colour of a force arrow by the kind of element that applied it."""

LIVE_OVERLAYS = ("segments", "balance", "forces", "contacts", "goal")
REPLAY_OVERLAYS = ("contacts", "trail")
"""Overlay layers of each mode, by name (all shown at the start)."""

STATE_KEYS = 9
"""Actions `state_1` ... `state_9` force that state of the controller's first state machine."""

OverlayKind = Literal["line", "arrow", "point"]
ThrowKind = Literal["ball", "box"]

_DRAWABLE_GEOMS = {int(mujoco.mjtGeom.mjGEOM_CAPSULE), int(mujoco.mjtGeom.mjGEOM_BOX), int(mujoco.mjtGeom.mjGEOM_SPHERE), int(mujoco.mjtGeom.mjGEOM_PLANE)}
"""Geom types a preview draws (those a `quadpipe.clip.model.Shape` can carry)."""


# --------------------------------------------------------------------------- clock


@dataclass
class Clock:
    """Turns wall time into whole ticks of simulated time.

    Attributes:
        tick_s: simulated seconds per tick (a physics step, or a clip frame).
        step_ticks: ticks one single step moves (one 1/30 s frame).
        paused: no ticks from wall time (single steps still go).
        slow: slow motion (`SLOW_MOTION_RATE`).
    """

    tick_s: float
    step_ticks: int = 1
    paused: bool = False
    slow: bool = False
    _owed_s: float = field(default=0.0, init=False, repr=False)
    _queued: int = field(default=0, init=False, repr=False)

    @property
    def rate(self) -> float:
        """Simulated seconds per wall second while running."""
        return SLOW_MOTION_RATE if self.slow else 1.0

    def advance(self, wall_dt: float) -> int:
        """The ticks due after `wall_dt` more wall seconds (at most `MAX_CATCH_UP_S` worth), plus queued steps."""
        ticks, self._queued = self._queued, 0
        if self.paused:
            return ticks
        self._owed_s += min(max(wall_dt, 0.0), MAX_CATCH_UP_S) * self.rate
        due = math.floor(self._owed_s / self.tick_s + 1e-9)
        self._owed_s = max(self._owed_s - due * self.tick_s, 0.0)
        return ticks + due

    def toggle_pause(self) -> None:
        """Pause, or run again."""
        self.paused = not self.paused
        self._owed_s = 0.0

    def step(self) -> None:
        """Pause, and queue one step for the next `advance`."""
        self.paused = True
        self._owed_s = 0.0
        self._queued += self.step_ticks

    def toggle_slow_motion(self) -> None:
        """Slow motion on or off."""
        self.slow = not self.slow

    def reset(self) -> None:
        """Forget owed time and queued steps (the pause and speed stay)."""
        self._owed_s, self._queued = 0.0, 0


# --------------------------------------------------------------------------- what the window draws


@dataclass(frozen=True)
class BodyShapes:
    """A moving body to draw: its name and its shapes, in its own frame."""

    name: str
    shapes: tuple[Shape, ...]


@dataclass(frozen=True)
class Scenery:
    """Everything to draw, built once per world.

    Attributes:
        bodies: the moving bodies, in the order of `Pose` rows.
        static: shapes fixed in the world (floor, terrain), world coordinates.
        hp: the first animal's pelvis height, metres (the length unit of the view).
    """

    bodies: tuple[BodyShapes, ...]
    static: tuple[Shape, ...]
    hp: float


@dataclass(frozen=True)
class Pose:
    """Where every body of the scenery is now.

    Attributes:
        positions: (B, 3) world positions of the body frames, metres (finite).
        quaternions: (B, 4) world orientations (w, x, y, z).
        visible: (B,) whether to draw each body (parked and diverged ones are not).
    """

    positions: np.ndarray
    quaternions: np.ndarray
    visible: np.ndarray


@dataclass(frozen=True)
class OverlayLayer:
    """One named layer of decorations at the current time.

    Attributes:
        name: the layer (`segments`, `balance`, ...).
        kind: `line` (start to end), `arrow` (the same, with a head at the end) or `point` (at start).
        starts: (K, 3) start points, metres.
        ends: (K, 3) end points (equal to `starts` for points).
        colors: (K, 4) RGBA per item.
    """

    name: str
    kind: OverlayKind
    starts: np.ndarray
    ends: np.ndarray
    colors: np.ndarray


def layer(name: str, kind: OverlayKind, starts: np.ndarray, ends: np.ndarray | None, rgba: Sequence[float] | np.ndarray) -> OverlayLayer:
    """An overlay layer; `rgba` is one colour for all items, or one per item."""
    starts = np.asarray(starts, dtype=float).reshape(-1, 3)
    ends = starts.copy() if ends is None else np.asarray(ends, dtype=float).reshape(-1, 3)
    colors = np.asarray(rgba, dtype=float)
    colors = np.tile(colors, (len(starts), 1)) if colors.ndim == 1 else colors.reshape(-1, 4)
    return OverlayLayer(name, kind, starts, ends, colors)


# --------------------------------------------------------------------------- base


class _Preview(abc.ABC):
    """What live and replay previews share: the clock, named actions, overlay toggles, notices."""

    overlay_names: tuple[str, ...] = ()

    def __init__(self, clock: Clock):
        self.clock = clock
        self.shown = set(self.overlay_names)
        self._notices: list[str] = []

    @property
    def error(self) -> str | None:
        """What went wrong, for the window (None: nothing)."""
        return None

    # -------------------------------------------------------------- actions

    def actions(self) -> dict[str, tuple[str, Callable[[np.ndarray | None], None]]]:
        """Action name -> (what it does, handler taking the camera's eye position or None)."""
        actions = {
            "pause": ("pause / run", lambda eye: self.clock.toggle_pause()),
            "step": ("pause and step one frame", lambda eye: self.clock.step()),
            "reset": ("back to the start", lambda eye: self.reset()),
            "slow_motion": (f"slow motion x{SLOW_MOTION_RATE:g} on / off", lambda eye: self.clock.toggle_slow_motion()),
        }
        for name in self.overlay_names:
            actions[f"toggle_{name}"] = (f"show / hide the {name}", lambda eye, name=name: self.toggle_overlay(name))
        return actions

    def perform(self, action: str, eye: Sequence[float] | None = None) -> None:
        """Run a named action; `eye` is the camera position (used by throws).

        Raises:
            KeyError: no such action in this mode.
        """
        self.actions()[action][1](None if eye is None else np.asarray(eye, dtype=float))

    @abc.abstractmethod
    def reset(self) -> None:
        """Back to the start (each mode says what that means)."""

    # -------------------------------------------------------------- overlays and notices

    def toggle_overlay(self, name: str) -> None:
        """Show or hide an overlay layer.

        Raises:
            KeyError: no such layer in this mode.
        """
        if name not in self.overlay_names:
            raise KeyError(name)
        self.shown ^= {name}

    def notify(self, text: str) -> None:
        """Queue a line for the console (the window prints them)."""
        self._notices.append(text)

    def pop_notices(self) -> list[str]:
        """The lines queued since the last call."""
        notices, self._notices = self._notices, []
        return notices

    def _clock_text(self, time: float) -> str:
        state = "paused" if self.clock.paused else "running"
        speed = f" x{self.clock.rate:g}" if self.clock.slow else ""
        return f"t {time:6.2f} s  {state}{speed}"


# --------------------------------------------------------------------------- live


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


class ThrowPool:
    """Throwable bodies preallocated in a world, parked until thrown.

    Args:
        model: the compiled world holding the bodies `add_throw_pool` added.
        names: kind -> body names.
    """

    def __init__(self, model: mujoco.MjModel, names: Mapping[str, Sequence[str]]):
        self.bodies = {kind: [int(model.body(name).id) for name in group] for kind, group in names.items()}
        self._next = {kind: 0 for kind in names}

    def park_all(self, model: mujoco.MjModel) -> None:
        """Every body back to colliding with nothing and held against gravity (positions: `qpos0`)."""
        for bodies in self.bodies.values():
            for body in bodies:
                _set_colliding(model, body, False)
        self._next = {kind: 0 for kind in self.bodies}

    def throw(self, model: mujoco.MjModel, data: mujoco.MjData, kind: str, position: np.ndarray, velocity: np.ndarray) -> int:
        """Teleport the next body of `kind` to `position`, moving at `velocity`; returns its body id."""
        bodies = self.bodies[kind]
        body = bodies[self._next[kind] % len(bodies)]
        self._next[kind] += 1
        joint = int(model.body_jntadr[body])
        qpos, dof = int(model.jnt_qposadr[joint]), int(model.jnt_dofadr[joint])
        data.qpos[qpos : qpos + 3] = position
        data.qpos[qpos + 3 : qpos + 7] = (1.0, 0.0, 0.0, 0.0)
        data.qvel[dof : dof + 3] = velocity
        data.qvel[dof + 3 : dof + 6] = 0.0
        _set_colliding(model, body, True)
        return body


def _set_colliding(model: mujoco.MjModel, body: int, on: bool) -> None:
    """A loose body touches the world and the animals and falls (on), or nothing and floats (off)."""
    from quadpipe.world.placement import WORLD_CONAFFINITY, WORLD_CONTYPE

    contype, conaffinity = (WORLD_CONTYPE, WORLD_CONAFFINITY) if on else (0, 0)
    geoms = slice(int(model.body_geomadr[body]), int(model.body_geomadr[body] + model.body_geomnum[body]))
    model.geom_contype[geoms], model.geom_conaffinity[geoms] = contype, conaffinity
    model.body_contype[body], model.body_conaffinity[body] = contype, conaffinity
    model.body_gravcomp[body] = 0.0 if on else 1.0


def add_throw_pool(spec: mujoco.MjSpec, hp: float, mass_kg: float, count: int = POOL_SIZE) -> dict[str, list[str]]:
    """Add `count` balls and `count` boxes, parked under the floor, to a world spec.

    Args:
        spec: the world (scene) spec, before compiling.
        hp: the first animal's pelvis height (sizes, softness and parking depth), metres.
        mass_kg: the first animal's body mass.
        count: bodies of each kind.

    Returns:
        kind -> body names.
    """
    shapes = {
        "ball": (mujoco.mjtGeom.mjGEOM_SPHERE, [BALL_RADIUS_HP * hp, 0.0, 0.0]),
        "box": (mujoco.mjtGeom.mjGEOM_BOX, [BOX_SIDE_HP * hp / 2] * 3),
    }
    names: dict[str, list[str]] = {}
    for kind, (geom_type, size) in shapes.items():
        names[kind] = [f"{POOL_PREFIX}{kind}{k}" for k in range(count)]
        for name in names[kind]:
            body = spec.worldbody.add_body(name=name, pos=[0.0, 0.0, -PARK_DEPTH_HP * hp], gravcomp=1.0)
            body.add_freejoint(name=name)
            body.add_geom(
                name=name, type=geom_type, size=size, mass=THROW_MASS_BM * mass_kg, rgba=list(THROWN_RGBA),
                solref=[sizing.constraint_time_constant(hp), 1.0], solimp=sizing.constraint_impedance(hp),
                contype=0, conaffinity=0,
            )
    return names


def aim_velocity(origin: np.ndarray, target: np.ndarray, speed: float, gravity: np.ndarray) -> np.ndarray:
    """The launch velocity that carries a ballistic body from `origin` to `target`.

    The flight takes distance / `speed` seconds; over it gravity pulls the path down by
    g T² / 2, which the launch makes up for: v0 = D / T - g T / 2.
    """
    displacement = np.asarray(target, dtype=float) - np.asarray(origin, dtype=float)
    flight = float(np.linalg.norm(displacement)) / speed
    return displacement / flight - np.asarray(gravity, dtype=float) * flight / 2


def throw_origin(eye: np.ndarray | None, target: np.ndarray, heading: np.ndarray, hp: float) -> np.ndarray:
    """Where a throw at `target` starts: the camera, brought within `MAX_THROW_DISTANCE_HP` of the target.

    Without a camera (or with one at the target), it comes from `DEFAULT_THROW_FROM` in the
    animal's heading frame (`heading`, 3x3).
    """
    reach = MAX_THROW_DISTANCE_HP * hp
    offset = None if eye is None else np.asarray(eye, dtype=float) - target
    if offset is None or np.linalg.norm(offset) < 1e-6:
        direction = heading @ np.asarray(DEFAULT_THROW_FROM)
        offset = reach * direction / np.linalg.norm(direction)
    distance = float(np.linalg.norm(offset))
    return target + offset * min(1.0, reach / distance)


class _GoalEnv(dict):
    """A minimal expression env to evaluate a goal parameter: time and body points."""

    def __init__(self, runtime: "ControllerRuntime", data: mujoco.MjData):
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
    """One built world: the scene, the compiled model, its state, the throw pool."""

    scene: "SceneSpec"
    setup: "SceneSetup"
    model: mujoco.MjModel
    data: mujoco.MjData
    pool: ThrowPool
    base_damping: np.ndarray
    hp: float


class LivePreview(_Preview):
    """An animal simulated live under a controller, its files watched for edits.

    Args:
        animal: animal name or config path.
        controller: controller name or YAML path.
        scene: scene name or YAML path (None: `flat`).
        parameters: controller parameter overrides (values as written in YAML).
        pool_size: throwable bodies of each kind.

    Raises:
        QuadpipeError: the animal, controller or scene cannot be loaded (at the start; later
            edits never raise, they set `error`).
    """

    overlay_names = LIVE_OVERLAYS

    def __init__(self, animal: str, controller: str, scene: str | None = None, parameters: Mapping[str, str] | None = None, pool_size: int = POOL_SIZE):
        from quadpipe.animals.library import load_animal
        from quadpipe.animals.model import build_animal
        from quadpipe.world import SCENE_KIND
        from quadpipe.sim.simulation import DEFAULT_SCENE

        self.controller = controller
        self.overrides: dict[str, str] = dict(parameters or {})
        self.goal_overrides: dict[str, str] = {}
        self.reload_error: str | None = None
        self.blow_up: str | None = None
        self.pool_size = pool_size
        self.built = build_animal(load_animal(animal))
        self.scene_path = configs.find_config(SCENE_KIND, scene or DEFAULT_SCENE)
        self.world = self._build_world(self._load_scene())
        runtime, sources = self._compile(self.world)
        super().__init__(Clock(self.world.model.opt.timestep, self._steps_per_frame(self.world.model)))
        self.run = self._make_run(runtime)
        self.controller_files = FileWatcher(sources)
        self.scene_file = FileWatcher([self.scene_path])
        self.scenery_version = 0
        self.scenery, self._body_ids = model_scenery(self.world.model, self.world.hp)
        mujoco.mj_forward(self.world.model, self.world.data)

    # -------------------------------------------------------------- building

    def _load_scene(self) -> "SceneSpec":
        from quadpipe.world import load_scene

        return load_scene(self.scene_path)

    def _build_world(self, scene: "SceneSpec") -> _World:
        from quadpipe.world import build_scene

        setup = build_scene(scene, self.built)
        first = setup.placements[0].built.animal
        names = add_throw_pool(setup.spec, first.pelvis_height, first.mass_kg, self.pool_size)
        model = setup.spec.compile()
        return _World(scene, setup, model, mujoco.MjData(model), ThrowPool(model, names), model.dof_damping.copy(), first.pelvis_height)

    def _compile(self, world: _World) -> tuple["ControllerRuntime", tuple[str, ...]]:
        """A runtime of the controller's current files for `world`, and the files it was read from.

        Raises:
            QuadpipeError: the files do not validate, or an override does not fit them.
        """
        from quadpipe.controllers.language import compile_controller, load_controller, scale_for_animals
        from quadpipe.controllers.runtime.runtime import ControllerRuntime

        placements = world.setup.placements
        declared = load_controller(self.controller).parameters
        goals = world.setup.goal_parameters | self.goal_overrides
        offered = {name: value for name, value in goals.items() if name in declared}
        given = {name: value for name, value in self.overrides.items() if name not in self.goal_overrides}
        spec = load_controller(self.controller, parameters=offered | given)
        compiled = compile_controller(spec, scale_for_animals([p.built.animal for p in placements]))
        world.model.dof_damping[:] = world.base_damping  # the runtime adds its damping to what it finds
        return ControllerRuntime(compiled, world.model, placements), spec.sources

    def _make_run(self, runtime: "ControllerRuntime") -> "Run":
        from quadpipe.sim.simulation import Run

        world = self.world
        return Run(world.model, world.data, world.setup.placements, [runtime], events=world.setup.events(world.model))

    @staticmethod
    def _steps_per_frame(model: mujoco.MjModel) -> int:
        return round(1.0 / (sizing.FRAME_RATE * model.opt.timestep))

    @property
    def runtime(self) -> "ControllerRuntime":
        """The controller runtime now driving the animals."""
        return self.run.controllers[0]

    @property
    def model(self) -> mujoco.MjModel:
        """The compiled world."""
        return self.world.model

    @property
    def data(self) -> mujoco.MjData:
        """Its state."""
        return self.world.data

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
        from quadpipe.sim.simulation import SimulationBlowUp, check_health

        for _ in range(steps):
            self.run.step()
        if steps:
            try:
                check_health(self.run, round(self.time * sizing.FRAME_RATE), self._far())
            except SimulationBlowUp as exc:
                self.blow_up = exc.format() + "\n  reset to start again"
                self.notify(self.blow_up)
                self.clock.paused = True
        return steps

    def _far(self) -> float:
        from quadpipe.sim.simulation import FAR_AWAY_HP

        return FAR_AWAY_HP * max(p.built.animal.pelvis_height for p in self.world.setup.placements)

    def reset(self) -> None:
        """Back to t = 0: the start pose, a fresh runtime of the current controller, thrown bodies parked."""
        from quadpipe.controllers.runtime.runtime import ControllerRuntime

        world = self.world
        mujoco.mj_resetData(world.model, world.data)
        world.pool.park_all(world.model)
        world.model.dof_damping[:] = world.base_damping
        self.run = self._make_run(ControllerRuntime(self.runtime.compiled, world.model, world.setup.placements))
        mujoco.mj_forward(world.model, world.data)
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
            runtime, sources = self._compile(self.world)
        except QuadpipeError as exc:
            self._fail(exc.format())
            return False
        runtime.adopt(self.runtime)
        runtime.last = self.runtime.last  # the forces acting until the next step, for the overlay
        self.run.controllers[0] = runtime
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
            runtime, sources = self._compile(world)
        except QuadpipeError as exc:
            self._fail(exc.format())
            return False
        runtime.adopt(self.runtime)
        self.world = world
        self.run = self._make_run(runtime)
        self.controller_files.watch(sources)
        self.clock = Clock(world.model.opt.timestep, self._steps_per_frame(world.model), self.clock.paused, self.clock.slow)
        self.scenery, self._body_ids = model_scenery(world.model, world.hp)
        self.scenery_version += 1
        mujoco.mj_forward(world.model, world.data)
        self.reload_error, self.blow_up = None, None
        self.notify(f"reloaded scene {world.scene.name!r}: the world was rebuilt and restarted")
        return True

    def _fail(self, text: str) -> None:
        self.reload_error = text
        self.notify(text)

    # -------------------------------------------------------------- actions

    def actions(self) -> dict[str, tuple[str, Callable[[np.ndarray | None], None]]]:
        """Clock and overlay actions, throws, goal moves and state switches (see `_Preview.actions`)."""
        actions = super().actions()
        actions["throw_ball"] = ("throw a ball at the animal from the camera", lambda eye: self.throw("ball", eye))
        actions["throw_box"] = ("throw a box at the animal from the camera", lambda eye: self.throw("box", eye))
        for name, (dx, dy) in {"goal_forward": (1, 0), "goal_back": (-1, 0), "goal_left": (0, 1), "goal_right": (0, -1)}.items():
            actions[name] = (f"move the goal {GOAL_STEP_HP:g} HP {name[5:]}", lambda eye, d=(dx, dy): self.nudge_goal(d))
        for k in range(1, STATE_KEYS + 1):
            actions[f"state_{k}"] = (f"force state {k} of the first state machine", lambda eye, k=k: self.force_state_number(k))
        return actions

    def throw(self, kind: ThrowKind, eye: np.ndarray | None = None) -> int:
        """Throw a ball or a box at the first animal's trunk from the camera at `eye`.

        It starts at the camera (within `MAX_THROW_DISTANCE_HP` of the target), aimed where
        the trunk will be when it gets there, at the animal's `froude_speed(2.5)`.

        Returns:
            the thrown body's id.
        """
        model, data = self.model, self.data
        runtime = self.runtime
        target = np.mean([runtime.point(data, p)[0] for p in THROW_TARGET_POINTS], axis=0)
        speed = math.sqrt(THROW_FROUDE * sizing.GRAVITY * self.world.hp)
        origin = throw_origin(eye, target, runtime.heading_frames(data)[0], self.world.hp)
        flight = float(np.linalg.norm(target - origin)) / speed
        drift = runtime.point_velocity(data, THROW_TARGET_POINTS[0])[0] * np.array([1.0, 1.0, 0.0])
        velocity = aim_velocity(origin, target + drift * flight, speed, model.opt.gravity)
        body = self.world.pool.throw(model, data, kind, origin, velocity)
        mujoco.mj_forward(model, data)
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
            return np.asarray(self.runtime.compiled.parameters[name](_GoalEnv(self.runtime, self.data)), dtype=float).reshape(-1, 3)[0]
        except KeyError:
            return None

    def move_goal(self, point: Sequence[float]) -> bool:
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
        """Move the goal `GOAL_STEP_HP` along world x and y times `direction` (from where it is now).

        Returns:
            True if moved; False if there is no goal, or one that depends on sensors (a notice says so).
        """
        current = self.goal_point()
        if current is None:
            self.notify(f"controller {self.runtime.name!r} has no goal point that can be moved")
            return False
        return self.move_goal(current + GOAL_STEP_HP * self.world.hp * np.array([*direction, 0.0]))

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
        return _pose(positions, self.data.xquat[self._body_ids], -HIDDEN_BELOW_HP * self.world.hp)

    def focus(self) -> np.ndarray:
        """The first animal's pelvis, where a following camera looks."""
        return self.runtime.point(self.data, "pelvis.start")[0].copy()

    def overlays(self) -> list[OverlayLayer]:
        """The shown overlay layers at the current state."""
        makers = {
            "segments": self._segments, "balance": self._balance, "forces": self._forces,
            "contacts": self._contacts, "goal": self._goal,
        }
        return [makers[name]() for name in self.overlay_names if name in self.shown]

    def _segments(self) -> OverlayLayer:
        runtime, data = self.runtime, self.data
        pairs = [(e.spec.from_, e.spec.to) for e in runtime.compiled.elements.values() if e.type == "segment"]
        starts = [runtime.point(data, a) for a, _ in pairs]
        ends = [runtime.point(data, b) for _, b in pairs]
        return layer("segments", "line", _stack(starts), _stack(ends), SEGMENT_RGBA)

    def _balance(self) -> OverlayLayer:
        """Gravity + velocity / horizon at each leg's top, one HP long for gravity alone."""
        from quadpipe.quantities import expressions

        runtime, data = self.runtime, self.data
        gravity = np.asarray(self.model.opt.gravity)
        hp = self._animal_hp()[:, None]
        starts, ends = [], []
        for leg in roles.LEGS:
            top = expressions.resolve_point_name(f"{leg}.top")
            at = runtime.point(data, top)
            vector = gravity + runtime.point_velocity(data, top) / BALANCE_HORIZON_S
            starts.append(at)
            ends.append(at + vector / np.linalg.norm(gravity) * hp)
        return layer("balance", "arrow", _stack(starts), _stack(ends), BALANCE_RGBA)

    def _forces(self) -> OverlayLayer:
        """Last step's Cartesian forces, `FORCE_ARROW_HP_PER_BW` HP per body weight."""
        last = self.runtime.last
        placements = self.world.setup.placements
        weight = np.array([p.built.animal.mass_kg * sizing.GRAVITY for p in placements])
        scale = FORCE_ARROW_HP_PER_BW * self._animal_hp() / weight
        ends = last.points + last.forces * scale[last.animals][:, None]
        colors = np.array([FORCE_RGBA[kind] for kind in last.kinds]).reshape(-1, 4)
        return layer("forces", "arrow", last.points, ends, colors)

    def _contacts(self) -> OverlayLayer:
        data = self.data
        count = data.ncon
        points = data.contact.pos[:count]
        normals = data.contact.frame[:count, :3]
        return layer("contacts", "arrow", points, points + normals * CONTACT_NORMAL_HP * self.world.hp, CONTACT_RGBA)

    def _goal(self) -> OverlayLayer:
        point = self.goal_point()
        return layer("goal", "point", np.zeros((0, 3)) if point is None else point, None, GOAL_RGBA)

    def _animal_hp(self) -> np.ndarray:
        return np.array([p.built.animal.pelvis_height for p in self.world.setup.placements])

    def status_line(self) -> str:
        """Time, clock state, controller, machine states, and whether there is an error."""
        parts = [self._clock_text(self.time), f"controller {self.runtime.name}"]
        parts += [f"{machine}: {self.runtime.state_of(machine)[0]}" for machine in self.runtime.compiled.machines]
        if self.error:
            parts.append("ERROR (see below)")
        return "  |  ".join(parts)


def model_scenery(model: mujoco.MjModel, hp: float) -> tuple[Scenery, np.ndarray]:
    """The drawable shapes of a compiled world: per moving body, and the world body's; with the body ids."""
    bodies, ids = [], []
    for body in range(1, model.nbody):
        shapes = _geom_shapes(model, body)
        if shapes:
            bodies.append(BodyShapes(model.body(body).name, shapes))
            ids.append(body)
    return Scenery(tuple(bodies), _geom_shapes(model, 0), hp), np.array(ids, dtype=int)


def _geom_shapes(model: mujoco.MjModel, body: int) -> tuple[Shape, ...]:
    start = int(model.body_geomadr[body])
    geoms = range(start, start + int(model.body_geomnum[body])) if start >= 0 else range(0)
    return tuple(geom_shape(model, g) for g in geoms if int(model.geom_type[g]) in _DRAWABLE_GEOMS)


def _stack(rows: list[np.ndarray]) -> np.ndarray:
    return np.concatenate(rows) if rows else np.zeros((0, 3))


def _pose(positions: np.ndarray, quaternions: np.ndarray, lowest: float) -> Pose:
    """A pose whose bodies below `lowest` (parked) or not finite (diverged) are hidden."""
    finite = np.isfinite(positions).all(axis=1) & np.isfinite(quaternions).all(axis=1)
    visible = finite & (np.where(finite, positions[:, 2], 0.0) > lowest)
    safe_quats = np.where(finite[:, None], quaternions, [1.0, 0.0, 0.0, 0.0])
    return Pose(np.where(finite[:, None], positions, 0.0), safe_quats, visible)


# --------------------------------------------------------------------------- replay


class ReplayPreview(_Preview):
    """A baked clip played on the preview clock, looping; overlays from `quadpipe.render`.

    Args:
        clip: the clip (see `load_replay`).
    """

    overlay_names = REPLAY_OVERLAYS

    def __init__(self, clip: Clip):
        from quadpipe.render import builtin_overlays

        if clip.frame_count == 0:
            raise QuadpipeError.single("empty-clip", "the clip has no frames to replay")
        super().__init__(Clock(1.0 / clip.fps))
        self.clip = clip
        self.frame = 0
        self._overlays = {overlay.name: overlay for overlay in builtin_overlays(clip, REPLAY_OVERLAYS)}
        self.scenery = clip_scenery(clip)
        self.scenery_version = 0
        self._positions, self._quaternions = _clip_poses(clip)
        self._focus = self._positions[0, 0].copy()

    @property
    def time(self) -> float:
        """Time of the current frame, seconds."""
        return self.frame / self.clip.fps

    def advance(self, wall_dt: float) -> int:
        """Move on by the frames `wall_dt` wall seconds are worth, looping at the end; returns them."""
        frames = self.clock.advance(wall_dt)
        self.frame = (self.frame + frames) % self.clip.frame_count
        return frames

    def reset(self) -> None:
        """Back to the first frame."""
        self.frame = 0
        self.clock.reset()

    def pose(self) -> Pose:
        """Every scenery body's pose at the current frame."""
        hp = self.scenery.hp
        return _pose(self._positions[self.frame], self._quaternions[self.frame], -HIDDEN_BELOW_HP * hp)

    def focus(self) -> np.ndarray:
        """The first animal's pelvis at this frame (its last finite place once it diverged)."""
        pelvis = self._positions[self.frame, 0]
        if np.isfinite(pelvis).all():
            self._focus = pelvis.copy()
        return self._focus

    def overlays(self) -> list[OverlayLayer]:
        """The shown layers at the current frame (items the clip marks NaN left out)."""
        layers = []
        for name in self.overlay_names:
            if name not in self.shown:
                continue
            overlay = self._overlays[name]
            starts = overlay.starts[self.frame]
            ends = starts if overlay.ends is None else overlay.ends[self.frame]
            keep = np.isfinite(starts).all(axis=1) & np.isfinite(ends).all(axis=1)
            layers.append(layer(name, overlay.kind, starts[keep], ends[keep], overlay.rgba))
        return layers

    def status_line(self) -> str:
        """Time, frame, clock state, and what the clip was made with."""
        meta = self.clip.metadata
        made = ", ".join(f"{key} {meta[key]}" for key in ("animal", "controller", "scene") if key in meta)
        parts = [self._clock_text(self.time), f"frame {self.frame + 1}/{self.clip.frame_count}"]
        return "  |  ".join(parts + ([made] if made else []))


def clip_scenery(clip: Clip) -> Scenery:
    """The drawable shapes of a clip: every animal bone (`name/role`), every prop, the terrain."""
    bodies = [
        BodyShapes(f"{track.name}/{role}", tuple(shapes))
        for track in clip.animals
        for role, shapes in zip(track.roles, track.shapes)
    ]
    bodies += [BodyShapes(prop.name, (prop.shape,)) for prop in clip.props]
    hp = clip.animals[0].pelvis_height if clip.animals else 1.0
    return Scenery(tuple(bodies), tuple(clip.terrain), float(hp))


def _clip_poses(clip: Clip) -> tuple[np.ndarray, np.ndarray]:
    """(F, B, 3) positions and (F, B, 4) orientations of the scenery's bodies, in its order."""
    positions = [track.positions for track in clip.animals] + [prop.positions[:, None] for prop in clip.props]
    rotations = [track.rotations for track in clip.animals] + [prop.rotations[:, None] for prop in clip.props]
    return np.concatenate(positions, axis=1), np.concatenate(rotations, axis=1)


REPLAY_SUFFIXES = (".npz",)
"""Clip files a preview can replay."""


def load_replay(path: str | Path) -> ReplayPreview:
    """A replay preview of a baked clip file.

    Raises:
        QuadpipeError: `unsupported-clip-format` for a suffix other than .npz, or the clip
            loader's errors (`file-not-found`, `bad-clip-file`).
    """
    from quadpipe.exporters.npz import load_clip

    path = Path(path)
    if path.suffix.lower() not in REPLAY_SUFFIXES:
        raise QuadpipeError.single(
            "unsupported-clip-format", f"cannot replay {str(path)!r}: previews read {', '.join(REPLAY_SUFFIXES)} clips",
            file=str(path), hint="bake the motion with `-o run.npz` (quadpipe simulate / bake)",
        )
    return ReplayPreview(load_clip(path))
