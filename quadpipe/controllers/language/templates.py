"""Templates: `for_each` copies of elements and parameters, one per leg.

In a template, `{leg}` becomes the leg (`lf`, `rf`, `lh`, `rh`) and `{pair}` its pair
(`front` or `hind`) in every text, keys included; the name must hold `{leg}` so that the
copies differ. Placeholders left where there is no `for_each`, and unknown ones, are
reported.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterable, Mapping
from typing import Any

from quadpipe.anatomy import roles
from quadpipe.controllers.language.entries import Bound, ElementEntry, Layer, Origin, ParameterEntry
from quadpipe.controllers.language.schema import LEG_PLACEHOLDER, PAIR_PLACEHOLDER, Parameter, Tunable
from quadpipe.core.errors import Issue, Location, did_you_mean
from quadpipe.core.yamlio import YamlDocument

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

PLACEHOLDERS: tuple[str, ...] = (LEG_PLACEHOLDER, PAIR_PLACEHOLDER)
"""The placeholders `for_each` replaces."""

PAIRS: dict[bool, str] = {True: "front", False: "hind"}
"""What `{pair}` becomes, by "is a front leg"."""


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
    """`value` with `{leg}` and `{pair}` replaced in every text; changed keys are recorded in `key_map`."""
    if isinstance(value, str):
        return value.replace(LEG_PLACEHOLDER, leg).replace(PAIR_PLACEHOLDER, PAIRS[leg.endswith("f")])
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


def template_legs(
    for_each: Any,
    name: str,
    what: str,
    where: Callable[[str], Location],
    groups: Mapping[str, tuple[str, ...]],
    issues: list[Issue],
) -> list[str]:
    """The legs a `for_each` template is copied for; none when it cannot be (reported).

    Args:
        for_each: the `for_each` value as written.
        name: the template's name, which must hold `{leg}` so that the copies differ.
        what: `element` or `parameter`, for messages.
        where: `for_each` or `name` -> where it is written.
        groups: the leg groups the controller knows.
        issues: receives the problems.
    """
    items = for_each if isinstance(for_each, list) else [for_each]
    if not all(isinstance(item, str) for item in items):
        issues.append(
            Issue("invalid-value", "`for_each` lists legs (lf, rf, lh, rh) or group names", where("for_each"))
        )
        return []
    legs, unknown = resolve_legs(items, groups)
    for bad in unknown:
        issues.append(
            Issue(
                "unknown-leg",
                f"{bad!r} is neither a leg nor a group",
                where("for_each"),
                did_you_mean(bad, [*roles.LEGS, *groups]),
            )
        )
    if LEG_PLACEHOLDER not in name:
        issues.append(
            Issue(
                "template-name",
                f"{what} {name!r} has `for_each` but its name lacks {LEG_PLACEHOLDER}",
                where("name"),
                f'each copy needs its own name, e.g. "{LEG_PLACEHOLDER}_{name}"',
            )
        )
        return []
    return legs


def expand_element(
    doc: YamlDocument,
    path: tuple[Any, ...],
    raw: dict[str, Any],
    groups: Mapping[str, tuple[str, ...]],
    issues: list[Issue],
) -> list[ElementEntry]:
    """One entry per leg for a `for_each` element, or the element itself."""
    for_each = raw.get("for_each")
    if for_each is None:
        return [ElementEntry(raw["name"], raw, Origin((Layer(doc, path, raw),)))]
    legs = template_legs(for_each, raw["name"], "element", lambda key: doc.locate(path + (key,)), groups, issues)
    entries = []
    body = {key: value for key, value in raw.items() if key != "for_each"}
    for leg in legs:
        key_map: dict[Any, Any] = {}
        copy = _substitute(body, leg, key_map)
        entries.append(ElementEntry(copy["name"], copy, Origin((Layer(doc, path, copy, key_map),)), raw["name"]))
    return entries


def placeholder_issues(entry: ElementEntry) -> list[Issue]:
    """Placeholders left in an element: `{leg}` without `for_each`, or unknown ones."""
    issues = []
    for path, text in _strings(entry.raw, ()):
        match = PLACEHOLDER.search(text)
        if match is None:
            continue
        issues.append(_placeholder_issue(match.group(), entry.label, entry.origin.locate(path)))
    return issues


def _placeholder_issue(placeholder: str, label: str, where: Location) -> Issue:
    """A placeholder left in a text: a known one outside `for_each`, or an unknown one."""
    if placeholder in PLACEHOLDERS:
        return Issue(
            "unknown-placeholder",
            f"{placeholder} in {label}, which has no `for_each`",
            where,
            "add `for_each: all_legs` (or the legs it is for)",
        )
    return Issue(
        "unknown-placeholder",
        f"unknown placeholder {placeholder} in {label}",
        where,
        f"the placeholders are {' and '.join(PLACEHOLDERS)}",
    )


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


def parameter_copies(
    doc: YamlDocument,
    section: str,
    key: str,
    parameter: Parameter,
    groups: Mapping[str, tuple[str, ...]],
    issues: list[Issue],
) -> list[tuple[str, ParameterEntry]]:
    """(name, entry) of a parameter or a tunable as written: one per leg of its `for_each`, or itself.

    Args:
        doc: the file.
        section: `tunables` or `parameters`.
        key: its name as written.
        parameter: its validated model.
        groups: the leg groups the controller knows.
        issues: receives the problems.
    """
    path, what = (section, key), section.removesuffix("s")
    entry = _parameter_entry(doc, path, parameter)
    if parameter.for_each is None:
        for text in (key, *(text for _, text in _strings(parameter.value, ()))):
            if (found := PLACEHOLDER.search(text)) is not None:
                issues.append(_placeholder_issue(found.group(), f"{what} {key!r}", doc.locate(path, key=True)))
        return [(key, entry)]

    def where(part: str) -> Location:
        return doc.locate(path + ("for_each",)) if part == "for_each" else doc.locate(path, key=True)

    copies = []
    for leg in template_legs(parameter.for_each, key, what, where, groups, issues):
        value, description = _substitute(parameter.value, leg, {}), _substitute(parameter.description, leg, {})
        copies.append(
            (
                _substitute(key, leg, {}),
                ParameterEntry(value, description, entry.where, entry.file, entry.tunable, entry.low, entry.high),
            )
        )
    return copies


def _parameter_entry(doc: YamlDocument, path: tuple[str, str], parameter: Parameter) -> ParameterEntry:
    """The entry of a parameter or a tunable as written, located at its value (and range)."""
    long_form = isinstance(doc.data[path[0]][path[1]], dict)
    where = doc.locate(path + ("value",) if long_form else path)
    if not isinstance(parameter, Tunable):
        return ParameterEntry(parameter.value, parameter.description, where, doc.file)
    low, high = (
        Bound(value, doc.locate(path + (end,))) if value is not None else None
        for end, value in (("min", parameter.min), ("max", parameter.max))
    )
    return ParameterEntry(parameter.value, parameter.description, where, doc.file, True, low, high)
