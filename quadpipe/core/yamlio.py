"""YAML that remembers where every value came from.

`load_yaml` returns a `YamlDocument`: the plain data (dicts, lists, scalars) plus the line and
column of every key and value, so that schema errors point at `file:line:col`. Duplicate keys
are errors (PyYAML silently keeps the last one), and so are documents that would grow without
bound (nesting, aliases: see `quadpipe.core.limits`).
"""

from __future__ import annotations

import difflib
import math
import types
import typing
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any, TypeVar

import pydantic
import yaml
from pydantic import AfterValidator
from pydantic_core import ErrorDetails

from quadpipe.core import limits
from quadpipe.core.errors import Issue, Location, QuadpipeError, did_you_mean
from quadpipe.core.textfiles import read_text

BaseModelT = TypeVar("BaseModelT", bound=pydantic.BaseModel)

PathKey = tuple[Any, ...]

JSON_SCHEMA_DIALECT = "https://json-schema.org/draft/2020-12/schema"
"""The JSON Schema version of the schemas generated from the file formats' models."""

_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)
"""libyaml's loader when PyYAML was built with it (about 10x faster), else the pure-Python one."""


@dataclass
class YamlDocument:
    """Parsed YAML data and the positions of its parts, keyed by path tuples.

    A path is the sequence of mapping keys and list indices from the root, as in
    pydantic's error `loc`: `("springs", 0, "strength")`.
    """

    data: Any
    file: str
    key_positions: dict[PathKey, tuple[int, int]] = field(default_factory=dict)
    value_positions: dict[PathKey, tuple[int, int]] = field(default_factory=dict)
    empty: bool = False
    """Whether the text held no YAML node (nothing, or only comments): `data` is then `{}`."""

    def locate(self, path: Iterable[Any], *, key: bool = False) -> Location:
        """Return the location of `path`, or of its nearest ancestor that has one.

        Args:
            path: keys and indices from the root.
            key: point at the key (for "unknown key") rather than at the value.
        """
        path = tuple(path)
        while True:
            table = self.key_positions if key else self.value_positions
            if path in table:
                line, column = table[path]
                return Location(self.file, line, column)
            if key and path in self.value_positions:
                line, column = self.value_positions[path]
                return Location(self.file, line, column)
            if not path:
                return Location(self.file)
            path = path[:-1]


def _mark(node: yaml.Node | yaml.Event) -> tuple[int, int]:
    return node.start_mark.line + 1, node.start_mark.column + 1


def _construct(node: yaml.Node, path: PathKey, doc: YamlDocument, loader: Any) -> Any:
    doc.value_positions[path] = _mark(node)
    if isinstance(node, yaml.MappingNode):
        loader.flatten_mapping(node)
        result: dict[Any, Any] = {}
        for key_node, value_node in node.value:
            key = loader.construct_object(key_node, deep=True)
            if key in result:
                line, column = _mark(key_node)
                raise QuadpipeError.single(
                    "duplicate-key",
                    f"key {key!r} appears twice in the same mapping",
                    file=doc.file,
                    line=line,
                    column=column,
                    hint="remove one of them; YAML would silently keep only the last",
                )
            doc.key_positions[path + (key,)] = _mark(key_node)
            result[key] = _construct(value_node, path + (key,), doc, loader)
        return result
    if isinstance(node, yaml.SequenceNode):
        return [_construct(item, path + (i,), doc, loader) for i, item in enumerate(node.value)]
    return loader.construct_object(node, deep=True)


def parse_yaml(text: str, file: str = "<input>") -> YamlDocument:
    """Parse YAML text into a `YamlDocument`; syntax errors become a located `QuadpipeError`.

    Parsing uses libyaml when available; a syntax error is measured and parsed again with
    PyYAML's own loader, whose messages say more ("expected <block end>, but found
    '<scalar>'"). Before anything is built, the parser's events are measured (`_measure`): too
    deep a nesting, too many aliases, or aliases that would expand past `MAX_YAML_NODES` are
    refused.
    """
    try:
        _measure(text, file, _LOADER)
        return _parse(text, file, _LOADER)
    except yaml.reader.ReaderError:
        raise _bad_character(text, file) from None
    except yaml.MarkedYAMLError as first:
        exc = first
        if _LOADER is not yaml.SafeLoader:
            try:
                # Measured again: some libyaml builds refuse a nesting past 1000 levels as a
                # syntax error, and PyYAML's own composer would recurse through all of them.
                _measure(text, file, yaml.SafeLoader)
                _parse(text, file, yaml.SafeLoader)
            except yaml.MarkedYAMLError as detailed:
                exc = detailed
        mark = exc.problem_mark or exc.context_mark
        raise QuadpipeError.single(
            "yaml-syntax",
            f"{exc.problem or 'invalid YAML'}" + (f" ({exc.context})" if exc.context else ""),
            file=file,
            line=mark.line + 1 if mark else None,
            column=mark.column + 1 if mark else None,
            hint="check indentation, colons and quotes around this place",
        ) from None


def _measure(text: str, file: str, loader_class: Any) -> None:
    """Refuse a document too deep, with too many aliases, or too big once its aliases expand.

    Works on the parser's events, before any node is composed or copied: the expanded size is
    counted, not built (an alias adds the size of what its anchor named).

    Raises:
        QuadpipeError: `limit-exceeded`, or `yaml-recursive-alias` for an alias inside the
            very collection it names.
        yaml.YAMLError: a syntax error.
    """
    loader = loader_class(text)
    anchored: dict[str, int] = {}
    open_collections: list[tuple[str | None, int]] = []
    expanded = aliases = 0
    try:
        while loader.check_event():
            event = loader.get_event()
            where = Location(file, *_mark(event))
            if isinstance(event, yaml.AliasEvent):
                aliases += 1
                if aliases > limits.MAX_YAML_ALIASES.value:
                    raise limits.MAX_YAML_ALIASES.exceeded(where=where)
                if any(anchor == event.anchor for anchor, _ in open_collections):
                    raise QuadpipeError.single(
                        "yaml-recursive-alias",
                        f"alias *{event.anchor} is inside the collection &{event.anchor} names: it would never end",
                        where=where,
                        hint="an alias can only repeat a collection that is already closed",
                    )
                expanded += anchored.get(event.anchor, 1)
            elif isinstance(event, (yaml.ScalarEvent, yaml.CollectionStartEvent)):
                expanded += 1
                if isinstance(event, yaml.CollectionStartEvent):
                    open_collections.append((event.anchor, expanded - 1))
                    limits.MAX_YAML_DEPTH.check(len(open_collections), where=where)
                elif event.anchor is not None:
                    anchored[event.anchor] = 1
            elif isinstance(event, yaml.CollectionEndEvent):
                anchor, start = open_collections.pop()
                if anchor is not None:
                    anchored[anchor] = expanded - start
            if expanded > limits.MAX_YAML_NODES.value:
                raise limits.MAX_YAML_NODES.exceeded(where=where)
    finally:
        loader.dispose()


def _bad_character(text: str, file: str) -> QuadpipeError:
    """The located error for a character YAML does not allow (a control character)."""
    match = yaml.reader.Reader.NON_PRINTABLE.search(text)
    offset = match.start() if match else 0
    line = text.count("\n", 0, offset) + 1
    column = offset - (text.rfind("\n", 0, offset) + 1) + 1
    character = f"U+{ord(text[offset]):04X}" if match else "a control character"
    return QuadpipeError.single(
        "yaml-bad-character",
        f"character {character} is not allowed in YAML text",
        file=file,
        line=line,
        column=column,
        hint="remove it: is the file binary, or was it damaged?",
    )


def _parse(text: str, file: str, loader_class: Any) -> YamlDocument:
    loader = loader_class(text)
    try:
        root = loader.get_single_node()
        doc = YamlDocument(data=None, file=file, empty=root is None)
        if root is None:  # empty, or only comments (a file cut short): errors point where it ends
            doc.value_positions[()] = (max(1, len(text.splitlines())), 1)
        doc.data = {} if root is None else _construct(root, (), doc, loader)
        return doc
    finally:
        loader.dispose()


def load_yaml(path: str | Path, what: str = "", model: type[pydantic.BaseModel] | None = None) -> YamlDocument:
    """Read and parse a YAML file; a missing, unreadable, too big or non-UTF-8 file is a `QuadpipeError`.

    `what` names the kind of file in messages (`batch plan`). With the `model` of its format,
    a file holding nothing (empty, or only comments) is an `empty-file` error whose hint names
    the keys it needs, rather than one error per missing key.
    """
    text = read_text(path, limits.MAX_YAML_FILE_BYTES, what)
    doc = parse_yaml(text, str(path))
    if model is not None and doc.empty:
        raise QuadpipeError([_empty_file(doc.file, text, what, model)])
    return doc


def _empty_file(file: str, text: str, what: str, model: type[pydantic.BaseModel]) -> Issue:
    """The issue of a file with no data, and what a file of its `model` holds."""
    fields = model.model_fields
    required = [field.alias or name for name, field in fields.items() if field.is_required()]
    keys = required or [field.alias or name for name, field in fields.items()]
    quoted = [f"`{key}:`" for key in keys]
    listed = ", ".join(quoted[:-1]) + (" and " if required else " or ") + quoted[-1] if len(quoted) > 1 else quoted[0]
    kind = f"{what} file" if what else "file"
    article = "an" if kind[0] in "aeiou" else "a"
    holds = "needs at least" if required else "holds"
    return Issue(
        "empty-file",
        f"the {kind} is empty" if not text.strip() else f"the {kind} holds only comments",
        Location(file, 1, 1),
        f"{article} {kind} {holds} {listed}",
    )


def _not_blank(value: str) -> str:
    if not value.strip():
        raise ValueError("a name cannot be empty")
    return value


Name = Annotated[str, AfterValidator(_not_blank)]
"""A name in a file (a controller, element, parameter, scene or animal): text, not empty or blank."""


def validate_document(model: type[BaseModelT], doc: YamlDocument) -> BaseModelT:
    """Validate a document against a pydantic model, turning errors into located issues.

    Unknown keys get a "did you mean" hint built from the model's field names.
    """
    try:
        return model.model_validate(doc.data)
    except pydantic.ValidationError as exc:
        raise QuadpipeError(located_issues(exc, model, doc)) from None


def located_issues(
    exc: pydantic.ValidationError, model: type[pydantic.BaseModel], doc: YamlDocument, prefix: PathKey = ()
) -> list[Issue]:
    """Pydantic errors of validating `model` as located issues (unknown-key, missing-key, invalid-value).

    Args:
        exc: the validation error.
        model: the model that was validated (for the valid key names).
        doc: the document, to locate the errors.
        prefix: path in the document of the data that was validated (a part of it).
    """
    return [_issue_from_pydantic(err, model, doc, prefix) for err in without_missing_explained_by_typos(exc.errors())]


def without_missing_explained_by_typos(errors: list[ErrorDetails]) -> list[ErrorDetails]:
    """Drop "missing key X" when a misspelt key beside it is close to X: one typo, one message."""
    unknown = {tuple(e["loc"]) for e in errors if e["type"] == "extra_forbidden"}

    def explained(err: ErrorDetails) -> bool:
        loc = tuple(err["loc"])
        siblings = [str(u[-1]) for u in unknown if u[:-1] == loc[:-1]]
        return err["type"] == "missing" and bool(difflib.get_close_matches(str(loc[-1]), siblings, n=1, cutoff=0.6))

    return [e for e in errors if not explained(e)]


def dotted(path: Iterable[Any]) -> str:
    """A path for messages: `throws.0.speed`."""
    return ".".join(str(part) for part in path)


def _issue_from_pydantic(
    err: ErrorDetails, model: type[pydantic.BaseModel], doc: YamlDocument, prefix: PathKey
) -> Issue:
    loc = tuple(err["loc"])
    path = prefix + loc
    kind = err["type"]
    if kind == "extra_forbidden":
        name = str(loc[-1])
        valid = field_names_at(model, loc[:-1])
        return Issue(
            "unknown-key",
            f"{name!r} is not a valid key here",
            doc.locate(path, key=True),
            did_you_mean(name, valid) if valid else None,
        )
    if kind == "missing":
        where = dotted(path[:-1]) or "the file's top level"
        return Issue("missing-key", f"required key {loc[-1]!r} is missing in {where}", doc.locate(path[:-1]))
    message = plain_message(err)
    return Issue("invalid-value", f"{dotted(path)}: {message}" if path else message, doc.locate(path))


_EXPECTED_KIND: dict[str, str] = {
    "float_type": "a number",
    "float_parsing": "a number",
    "int_type": "a whole number",
    "int_parsing": "a whole number",
    "int_from_float": "a whole number",
    "finite_number": "a finite number",
    "string_type": "text",
    "dict_type": "a mapping of keys (`key: value`)",
    "list_type": "a list",
    "tuple_type": "a list",
    "bool_type": "true or false",
    "bool_parsing": "true or false",
    "model_type": "a mapping of keys (`key: value`)",
    "model_attributes_type": "a mapping of keys (`key: value`)",
}
"""Pydantic type errors -> what the value should have been, in the words of a YAML file."""

_BOUNDS: dict[str, str] = {"greater_than": "more than", "greater_than_equal": "at least", "less_than": "less than"}
_BOUNDS |= {"less_than_equal": "at most"}
"""Pydantic bound errors -> how the bound reads in a message (its number is in the error's context)."""


def plain_message(err: ErrorDetails) -> str:
    """A pydantic error in plain words (`must be a number, not the text 'abc'`), without its wording
    ("Input should be a valid number, unable to parse string as a number") or its type names."""
    kind, ctx, given = err["type"], err.get("ctx") or {}, err.get("input")
    if isinstance(given, float) and not math.isfinite(given):
        return f"{given} is not a finite number"
    if kind in _EXPECTED_KIND:
        return f"must be {_EXPECTED_KIND[kind]}, not {described_value(given)}"
    if kind in _BOUNDS:
        bound = next(iter(ctx.values()), "?")
        shown = f"{bound:g}" if isinstance(bound, float) else bound
        return f"must be {_BOUNDS[kind]} {shown}, not {given}"
    if kind in ("string_too_short", "too_short"):
        if ctx.get("min_length") == 1:
            return "cannot be empty"
        return f"needs at least {ctx.get('min_length')} {'characters' if kind == 'string_too_short' else 'items'}"
    if kind in ("string_too_long", "too_long"):
        return f"takes at most {ctx.get('max_length')} {'characters' if kind == 'string_too_long' else 'items'}"
    if kind in ("literal_error", "enum"):
        return f"must be {ctx.get('expected', 'one of the listed values')}, not {described_value(given)}"
    return err["msg"].removeprefix("Value error, ").removeprefix("Assertion failed, ")


def described_value(value: Any) -> str:
    """A value as a message names it: `the text 'abc'`, `a mapping`, `nothing (null)`."""
    if value is None:
        return "nothing (null)"
    if isinstance(value, str):
        return f"the text {value!r}" if len(value) <= 40 else "a text"
    if isinstance(value, (dict, list, bool)):
        return kind_of_value(value)
    return f"the number {value}" if isinstance(value, (int, float)) else type(value).__name__


# --------------------------------------------------------------------------- field names


def unwrap_annotation(annotation: Any) -> list[Any]:
    """The concrete types inside Annotated / Optional / Union annotations."""
    if hasattr(annotation, "__metadata__"):
        return unwrap_annotation(typing.get_args(annotation)[0])
    if typing.get_origin(annotation) in (typing.Union, types.UnionType):
        return [t for arm in typing.get_args(annotation) for t in unwrap_annotation(arm)]
    return [annotation]


def _step(annotation: Any, part: Any) -> Any:
    for candidate in unwrap_annotation(annotation):
        if isinstance(candidate, type) and issubclass(candidate, pydantic.BaseModel):
            for name, info in candidate.model_fields.items():
                if part in (name, info.alias):
                    return info.annotation
        elif typing.get_origin(candidate) in (list, dict):
            return typing.get_args(candidate)[-1]
    return None


def field_names_at(model: type[pydantic.BaseModel], loc: tuple[Any, ...]) -> list[str]:
    """Key names valid in the mapping at `loc` inside `model`, for "did you mean" hints."""
    annotation: Any = model
    for part in loc:
        annotation = _step(annotation, part)
        if annotation is None:
            return []
    for candidate in unwrap_annotation(annotation):
        if isinstance(candidate, type) and issubclass(candidate, pydantic.BaseModel):
            return [info.alias or name for name, info in candidate.model_fields.items()]
    return []


def kind_of_value(value: Any) -> str:
    """What a YAML value is, for a message: `a mapping`, `a list`, `a number`."""
    if isinstance(value, dict):
        return "a mapping"
    if isinstance(value, list):
        return "a list"
    return "a yes/no value" if isinstance(value, bool) else "a number"
