"""Building a scene for its animals: the world's `MjSpec` with terrain, props, thrown
objects and the animals placed in it (`build_scene` -> `SceneSetup`)."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np

from quadpipe.animals import sizing
from quadpipe.animals.model import BuiltAnimal
from quadpipe.core.errors import Issue, Location, QuadpipeError
from quadpipe.quantities import units
from quadpipe.world.direction import DirectionSpec, bend_warnings, body_length, scene_timelines
from quadpipe.world.format import AnimalGrid, Ground
from quadpipe.world.goals import check_direction_length, direction_parameters, goal_text, look_ahead
from quadpipe.world.loading import SceneSpec, entry_names, is_path
from quadpipe.world.placement import Placement, attach_animals, world_spec
from quadpipe.world.props import PropStart, add_props
from quadpipe.world.terrain import add_terrain
from quadpipe.world.throws import ThrowEvent, ThrowPlan, add_thrown, plan_throws, point_on_bone
from quadpipe.world.timeline import Timeline
from quadpipe.world.values import Values


@dataclass
class SceneSetup:
    """A scene built for its animals.

    Attributes:
        scene: what it was built from.
        spec: the world, uncompiled, animals attached under `<name>/`.
        placements: the animals, in scene order (the first sets HP, bw and bm).
        headings: each animal's start heading, radians counter-clockwise from +x.
        goal_parameters: controller parameter -> expression text (metres, `t` in seconds).
        throws: the throws in declaration order (random series expanded).
        prop_velocities: prop body name -> its start velocity, for props that move at the start.
        timelines: animal name -> its direction played out in time (see `quadpipe.world.timeline`).
        directions: animal name -> the controller parameters that play its timeline
            (`quadpipe.world.goals.direction_parameters`); see `parameter_groups`.
        warnings: what the scene warns of (a directed path bending tighter than its animal
            can follow: `quadpipe.world.direction.bend_warnings`).
    """

    scene: SceneSpec
    spec: mujoco.MjSpec
    placements: list[Placement]
    headings: list[float]
    goal_parameters: dict[str, str]
    throws: list[ThrowPlan] = field(default_factory=list)
    prop_velocities: dict[str, np.ndarray] = field(default_factory=dict)
    timelines: dict[str, Timeline] = field(default_factory=dict)
    directions: dict[str, dict[str, str]] = field(default_factory=dict)
    warnings: list[Issue] = field(default_factory=list)

    def parameter_groups(self) -> list[tuple[list[Placement], dict[str, str]]]:
        """The animals that one controller runtime drives together, with the parameters the
        scene offers them: each directed animal alone, with its direction's, and the others
        together, with the goals. One group holding every animal when none is directed, or
        when the only animal is (its direction is then among `goal_parameters` too)."""
        rest = [p for p in self.placements if p.name not in self.directions]
        groups = [([p], self.goal_parameters | self.directions[p.name]) for p in self.placements if p not in rest]
        return groups + ([(rest, self.goal_parameters)] if rest else [])

    def goal_places(self) -> dict[str, Location]:
        """Where each goal is written in the scene file, for messages about the parameter it sets."""
        return {name: self.scene.locate(("goals", name)) for name in self.goal_parameters}

    def events(self, model: mujoco.MjModel) -> list[Callable[[mujoco.MjModel, mujoco.MjData], None]]:
        """The scene's events for a model compiled from `spec`: props set moving, then the throws.

        Each is called before every physics step (see `quadpipe.sim.simulation.Simulation.step`). Thrown objects
        are parked (collisions off, held against gravity) until their time; binding resets
        that, so a model can be reused.
        """
        starts: list[Callable] = [PropStart(model, name, velocity) for name, velocity in self.prop_velocities.items()]
        headings = dict(zip((p.name for p in self.placements), self.headings))
        throws = [
            ThrowEvent(model, plan, self._point_offset(plan), headings[plan.animal], self._bones(plan.animal))
            for plan in self.throws
        ]
        return starts + throws

    def _placement(self, animal: str) -> Placement:
        """The placement of the animal named `animal`."""
        return next(p for p in self.placements if p.name == animal)

    def _bones(self, animal: str) -> list[tuple[str, np.ndarray]]:
        """An animal's bones for its throws: each bone's body and the bone in that body's frame
        (a bone's body starts at the bone's start, its axes the world's in the rest pose)."""
        bones = self._placement(animal).built.animal.skeleton.bones
        return [(f"{animal}/{role}", np.asarray(bone.end) - np.asarray(bone.start)) for role, bone in bones.items()]

    def _point_offset(self, plan: ThrowPlan) -> tuple[str, np.ndarray]:
        """The target's body and the point's offset from that body's origin, in the body frame."""
        role, offset = point_on_bone(self._placement(plan.animal).built.animal.skeleton, plan.point)
        return f"{plan.animal}/{role}", offset


@dataclass(frozen=True)
class _Slot:
    """One animal of the scene before placement: its name, model and where it is declared.

    Attributes:
        name: instance name.
        built: its model.
        index: index of its item in `animals`, None for the default animal.
        cell: its rank in a grid (row by row), 0 otherwise.
    """

    name: str
    built: BuiltAnimal
    index: int | None = None
    cell: int = 0


def build_scene(
    scene: SceneSpec, species: Sequence[BuiltAnimal] | BuiltAnimal, direction: DirectionSpec | None = None
) -> SceneSetup:
    """Build a scene's world with its animals.

    Args:
        scene: the loaded scene.
        species: the animal for scene entries without a `species` (the command line's): one
            for all of them, or a list with one per such animal, in scene order.
        direction: a direction file that replaces the scene's `direction:` section.

    Raises:
        QuadpipeError: a value out of range for these animals, a throw too slow for its
            distance, goal times out of order, the wrong number of animals given, a
            direction that cannot be played (see `quadpipe.world.direction.scene_timelines`).
    """
    slots = _slots(scene, species)
    first = slots[0].built.animal
    hp = first.pelvis_height
    scale = units.Scale.of(hp, first.mass_kg)
    values = Values(scene, scale)
    placements = [_placement(values, scene, slot) for slot in slots]
    ground = scene.file.ground
    friction = (ground or Ground.model_validate({})).friction
    spec = world_spec(
        scene.name, [placement.built for placement in placements], friction if ground is not None else None
    )
    add_terrain(spec, scene, values, friction)
    attach_animals(spec, placements, friction, scene.file.animals_collide)
    tau = sizing.constraint_time_constant(hp)
    velocities = add_props(spec, scene, values, tau)
    skeletons = {placement.name: placement.built.animal.skeleton for placement in placements}
    throws = plan_throws(scene, values, skeletons, -float(spec.option.gravity[2]))
    add_thrown(spec, throws, tau, hp)
    goals = {name: goal_text(scene, values, name) for name in scene.file.goals}
    lengths = {placement.name: body_length(placement.built.animal) for placement in placements}
    timelines = scene_timelines(scene, values, [placement.name for placement in placements], scale, direction, lengths)
    directions = {
        p.name: direction_parameters(timelines[p.name], *_sizes(p.built), look_ahead(p.built.animal))
        for p in placements
        if p.name in timelines
    }
    for name, parameters in directions.items():
        check_direction_length(name, parameters, (direction or scene).locate(("direction", name)))
    if len(placements) == 1:
        goals |= directions.get(placements[0].name, {})
    headings = [placement.heading for placement in placements]
    warnings = [
        issue
        for p in placements
        if p.name in timelines
        for issue in bend_warnings(
            p.name, p.built.animal, timelines[p.name], (direction or scene).locate(("direction", p.name))
        )
    ]
    return SceneSetup(scene, spec, placements, headings, goals, throws, velocities, timelines, directions, warnings)


def _sizes(built: BuiltAnimal) -> tuple[float, float]:
    """An animal's pelvis height (m) and natural time sqrt(HP / g) (s)."""
    hp = built.animal.pelvis_height
    return hp, math.sqrt(hp / units.STANDARD_GRAVITY)


def _slots(scene: SceneSpec, species: Sequence[BuiltAnimal] | BuiltAnimal) -> list[_Slot]:
    """The scene's animals in order, grids expanded, each with its model."""
    given = [species] if isinstance(species, BuiltAnimal) else list(species)
    items = scene.file.animals
    needed = 1 if items is None else sum(len(entry_names(item)) for item in items if item.species is None)
    if needed and len(given) not in (1, needed):
        raise QuadpipeError.single(
            "animal-count",
            f"this scene has {needed} animals without a species, and {len(given)} animals were given",
            where=scene.locate(("animals",)),
            hint="give one animal for all of them, or one per animal",
        )
    if items is None:
        return [_Slot(given[0].animal.name, given[0])]
    pending = iter(given * needed if len(given) == 1 else given)
    built_of = _species_builder(scene)
    slots = []
    for index, item in enumerate(items):
        for cell, name in enumerate(entry_names(item)):
            built = next(pending) if item.species is None else built_of(item.species)
            slots.append(_Slot(name, built, index, cell))
    return slots


def _species_builder(scene: SceneSpec) -> Callable[[str], BuiltAnimal]:
    """Load and build the animals a scene names, once per species."""
    from quadpipe.animals.library import load_animal
    from quadpipe.animals.model import build_animal

    cache: dict[str, BuiltAnimal] = {}

    def built_of(species: str) -> BuiltAnimal:
        if species not in cache:
            source = Path(scene.doc.file).parent / species if is_path(species) else species
            cache[species] = build_animal(load_animal(source))
        return cache[species]

    return built_of


def _placement(values: Values, scene: SceneSpec, slot: _Slot) -> Placement:
    """Where a slot's animal starts."""
    if slot.index is None:
        return Placement(slot.name, slot.built, (0.0, 0.0), 0.0)
    base = ("animals", slot.index)
    assert scene.file.animals is not None, "a slot with an index comes from the scene's `animals`"
    item = scene.file.animals[slot.index]
    x, y = values.items(base + ("at",), 2)
    if isinstance(item, AnimalGrid):
        row_gap, column_gap = values.items(base + ("grid", "spacing"), 2)
        row, column = divmod(slot.cell, item.grid.columns)
        x, y = x - row * row_gap, y - column * column_gap
    return Placement(slot.name, slot.built, (float(x), float(y)), float(values[base + ("heading",)]))
