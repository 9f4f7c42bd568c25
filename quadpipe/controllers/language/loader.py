"""Reading controller files: YAML, structure, leg templates and `extends` merging.

`merge_controller(path)` reads a file and, recursively, the controllers it extends, and
returns a `MergedController`: raw element mappings and parameters with their templates
expanded (`for_each` -> one copy per leg with `{leg}` and `{pair}` replaced), parents'
elements merged by name (replaced, removed with `remove:`, changed with `override:`),
tunables, parameters and groups merged by name (a tunable inherits the range and the
description it leaves out), and every element validated against its pydantic model. Each
element keeps an `Origin` (`entries.py`) that locates any of its keys in the file (and the
override) it came from, so later checks can point at `file:line:col`. Templates are
expanded by `templates.py`.

Problems are collected as `Issue`s rather than raised, so that one run reports them all.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterable, Mapping
from dataclasses import replace
from fnmatch import fnmatchcase
from pathlib import Path
from typing import Any

import pydantic
from pydantic_core import ErrorDetails

from quadpipe.anatomy import roles
from quadpipe.controllers.language.entries import ElementEntry, Layer, MergedController, ParameterEntry
from quadpipe.controllers.language.schema import MODEL_OF_TYPE, SCHEMA_VERSION, ControllerFile
from quadpipe.controllers.language.templates import (
    BUILTIN_GROUPS,
    expand_element,
    parameter_copies,
    placeholder_issues,
    resolve_legs,
)
from quadpipe.core import configs
from quadpipe.core.errors import Issue, Location, QuadpipeError, did_you_mean
from quadpipe.core.textfiles import missing_file
from quadpipe.core.yamlio import YamlDocument, field_names_at, kind_of_value, load_yaml, plain_message
from quadpipe.core.yamlio import unwrap_annotation as unwrap_annotation  # re-exported

CONTROLLER_KIND = "controllers"
"""The configs folder holding built-in controllers."""


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
            issues.append(
                Issue(
                    "unknown-key",
                    f"{name!r} is not a valid key in {where}",
                    locate(loc, True),
                    did_you_mean(name, valid) if valid else None,
                )
            )
        elif err["type"] == "missing":
            issues.append(
                Issue("missing-key", f"required key {loc[-1]!r} is missing in {where}", locate(loc[:-1], False))
            )
        elif loc and loc[-1] == "[key]":
            message = plain_message(err)
            issues.append(
                Issue("invalid-value", f"a key in {_where_in(label, loc[:-2])}: {message}", locate(loc[:-1], True))
            )
        else:
            message = plain_message(err)
            issues.append(Issue("invalid-value", f"{_where_in(label, loc)}: {message}", locate(loc, False)))
    return issues


def _yaml_boolean_issue(
    err: ErrorDetails, loc: tuple[Any, ...], label: str, locate: Callable[[tuple[Any, ...], bool], Location]
) -> Issue:
    """YAML 1.1 reads yes/no/on/off/true/false as booleans; say so where a name was meant."""
    if loc and loc[-1] == "[key]":
        where, at = _where_in(label, loc[:-2]), locate(loc[:-1], True)
        subject = "a key here"
    else:
        where, at = _where_in(label, loc), locate(loc, False)
        subject = "this value"
    word = str(err["input"]).lower()
    return Issue(
        "invalid-value",
        f"{where}: YAML read {subject} as {word}, not as a name",
        at,
        'quote words like on, off, yes, no, true, false: "on"',
    )


def _where_in(label: str, loc: tuple[Any, ...]) -> str:
    dotted = ".".join(str(part) for part in loc)
    return f"`{dotted}` of {label}" if dotted else label


# --------------------------------------------------------------------------- reading


_UNQUOTED_PLACEHOLDER = re.compile(r"(:|-)\s+\{leg\}")


def _read_yaml(path: Path, issues: list[Issue]) -> YamlDocument | None:
    try:
        return load_yaml(path, "controller", ControllerFile)
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
        return Issue(
            issue.code,
            issue.message,
            issue.where,
            'a value starting with {leg} must be quoted: "{leg}_hip", or YAML reads it as a mapping',
        )
    return issue


def _read(path: Path, issues: list[Issue]) -> tuple[YamlDocument, ControllerFile] | None:
    """Parse a file and check its top-level keys (elements are checked after merging)."""
    doc = _read_yaml(path, issues)
    if doc is None:
        return None
    if not isinstance(doc.data, dict):
        issues.append(
            Issue(
                "invalid-value",
                "a controller file must be a mapping of keys (schema, name, elements, ...)",
                doc.locate(()),
            )
        )
        return None
    top = {key: value for key, value in doc.data.items() if key != "elements"}
    try:
        model = ControllerFile.model_validate(top)
    except pydantic.ValidationError as exc:
        issues.extend(pydantic_issues(exc, ControllerFile, lambda loc, key: doc.locate(loc, key=key), "the controller"))
        return None
    if model.schema_ != SCHEMA_VERSION:
        issues.append(
            Issue(
                "unsupported-schema",
                f"schema version {model.schema_} is not supported",
                doc.locate(("schema",)),
                f"this quadpipe reads `schema: {SCHEMA_VERSION}`",
            )
        )
        return None
    return doc, model


def _raw_elements(doc: YamlDocument, issues: list[Issue]) -> list[tuple[tuple[Any, ...], dict[str, Any]]]:
    """The file's element mappings with their paths; those without a usable type and name are reported."""
    elements = doc.data.get("elements", [])
    if elements is None:
        return []
    if not isinstance(elements, list):
        issues.append(
            Issue(
                "invalid-value",
                "`elements` must be a list (each item starting with '- type: ...')",
                doc.locate(("elements",)),
            )
        )
        return []
    found = []
    for index, raw in enumerate(elements):
        path = ("elements", index)
        if not isinstance(raw, dict):
            issues.append(
                Issue(
                    "invalid-value", f"element {index + 1} must be a mapping with `type` and `name`", doc.locate(path)
                )
            )
            continue
        kind = raw.get("type")
        if kind is None:
            issues.append(
                Issue(
                    "missing-key",
                    f"element {index + 1} has no `type`",
                    doc.locate(path),
                    f"valid: {', '.join(MODEL_OF_TYPE)}",
                )
            )
            continue
        if not isinstance(kind, str):
            issues.append(
                Issue(
                    "invalid-value",
                    f"element {index + 1}'s `type` must be a name, not {kind_of_value(kind)}",
                    doc.locate(path + ("type",)),
                    f"valid: {', '.join(MODEL_OF_TYPE)}",
                )
            )
            continue
        if kind not in MODEL_OF_TYPE:
            issues.append(
                Issue(
                    "unknown-element-type",
                    f"there is no element type {kind!r}",
                    doc.locate(path + ("type",)),
                    did_you_mean(str(kind), MODEL_OF_TYPE),
                )
            )
            continue
        if not isinstance(raw.get("name"), str):
            issues.append(
                Issue(
                    "missing-key",
                    f"element {index + 1} ({kind}) needs a `name` (text)",
                    doc.locate(path + ("name",) if "name" in raw else path),
                )
            )
            continue
        found.append((path, raw))
    return found


# --------------------------------------------------------------------------- templates


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
        issue = missing_file(
            candidate,
            "controller",
            name=text,
            where=where,
            suffixes=(".yaml", ".yml"),
            hint="a path is relative to this file; a bare name is a built-in controller",
        )
        problem = "which is a folder, not a file" if issue.code == "is-a-folder" else "but there is no such file"
        issues.append(replace(issue, message=f"extends {text!r}, {problem}"))
        return None
    try:
        return configs.find_config(CONTROLLER_KIND, text).resolve()
    except QuadpipeError as exc:
        issue = exc.issues[0]
        issues.append(Issue(issue.code, f"extends {text!r}: {issue.message}", where, issue.hint))
        return None


def _own_groups(
    doc: YamlDocument, model: ControllerFile, inherited: Mapping[str, tuple[str, ...]], issues: list[Issue]
) -> dict[str, tuple[str, ...]]:
    groups = dict(inherited)
    for name, members in model.groups.items():
        if name in roles.LEGS or name in BUILTIN_GROUPS:
            issues.append(
                Issue(
                    "name-clash",
                    f"group {name!r} has the name of a built-in leg or group",
                    doc.locate(("groups", name), key=True),
                    "choose another name",
                )
            )
            continue
        legs, unknown = resolve_legs(members, {})
        for bad in unknown:
            issues.append(
                Issue(
                    "unknown-leg",
                    f"group {name!r} lists {bad!r}, which is not a leg",
                    doc.locate(("groups", name)),
                    did_you_mean(bad, roles.LEGS),
                )
            )
        groups[name] = tuple(legs)
    return groups


def _own_parameters(
    doc: YamlDocument,
    model: ControllerFile,
    groups: Mapping[str, tuple[str, ...]],
    inherited: Mapping[str, ParameterEntry],
    issues: list[Issue],
) -> dict[str, ParameterEntry]:
    """The file's tunables and parameters, templates expanded, tunables completed from `inherited`."""
    entries: dict[str, ParameterEntry] = {}
    for section, written in (("tunables", model.tunables), ("parameters", model.parameters)):
        for key, parameter in written.items():
            for name, entry in parameter_copies(doc, section, key, parameter, groups, issues):
                if name in entries:
                    issues.append(
                        Issue(
                            "duplicate-name",
                            f"two tunables or parameters are named {name!r}",
                            entry.where,
                            "names must be unique across `tunables` and `parameters`; rename one",
                        )
                    )
                    continue
                completed = _completed(name, entry, inherited.get(name), issues) if entry.tunable else entry
                entries[name] = replace(completed, replaces=inherited.get(name))
    return entries


def _completed(name: str, entry: ParameterEntry, parent: ParameterEntry | None, issues: list[Issue]) -> ParameterEntry:
    """A tunable with the description and range it leaves out taken from the parent's tunable of that name."""
    inherited = parent if parent is not None and parent.tunable else None
    description = entry.description or (inherited.description if inherited else "")
    low = entry.low or (inherited.low if inherited else None)
    high = entry.high or (inherited.high if inherited else None)
    missing = [key for key, given in (("description", description), ("min", low), ("max", high)) if not given]
    if missing:
        listed = ", ".join(f"`{key}`" for key in missing)
        issues.append(
            Issue(
                "missing-key",
                f"tunable {name!r} needs {listed}",
                entry.where,
                "a tunable is a knob: say what it changes and its range, e.g. `{value: 0.3, description: ..., min: 0, max: 1}`",
            )
        )
    return ParameterEntry(entry.value, description, entry.where, entry.file, True, low, high)


def _apply_remove(
    doc: YamlDocument, model: ControllerFile, elements: dict[str, ElementEntry], issues: list[Issue]
) -> None:
    for index, pattern in enumerate(model.remove):
        matched = match_names(pattern, elements)
        if not matched:
            issues.append(_unknown_element(pattern, elements, doc.locate(("remove", index)), model.extends))
        for name in matched:
            del elements[name]


def _apply_override(
    doc: YamlDocument, model: ControllerFile, elements: dict[str, ElementEntry], issues: list[Issue]
) -> None:
    for pattern, patch in model.override.items():
        matched = match_names(pattern, elements)
        if not matched:
            issues.append(
                _unknown_element(pattern, elements, doc.locate(("override", pattern), key=True), model.extends)
            )
        for key in ("type", "name", "for_each"):
            if key in patch:
                issues.append(
                    Issue(
                        "bad-override",
                        f"an override cannot change `{key}`",
                        doc.locate(("override", pattern, key), key=True),
                        "remove the element and add a new one instead",
                    )
                )
                return
        for name in matched:
            entry = elements[name]
            layer = Layer(doc, ("override", pattern), patch)
            elements[name] = ElementEntry(
                name, deep_merge(entry.raw, patch), entry.origin.patched(layer), entry.template
            )


def _unknown_element(pattern: str, elements: Mapping[str, ElementEntry], where: Location, extends: str | None) -> Issue:
    if extends is None:
        return Issue(
            "unknown-element",
            f"no element matches {pattern!r}",
            where,
            "`remove` and `override` change the controller named by `extends`, and this file extends none",
        )
    return Issue(
        "unknown-element", f"{extends!r} has no element matching {pattern!r}", where, did_you_mean(pattern, elements)
    )


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
            issues.append(
                Issue(
                    "extends-cycle",
                    f"controllers extend each other in a loop: {cycle}",
                    where,
                    "one of them must stop extending the other",
                )
            )
            return None
        parent = _merge_file(parent_path, (*chain, path.resolve()), issues)
        if parent is None:
            return None
    groups = _own_groups(doc, model, parent.groups if parent else BUILTIN_GROUPS, issues)
    inherited = parent.parameters if parent else {}
    elements = dict(parent.elements) if parent else {}
    _apply_remove(doc, model, elements, issues)
    _apply_override(doc, model, elements, issues)
    own: dict[str, ElementEntry] = {}
    for element_path, raw in _raw_elements(doc, issues):
        for entry in expand_element(doc, element_path, raw, groups, issues):
            if entry.name in own:
                issues.append(
                    Issue(
                        "duplicate-name",
                        f"two elements are named {entry.name!r}",
                        entry.origin.locate(("name",)),
                        "element names must be unique; rename one",
                    )
                )
                continue
            own[entry.name] = entry
            elements[entry.name] = entry
    return MergedController(
        name=model.name,
        description=model.description,
        sources=[doc.file, *(parent.sources if parent else [])],
        parameters={**inherited, **_own_parameters(doc, model, groups, inherited, issues)},
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
        issues.extend(placeholder_issues(entry))
        model = MODEL_OF_TYPE[entry.raw["type"]]
        try:
            entry.model = model.model_validate(entry.raw)
        except pydantic.ValidationError as exc:
            issues.extend(pydantic_issues(exc, model, entry.origin.locate, entry.label))
    return merged if len(issues) == before else None
