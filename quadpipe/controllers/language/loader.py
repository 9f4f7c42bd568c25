"""Reading controller files: YAML, structure, leg templates and `extends` merging.

`merge_controller(path)` reads a file and, recursively, the controllers it extends, and
returns a `MergedController`: raw element mappings with their templates expanded
(`for_each` -> one copy per leg with `{leg}` replaced), parents' elements merged by name
(replaced, removed with `remove:`, changed with `override:`), parameters and groups merged
by name, and every element validated against its pydantic model. Each element keeps an
`Origin` that locates any of its keys in the file (and the override) it came from, so later
checks can point at `file:line:col`.

Problems are collected as `Issue`s rather than raised, so that one run reports them all.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from fnmatch import fnmatchcase
from pathlib import Path
from typing import Any, Callable, Iterable, Mapping

import pydantic

from quadpipe.core import configs
from quadpipe.anatomy import roles
from quadpipe.controllers.language.schema import LEG_PLACEHOLDER, MODEL_OF_TYPE, SCHEMA_VERSION, ControllerFile
from quadpipe.core.errors import Issue, Location, QuadpipeError, did_you_mean
from quadpipe.core.yamlio import YamlDocument, field_names_at, load_yaml
from quadpipe.core.yamlio import unwrap_annotation as unwrap_annotation  # re-exported

BUILTIN_GROUPS: dict[str, tuple[str, ...]] = {
    "all_legs": ("lf", "rf", "lh", "rh"),
    "front_legs": ("lf", "rf"),
    "hind_legs": ("lh", "rh"),
    "left_legs": ("lf", "lh"),
    "right_legs": ("rf", "rh"),
}
"""Leg groups every controller can use in `for_each`, `feet` and its own `groups`."""

PLACEHOLDER = re.compile(r"\{[^{}\s]*\}")
"""Text that looks like a placeholder, such as `{leg}` or a mistyped `{legs}`."""

CONTROLLER_KIND = "controllers"
"""The configs folder holding built-in controllers."""


@dataclass(frozen=True)
class Layer:
    """One source of an element's keys: a mapping in a YAML document.

    Attributes:
        doc: the document.
        base: path of the mapping in the document.
        raw: the mapping, after `{leg}` substitution.
        key_map: keys changed by substitution -> the key as written, to find positions.
    """

    doc: YamlDocument
    base: tuple[Any, ...]
    raw: Any
    key_map: Mapping[Any, Any] = field(default_factory=dict)

    def holds(self, path: tuple[Any, ...]) -> bool:
        """Whether the mapping contains `path`."""
        node = self.raw
        for part in path:
            if isinstance(node, dict) and part in node:
                node = node[part]
            elif isinstance(node, list) and isinstance(part, int) and 0 <= part < len(node):
                node = node[part]
            else:
                return False
        return True

    def locate(self, path: tuple[Any, ...], key: bool) -> Location:
        """Position of `path` in the document."""
        written = tuple(self.key_map.get(part, part) for part in path)
        return self.doc.locate(self.base + written, key=key)


@dataclass(frozen=True)
class Origin:
    """Where an element's keys come from: layers from the original element to the last patch."""

    layers: tuple[Layer, ...]

    def locate(self, path: Iterable[Any] = (), key: bool = False) -> Location:
        """Position of a key path of the element, in the latest layer that sets it."""
        path = tuple(path)
        layers = self.layers[self._last_replacing(path):]
        for size in range(len(path), -1, -1):
            for layer in reversed(layers):
                if layer.holds(path[:size]):
                    return layer.locate(path[:size], key and size == len(path))
        return self.layers[0].locate((), key)

    def _last_replacing(self, path: tuple[Any, ...]) -> int:
        """Index of the last layer that replaced a part of `path` by a plain value, 0 if none.

        Keys that earlier layers had below that part are gone, so their positions must not be
        reported (`strength: 20 deg` over a parent's `strength: {force: ...}`).
        """
        for index in range(len(self.layers) - 1, 0, -1):
            node = self.layers[index].raw
            for part in path[:-1]:
                if not isinstance(node, dict) or part not in node:
                    break
                node = node[part]
                if not isinstance(node, (dict, list)):
                    return index
        return 0

    def sublayer(self, path: tuple[Any, ...], raw: Any) -> Layer:
        """A layer for the mapping `raw` found at `path` inside this element (a state's patch)."""
        for layer in reversed(self.layers):
            if layer.holds(path):
                written = tuple(layer.key_map.get(part, part) for part in path)
                return Layer(layer.doc, layer.base + written, raw, layer.key_map)
        return Layer(self.layers[-1].doc, self.layers[-1].base + path, raw)

    def patched(self, layer: Layer) -> "Origin":
        """This origin with one more patch on top."""
        return Origin((*self.layers, layer))


@dataclass
class ElementEntry:
    """One element after template expansion and merging.

    Attributes:
        name: its (expanded) name.
        raw: its keys, as plain data.
        origin: where each key comes from.
        template: the name as written (with {leg}) for a `for_each` copy.
        model: the validated pydantic model, set once the merge is complete.
    """

    name: str
    raw: dict[str, Any]
    origin: Origin
    template: str | None = None
    model: Any = None

    @property
    def label(self) -> str:
        """How messages name it: the template's name for a `for_each` copy, so copies agree."""
        return f"element {self.template or self.name!r}"


@dataclass(frozen=True)
class ParameterEntry:
    """A parameter as written: its value, description and position."""

    value: Any
    description: str
    where: Location
    file: str


@dataclass
class MergedController:
    """A controller with its `extends` chain merged, before meaning is checked.

    Attributes:
        name: the controller's name.
        description: its description.
        sources: files read, the requested one first.
        parameters: name -> entry (children replace parents').
        groups: leg groups, built-in ones included.
        elements: name -> entry, in order (parents' first, replaced ones in place).
    """

    name: str
    description: str
    sources: list[str]
    parameters: dict[str, ParameterEntry]
    groups: dict[str, tuple[str, ...]]
    elements: dict[str, ElementEntry]


# --------------------------------------------------------------------------- pydantic errors


def pydantic_issues(
    exc: pydantic.ValidationError,
    model: type[pydantic.BaseModel],
    locate: Callable[[tuple[Any, ...], bool], Location],
    label: str,
) -> list[Issue]:
    """Turn pydantic errors into located issues (unknown-key, missing-key, invalid-value).

    Args:
        exc: the validation error.
        model: the model that was validated (for valid key names).
        locate: key path, point-at-key flag -> location.
        label: what was validated, for messages (`element 'legs'`).
    """
    issues = []
    for err in exc.errors():
        loc = tuple(err["loc"])
        where = _where_in(label, loc[:-1])
        if isinstance(err.get("input"), bool):
            issues.append(_yaml_boolean_issue(err, loc, label, locate))
        elif err["type"] == "extra_forbidden":
            name = str(loc[-1])
            valid = field_names_at(model, loc[:-1])
            issues.append(Issue("unknown-key", f"{name!r} is not a valid key in {where}", locate(loc, True), did_you_mean(name, valid) if valid else None))
        elif err["type"] == "missing":
            issues.append(Issue("missing-key", f"required key {loc[-1]!r} is missing in {where}", locate(loc[:-1], False)))
        else:
            message = err["msg"].removeprefix("Value error, ")
            issues.append(Issue("invalid-value", f"{_where_in(label, loc)}: {message}", locate(loc, False)))
    return issues


def _yaml_boolean_issue(err: dict[str, Any], loc: tuple[Any, ...], label: str, locate: Callable[[tuple[Any, ...], bool], Location]) -> Issue:
    """YAML 1.1 reads yes/no/on/off/true/false as booleans; say so where a name was meant."""
    if loc and loc[-1] == "[key]":
        where, at = _where_in(label, loc[:-2]), locate(loc[:-1], True)
        subject = "a key here"
    else:
        where, at = _where_in(label, loc), locate(loc, False)
        subject = "this value"
    word = str(err["input"]).lower()
    return Issue("invalid-value", f"{where}: YAML read {subject} as {word}, not as a name", at, 'quote words like on, off, yes, no, true, false: "on"')


def _where_in(label: str, loc: tuple[Any, ...]) -> str:
    dotted = ".".join(str(part) for part in loc)
    return f"`{dotted}` of {label}" if dotted else label


# --------------------------------------------------------------------------- reading


_UNQUOTED_PLACEHOLDER = re.compile(r"(:|-)\s+\{leg\}")


def _read_yaml(path: Path, issues: list[Issue]) -> YamlDocument | None:
    try:
        return load_yaml(path)
    except QuadpipeError as exc:
        issues.extend(_with_placeholder_hint(issue, path) for issue in exc.issues)
        return None


def _with_placeholder_hint(issue: Issue, path: Path) -> Issue:
    """Explain the most common YAML error in controllers: an unquoted `{leg}` value."""
    if issue.code != "yaml-syntax" or issue.where is None or issue.where.line is None:
        return issue
    lines = path.read_text(encoding="utf-8").splitlines()
    nearby = lines[max(issue.where.line - 2, 0) : issue.where.line]
    if any(_UNQUOTED_PLACEHOLDER.search(line) for line in nearby):
        return Issue(issue.code, issue.message, issue.where, 'a value starting with {leg} must be quoted: "{leg}_hip", or YAML reads it as a mapping')
    return issue


def _read(path: Path, issues: list[Issue]) -> tuple[YamlDocument, ControllerFile] | None:
    """Parse a file and check its top-level keys (elements are checked after merging)."""
    doc = _read_yaml(path, issues)
    if doc is None:
        return None
    if not isinstance(doc.data, dict):
        issues.append(Issue("invalid-value", "a controller file must be a mapping of keys (schema, name, elements, ...)", doc.locate(())))
        return None
    top = {key: value for key, value in doc.data.items() if key != "elements"}
    try:
        model = ControllerFile.model_validate(top)
    except pydantic.ValidationError as exc:
        issues.extend(pydantic_issues(exc, ControllerFile, lambda loc, key: doc.locate(loc, key=key), "the controller"))
        return None
    if model.schema_ != SCHEMA_VERSION:
        issues.append(Issue("unsupported-schema", f"schema version {model.schema_} is not supported", doc.locate(("schema",)), f"this quadpipe reads `schema: {SCHEMA_VERSION}`"))
        return None
    return doc, model


def _raw_elements(doc: YamlDocument, issues: list[Issue]) -> list[tuple[tuple[Any, ...], dict[str, Any]]]:
    """The file's element mappings with their paths; those without a usable type and name are reported."""
    elements = doc.data.get("elements", [])
    if elements is None:
        return []
    if not isinstance(elements, list):
        issues.append(Issue("invalid-value", "`elements` must be a list (each item starting with '- type: ...')", doc.locate(("elements",))))
        return []
    found = []
    for index, raw in enumerate(elements):
        path = ("elements", index)
        if not isinstance(raw, dict):
            issues.append(Issue("invalid-value", f"element {index + 1} must be a mapping with `type` and `name`", doc.locate(path)))
            continue
        kind = raw.get("type")
        if kind is None:
            issues.append(Issue("missing-key", f"element {index + 1} has no `type`", doc.locate(path), f"valid: {', '.join(MODEL_OF_TYPE)}"))
            continue
        if kind not in MODEL_OF_TYPE:
            issues.append(Issue("unknown-element-type", f"there is no element type {kind!r}", doc.locate(path + ("type",)), did_you_mean(str(kind), MODEL_OF_TYPE)))
            continue
        if not isinstance(raw.get("name"), str):
            issues.append(Issue("missing-key", f"element {index + 1} ({kind}) needs a `name` (text)", doc.locate(path + ("name",) if "name" in raw else path)))
            continue
        found.append((path, raw))
    return found


# --------------------------------------------------------------------------- templates


def resolve_legs(items: Iterable[str], groups: Mapping[str, tuple[str, ...]]) -> tuple[list[str], list[str]]:
    """Legs named by leg prefixes and group names, in order without repeats; and the unknown names."""
    legs: list[str] = []
    unknown = []
    for item in items:
        members = (item,) if item in roles.LEGS else groups.get(item)
        if members is None:
            unknown.append(item)
            continue
        legs.extend(leg for leg in members if leg not in legs)
    return legs, unknown


def _substitute(value: Any, leg: str, key_map: dict[Any, Any]) -> Any:
    if isinstance(value, str):
        return value.replace(LEG_PLACEHOLDER, leg)
    if isinstance(value, list):
        return [_substitute(item, leg, key_map) for item in value]
    if isinstance(value, dict):
        out = {}
        for key, item in value.items():
            new_key = _substitute(key, leg, key_map)
            if new_key != key:
                key_map[new_key] = key
            out[new_key] = _substitute(item, leg, key_map)
        return out
    return value


def _expand(
    doc: YamlDocument, path: tuple[Any, ...], raw: dict[str, Any], groups: Mapping[str, tuple[str, ...]], issues: list[Issue]
) -> list[ElementEntry]:
    """One entry per leg for a `for_each` element, or the element itself."""
    for_each = raw.get("for_each")
    if for_each is None:
        return [ElementEntry(raw["name"], raw, Origin((Layer(doc, path, raw),)))]
    items = for_each if isinstance(for_each, list) else [for_each]
    if not all(isinstance(item, str) for item in items):
        issues.append(Issue("invalid-value", "`for_each` lists legs (lf, rf, lh, rh) or group names", doc.locate(path + ("for_each",))))
        return []
    legs, unknown = resolve_legs(items, groups)
    for name in unknown:
        issues.append(Issue("unknown-leg", f"{name!r} is neither a leg nor a group", doc.locate(path + ("for_each",)), did_you_mean(name, [*roles.LEGS, *groups])))
    if LEG_PLACEHOLDER not in raw["name"]:
        issues.append(
            Issue("template-name", f"element {raw['name']!r} has `for_each` but its name lacks {LEG_PLACEHOLDER}", doc.locate(path + ("name",)), f'each copy needs its own name, e.g. "{LEG_PLACEHOLDER}_{raw["name"]}"')
        )
        return []
    entries = []
    body = {key: value for key, value in raw.items() if key != "for_each"}
    for leg in legs:
        key_map: dict[Any, Any] = {}
        copy = _substitute(body, leg, key_map)
        entries.append(ElementEntry(copy["name"], copy, Origin((Layer(doc, path, copy, key_map),)), raw["name"]))
    return entries


def _placeholder_issues(entry: ElementEntry) -> list[Issue]:
    """Placeholders left in an element: `{leg}` without `for_each`, or unknown ones."""
    issues = []
    for path, text in _strings(entry.raw, ()):
        match = PLACEHOLDER.search(text)
        if match is None:
            continue
        if match.group() == LEG_PLACEHOLDER:
            issues.append(Issue("unknown-placeholder", f"{LEG_PLACEHOLDER} in {entry.label}, which has no `for_each`", entry.origin.locate(path), "add `for_each: all_legs` (or the legs it is for)"))
        else:
            issues.append(Issue("unknown-placeholder", f"unknown placeholder {match.group()} in {entry.label}", entry.origin.locate(path), f"the only placeholder is {LEG_PLACEHOLDER}"))
    return issues


def _strings(value: Any, path: tuple[Any, ...]) -> Iterable[tuple[tuple[Any, ...], str]]:
    if isinstance(value, str):
        yield path, value
    elif isinstance(value, list):
        for index, item in enumerate(value):
            yield from _strings(item, path + (index,))
    elif isinstance(value, dict):
        for key, item in value.items():
            if isinstance(key, str):
                yield path + (key,), key
            yield from _strings(item, path + (key,))


# --------------------------------------------------------------------------- merging


def deep_merge(base: dict[str, Any], patch: Mapping[str, Any]) -> dict[str, Any]:
    """`base` with `patch` laid over it: mappings merge, other values replace, `null` deletes."""
    out = dict(base)
    for key, value in patch.items():
        if value is None:
            out.pop(key, None)
        elif isinstance(value, dict) and isinstance(out.get(key), dict):
            out[key] = deep_merge(out[key], value)
        else:
            out[key] = value
    return out


def match_names(pattern: str, names: Iterable[str]) -> list[str]:
    """Names equal to `pattern` or matching it as a glob (`*_leg`), in order."""
    return [name for name in names if name == pattern or fnmatchcase(name, pattern)]


def _find_parent(text: str, child: Path, where: Location, issues: list[Issue]) -> Path | None:
    if text.endswith((".yaml", ".yml")) or "/" in text:
        candidate = (child.parent / text).resolve()
        if candidate.is_file():
            return candidate
        issues.append(Issue("file-not-found", f"extends {text!r}, but there is no such file", where, "a path is relative to this file; a bare name is a built-in controller"))
        return None
    try:
        return configs.find_config(CONTROLLER_KIND, text).resolve()
    except QuadpipeError as exc:
        issue = exc.issues[0]
        issues.append(Issue(issue.code, f"extends {text!r}: {issue.message}", where, issue.hint))
        return None


def _own_groups(doc: YamlDocument, model: ControllerFile, inherited: Mapping[str, tuple[str, ...]], issues: list[Issue]) -> dict[str, tuple[str, ...]]:
    groups = dict(inherited)
    for name, members in model.groups.items():
        if name in roles.LEGS or name in BUILTIN_GROUPS:
            issues.append(Issue("name-clash", f"group {name!r} has the name of a built-in leg or group", doc.locate(("groups", name), key=True), "choose another name"))
            continue
        legs, unknown = resolve_legs(members, {})
        for bad in unknown:
            issues.append(Issue("unknown-leg", f"group {name!r} lists {bad!r}, which is not a leg", doc.locate(("groups", name)), did_you_mean(bad, roles.LEGS)))
        groups[name] = tuple(legs)
    return groups


def _own_parameters(doc: YamlDocument, model: ControllerFile) -> dict[str, ParameterEntry]:
    entries = {}
    for name, parameter in model.parameters.items():
        long_form = isinstance(doc.data["parameters"][name], dict)
        where = doc.locate(("parameters", name, "value") if long_form else ("parameters", name))
        entries[name] = ParameterEntry(parameter.value, parameter.description, where, doc.file)
    return entries


def _apply_remove(doc: YamlDocument, model: ControllerFile, elements: dict[str, ElementEntry], issues: list[Issue]) -> None:
    for index, pattern in enumerate(model.remove):
        matched = match_names(pattern, elements)
        if not matched:
            issues.append(_unknown_element(pattern, elements, doc.locate(("remove", index)), model.extends))
        for name in matched:
            del elements[name]


def _apply_override(doc: YamlDocument, model: ControllerFile, elements: dict[str, ElementEntry], issues: list[Issue]) -> None:
    for pattern, patch in model.override.items():
        matched = match_names(pattern, elements)
        if not matched:
            issues.append(_unknown_element(pattern, elements, doc.locate(("override", pattern), key=True), model.extends))
        for key in ("type", "name", "for_each"):
            if key in patch:
                issues.append(Issue("bad-override", f"an override cannot change `{key}`", doc.locate(("override", pattern, key), key=True), "remove the element and add a new one instead"))
                return
        for name in matched:
            entry = elements[name]
            layer = Layer(doc, ("override", pattern), patch)
            elements[name] = ElementEntry(name, deep_merge(entry.raw, patch), entry.origin.patched(layer), entry.template)


def _unknown_element(pattern: str, elements: Mapping[str, ElementEntry], where: Location, extends: str | None) -> Issue:
    if extends is None:
        return Issue("unknown-element", f"no element matches {pattern!r}", where, "`remove` and `override` change the controller named by `extends`, and this file extends none")
    return Issue("unknown-element", f"{extends!r} has no element matching {pattern!r}", where, did_you_mean(pattern, elements))


def _merge_file(path: Path, chain: tuple[Path, ...], issues: list[Issue]) -> MergedController | None:
    loaded = _read(path, issues)
    if loaded is None:
        return None
    doc, model = loaded
    parent = None
    if model.extends is not None:
        where = doc.locate(("extends",))
        parent_path = _find_parent(model.extends, path, where, issues)
        if parent_path is None:
            return None
        if parent_path in chain or parent_path == path.resolve():
            cycle = " -> ".join(p.stem for p in (*chain, path.resolve(), parent_path))
            issues.append(Issue("extends-cycle", f"controllers extend each other in a loop: {cycle}", where, "one of them must stop extending the other"))
            return None
        parent = _merge_file(parent_path, (*chain, path.resolve()), issues)
        if parent is None:
            return None
    groups = _own_groups(doc, model, parent.groups if parent else BUILTIN_GROUPS, issues)
    elements = dict(parent.elements) if parent else {}
    _apply_remove(doc, model, elements, issues)
    _apply_override(doc, model, elements, issues)
    own: dict[str, ElementEntry] = {}
    for element_path, raw in _raw_elements(doc, issues):
        for entry in _expand(doc, element_path, raw, groups, issues):
            if entry.name in own:
                issues.append(Issue("duplicate-name", f"two elements are named {entry.name!r}", entry.origin.locate(("name",)), "element names must be unique; rename one"))
                continue
            own[entry.name] = entry
            elements[entry.name] = entry
    return MergedController(
        name=model.name,
        description=model.description,
        sources=[doc.file, *(parent.sources if parent else [])],
        parameters={**(parent.parameters if parent else {}), **_own_parameters(doc, model)},
        groups=groups,
        elements=elements,
    )


def merge_controller(path: str | Path, issues: list[Issue]) -> MergedController | None:
    """Read a controller file and its `extends` chain into one validated structure.

    Args:
        path: the controller file.
        issues: receives every problem found.

    Returns:
        The merged controller, or None when problems prevent going further; elements carry
        their validated models. Any issue added means the structure is not to be trusted.
    """
    path = Path(path)
    before = len(issues)
    merged = _merge_file(path, (), issues)
    if merged is None:
        return None
    for entry in merged.elements.values():
        issues.extend(_placeholder_issues(entry))
        model = MODEL_OF_TYPE[entry.raw["type"]]
        try:
            entry.model = model.model_validate(entry.raw)
        except pydantic.ValidationError as exc:
            issues.extend(pydantic_issues(exc, model, entry.origin.locate, entry.label))
    return merged if len(issues) == before else None
