"""Loading scenes: parse, validate, and point every problem at its file:line:col.

A scene is checked in three passes, each reporting all it finds: structure (keys and value
shapes; the items of `terrain`, `props`, `throws` and `animals` one by one, so that errors
point inside the right item), then units of every quantity, then names (unique animals and
props, known species, throw targets). Values that depend on the animals' size (bounds, throw
reach) are checked when the scene is built (`quadpipe.world.values`).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import pydantic
from pydantic import BaseModel

from quadpipe.core import configs
from quadpipe.core.errors import Issue, Location, QuadpipeError, did_you_mean
from quadpipe.core.limits import MAX_ANIMALS, MAX_PROPS, MAX_TERRAIN_PIECES, MAX_THROWS, Limit
from quadpipe.core.textfiles import missing_file
from quadpipe.core.yamlio import YamlDocument, dotted, kind_of_value, load_yaml, located_issues
from quadpipe.quantities.expressions import ExprError, Namespace, check_expected, resolve_point_name
from quadpipe.world.format import (
    RESERVED_PROP_NAMES,
    SCHEMA_VERSION,
    TAGGED_LISTS,
    AnimalEntry,
    AnimalGrid,
    SceneFile,
    Stairs,
    ThrowSeries,
    is_zero,
    iter_quantities,
)
from quadpipe.world.set_format import TerrainMesh

SCENE_KIND = "scenes"
"""The config folder of scenes (see `quadpipe.core.configs`)."""


@dataclass(frozen=True)
class SceneSpec:
    """A validated scene file.

    Attributes:
        file: its content.
        doc: the parsed YAML, to point at values in errors found when building.
    """

    file: SceneFile
    doc: YamlDocument

    @property
    def name(self) -> str:
        """The scene's name."""
        return self.file.name

    @property
    def description(self) -> str:
        """Its one-line description."""
        return self.file.description

    def locate(self, path: tuple[Any, ...]) -> Location:
        """Where a value of the file is (or its nearest enclosing value)."""
        return self.doc.locate(path)


def available_scenes() -> list[str]:
    """Names of the built-in scenes."""
    return configs.available(SCENE_KIND)


def load_scene(name_or_path: str | Path) -> SceneSpec:
    """Load a built-in scene by name, or a scene file by path.

    Raises:
        QuadpipeError: unknown name (listing the valid ones), unreadable file, or every
            problem found in it, each at its file:line:col.
    """
    path = configs.find_config(SCENE_KIND, name_or_path)
    doc = load_yaml(path, "scene", SceneFile)
    return SceneSpec(parse_scene(doc), doc)


def parse_scene(doc: YamlDocument) -> SceneFile:
    """Validate a parsed scene document: structure, then units, then cross-references.

    Raises:
        QuadpipeError: every problem found, in file order.
    """
    if not isinstance(doc.data, dict):
        raise QuadpipeError.single(
            "invalid-value", "a scene file must be a mapping of keys (schema, name, terrain, ...)", where=doc.locate(())
        )
    issues = _structure_issues(doc)
    if not issues:
        scene = SceneFile.model_validate(doc.data)
        issues = _count_issues(scene, doc) or quantity_issues(scene, doc) + _reference_issues(scene, doc)
    if issues:
        raise QuadpipeError(sorted(issues, key=file_order))
    return scene


def file_order(issue: Issue) -> tuple[int, int]:
    """Sort key of issues: their line and column in the file."""
    where = issue.where or Location()
    return (where.line or 0, where.column or 0)


def _structure_issues(doc: YamlDocument) -> list[Issue]:
    """Keys and value shapes: the top level, then each item of the tagged lists on its own."""
    top = {key: ([] if key in TAGGED_LISTS and isinstance(value, list) else value) for key, value in doc.data.items()}
    issues = validate_part(SceneFile, top, (), doc)
    for key, (tag_of, models, what) in TAGGED_LISTS.items():
        items = doc.data.get(key)
        for index, item in enumerate(items if isinstance(items, list) else []):
            path = (key, index)
            if not isinstance(item, dict):
                issues.append(
                    Issue("invalid-value", f"{what} item {index + 1} must be a mapping of keys", doc.locate(path))
                )
                continue
            tag = tag_of(item)
            if tag is None:
                issues.append(
                    Issue(
                        "missing-key",
                        f"{what} item {index + 1} has no `type`",
                        doc.locate(path),
                        f"valid: {', '.join(models)}",
                    )
                )
            elif not isinstance(tag, str):
                issues.append(
                    Issue(
                        "invalid-value",
                        f"{what} item {index + 1}'s `type` must be a name, not {kind_of_value(tag)}",
                        doc.locate(path + ("type",)),
                        f"valid: {', '.join(models)}",
                    )
                )
            elif tag not in models:
                issues.append(
                    Issue(
                        f"unknown-{what}-type",
                        f"there is no {what} type {tag!r}",
                        doc.locate(path + ("type",)),
                        did_you_mean(str(tag), models),
                    )
                )
            else:
                issues += validate_part(models[tag], item, path, doc)
    if not issues:
        issues += schema_issues(doc)
    return issues


def schema_issues(doc: YamlDocument) -> list[Issue]:
    """`unsupported-schema` when a scene or direction file's `schema:` is not this quadpipe's."""
    if doc.data.get("schema") == SCHEMA_VERSION:
        return []
    return [
        Issue(
            "unsupported-schema",
            f"schema version {doc.data.get('schema')!r} is not supported",
            doc.locate(("schema",)),
            f"this quadpipe reads `schema: {SCHEMA_VERSION}`",
        )
    ]


def validate_part(model: type[BaseModel], data: Any, prefix: tuple[Any, ...], doc: YamlDocument) -> list[Issue]:
    """Pydantic errors of `data` against `model`, located at `prefix` + their path in the file."""
    try:
        model.model_validate(data)
    except pydantic.ValidationError as exc:
        return located_issues(exc, model, doc, prefix)
    return []


def shown(path: tuple[Any, ...], doc: YamlDocument) -> str:
    """A value's path for messages, without the keys a shorthand leaves out of the file."""
    while path and path not in doc.value_positions:
        path = path[:-1]
    return dotted(path)


_MOST_PIECES_PER_ITEM = 3
"""Boxes a terrain item other than stairs is built from, at most (a hill: up, top, down)."""


def _count_issues(scene: SceneFile, doc: YamlDocument) -> list[Issue]:
    """Terrain pieces, props, throws and animals over their limits (stairs, grids and random
    series counted as what they expand to), each at the item that goes over, checked before
    anything is expanded or built."""
    counts = {
        (MAX_TERRAIN_PIECES, "terrain"): [
            item.steps + 1 if isinstance(item, Stairs) else _MOST_PIECES_PER_ITEM for item in scene.terrain
        ],
        (MAX_PROPS, "props"): [1 for _ in scene.props],
        (MAX_THROWS, "throws"): [throw.random.count if isinstance(throw, ThrowSeries) else 1 for throw in scene.throws],
        (MAX_ANIMALS, "animals"): [
            entry.grid.rows * entry.grid.columns if isinstance(entry, AnimalGrid) else 1
            for entry in scene.animals or []
        ],
    }
    return [issue for (limit, key), sizes in counts.items() for issue in _over(limit, key, sizes, doc)]


def _over(limit: Limit, key: str, sizes: list[int], doc: YamlDocument) -> list[Issue]:
    """The issue of the first item of list `key` whose running total of `sizes` is over `limit`."""
    total = 0
    for index, size in enumerate(sizes):
        total += size
        if total > limit.value:
            return limit.exceeded(sum(sizes), where=doc.locate((key, index))).issues
    return []


def quantity_issues(scene: BaseModel, doc: YamlDocument) -> list[Issue]:
    """Units and dimensions of every quantity; scene values must be constants."""
    issues = []
    for path, value, expect, _ in iter_quantities(scene):
        if is_zero(value):
            continue
        try:
            expr = check_expected(value, expect, Namespace())
        except ExprError as exc:
            issues.append(Issue(exc.code, f"{shown(path, doc)}: {exc.message}", doc.locate(path), exc.hint))
            continue
        if expr.needs:
            issues.append(
                Issue(
                    "not-constant",
                    f"{shown(path, doc)}: a scene value must be fixed, but {value!r} reads the simulation",
                    doc.locate(path),
                    "`t`, body points and sensors only exist in controllers; moving goals use `path`",
                )
            )
    return issues


def _reference_issues(scene: SceneFile, doc: YamlDocument) -> list[Issue]:
    """Names: unique animals and props, known species, throw targets and animals that exist."""
    issues = []
    names = animal_names(scene)
    if names == []:
        issues.append(
            Issue(
                "invalid-value",
                "animals: the list is empty",
                doc.locate(("animals",)),
                "list at least one animal, or leave `animals` out for the default one",
            )
        )
    seen: set[str] = set()
    for path, name in _named_things(scene):
        if name in seen:
            issues.append(
                Issue(
                    "duplicate-name",
                    f"the name {name!r} is used twice",
                    doc.locate(path),
                    "give every animal and prop its own name",
                )
            )
        seen.add(name)
    issues += _reserved_issues(scene, doc)
    issues += _set_file_issues(scene, doc)
    for index, entry in enumerate(scene.animals or []):
        if entry.species is not None:
            issues += _species_issues(entry.species, ("animals", index, "species"), doc)
    for index, throw in enumerate(scene.throws):
        path = ("throws", index)
        try:
            resolve_point_name(throw.target)
        except ExprError as exc:
            issues.append(
                Issue(
                    exc.code, f"{dotted(path + ('target',))}: {exc.message}", doc.locate(path + ("target",)), exc.hint
                )
            )
        if names is not None and not animal_exists(throw.animal, names):
            issues.append(
                Issue(
                    "unknown-animal-ref",
                    f"there is no animal {throw.animal!r} in this scene",
                    doc.locate(path + ("animal",)),
                    animal_hint(names),
                )
            )
    return issues


def _set_file_issues(scene: SceneFile, doc: YamlDocument) -> list[Issue]:
    """Set files (`type: mesh` terrain) that are missing or in a format quadpipe does not read."""
    from quadpipe.world.sets import set_issue

    issues = []
    for index, item in enumerate(scene.terrain):
        if isinstance(item, TerrainMesh):
            path = ("terrain", index, "file")
            issue = set_issue(set_path(doc, item), item.file, doc.locate(path))
            issues += [] if issue is None else [issue]
    return issues


def set_path(doc: YamlDocument, item: TerrainMesh) -> Path:
    """Where a set file is: its `file`, relative to the scene file."""
    return Path(doc.file).parent / item.file


def _named_things(scene: SceneFile) -> Iterator[tuple[tuple[Any, ...], str]]:
    for index, entry in enumerate(scene.animals or []):
        for name in entry_names(entry):
            yield ("animals", index, "name"), name
    for index, prop in enumerate(scene.props):
        yield ("props", index, "name"), prop.name


def _reserved_issues(scene: SceneFile, doc: YamlDocument) -> list[Issue]:
    return [
        Issue(
            "reserved-name",
            f"the name {prop.name!r} is taken by the scene itself",
            doc.locate(("props", index, "name")),
            "rename the prop",
        )
        for index, prop in enumerate(scene.props)
        if RESERVED_PROP_NAMES.match(prop.name)
    ]


def entry_names(entry: AnimalEntry | AnimalGrid) -> list[str]:
    """The names of the animals of one `animals` item (a grid's are numbered row by row)."""
    if isinstance(entry, AnimalGrid):
        return [f"{entry.name}{k + 1}" for k in range(entry.grid.rows * entry.grid.columns)]
    return [entry.name]


def animal_names(scene: SceneFile) -> list[str] | None:
    """The names of the scene's animals in order (grids expanded); None when it has the default one."""
    if scene.animals is None:
        return None
    return [name for entry in scene.animals for name in entry_names(entry)]


def animal_exists(ref: int | str, names: list[str]) -> bool:
    """Whether an animal reference (index or name) names one of the scene's animals."""
    return 0 <= ref < len(names) if isinstance(ref, int) else ref in names


def animal_hint(names: list[str]) -> str:
    """The hint of an unknown animal reference: the valid indices and names."""
    return f"use an index from 0 to {len(names) - 1}, or a name ({', '.join(names[:10])}{', ...' if len(names) > 10 else ''})"


def _species_issues(species: str, path: tuple[Any, ...], doc: YamlDocument) -> list[Issue]:
    if is_path(species):
        file = Path(doc.file).parent / species
        if file.is_file():
            return []
        issue = missing_file(file, "animal", name=species, where=doc.locate(path), suffixes=(".yaml", ".yml"))
        return [replace(issue, message=f"{issue.message} (relative to this scene)")]
    known = configs.available("animals")
    return (
        []
        if species in known
        else [
            Issue(
                "unknown-animal",
                f"there is no animal named {species!r}",
                doc.locate(path),
                did_you_mean(species, known),
            )
        ]
    )


def is_path(text: str) -> bool:
    """Whether a `species` names a config file (relative to the scene) rather than a built-in animal."""
    return "/" in text or text.endswith((".yaml", ".yml"))
