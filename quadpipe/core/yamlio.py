"""YAML that remembers where every value came from.

`load_yaml` returns a `YamlDocument`: the plain data (dicts, lists, scalars) plus the line and
column of every key and value, so that schema errors point at `file:line:col`. Duplicate keys
are errors (PyYAML silently keeps the last one).
"""

from __future__ import annotations

import difflib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable, TypeVar

import pydantic
import yaml

from quadpipe.core.errors import Issue, Location, QuadpipeError, did_you_mean

BaseModelT = TypeVar("BaseModelT", bound=pydantic.BaseModel)

PathKey = tuple[Any, ...]

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


def _mark(node: yaml.Node) -> tuple[int, int]:
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

    Parsing uses libyaml when available; a syntax error is parsed again with PyYAML's own
    loader, whose messages say more ("expected <block end>, but found '<scalar>'").
    """
    try:
        return _parse(text, file, _LOADER)
    except yaml.MarkedYAMLError:
        if _LOADER is not yaml.SafeLoader:
            try:
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


def _parse(text: str, file: str, loader_class: Any) -> YamlDocument:
    loader = loader_class(text)
    try:
        root = loader.get_single_node()
        doc = YamlDocument(data=None, file=file)
        doc.data = {} if root is None else _construct(root, (), doc, loader)
        return doc
    finally:
        loader.dispose()


def load_yaml(path: str | Path) -> YamlDocument:
    """Read and parse a YAML file; a missing or unreadable file is a `QuadpipeError`."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise QuadpipeError.single(
            "file-unreadable", f"cannot read {path}: {exc.strerror}", file=str(path)
        ) from None
    return parse_yaml(text, str(path))


def validate_document(model: type[BaseModelT], doc: YamlDocument) -> BaseModelT:
    """Validate a document against a pydantic model, turning errors into located issues.

    Unknown keys get a "did you mean" hint built from the model's field names.
    """
    try:
        return model.model_validate(doc.data)
    except pydantic.ValidationError as exc:
        errors = without_missing_explained_by_typos(exc.errors())
        raise QuadpipeError([_issue_from_pydantic(err, model, doc) for err in errors]) from None


def without_missing_explained_by_typos(errors: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Drop "missing key X" when a misspelt key beside it is close to X: one typo, one message."""
    unknown = {tuple(e["loc"]) for e in errors if e["type"] == "extra_forbidden"}

    def explained(err: dict[str, Any]) -> bool:
        loc = tuple(err["loc"])
        siblings = [str(u[-1]) for u in unknown if u[:-1] == loc[:-1]]
        return err["type"] == "missing" and bool(difflib.get_close_matches(str(loc[-1]), siblings, n=1, cutoff=0.6))

    return [e for e in errors if not explained(e)]


def _fields_at(model: type[pydantic.BaseModel], loc: tuple[Any, ...]) -> list[str]:
    """Field names of the (nested) model found by following `loc`, for "did you mean" hints."""
    current: Any = model
    for part in loc:
        if isinstance(part, int) or current is None:
            continue
        field_info = getattr(current, "model_fields", {}).get(part)
        if field_info is None:
            return []
        annotation = field_info.annotation
        current = _model_in(annotation)
    return list(getattr(current, "model_fields", {}) or [])


def _model_in(annotation: Any) -> Any:
    """The first pydantic model class inside a type annotation (list[X], dict[str, X], X | None)."""
    if isinstance(annotation, type) and issubclass(annotation, pydantic.BaseModel):
        return annotation
    for arg in getattr(annotation, "__args__", ()) or ():
        found = _model_in(arg)
        if found is not None:
            return found
    return None


def _issue_from_pydantic(err: dict[str, Any], model: type[pydantic.BaseModel], doc: YamlDocument) -> Issue:
    loc = tuple(err["loc"])
    kind = err["type"]
    if kind == "extra_forbidden":
        name = str(loc[-1])
        valid = _fields_at(model, loc[:-1])
        return Issue(
            "unknown-key",
            f"{name!r} is not a valid key here",
            doc.locate(loc, key=True),
            did_you_mean(name, valid) if valid else None,
        )
    if kind == "missing":
        where = ".".join(str(p) for p in loc[:-1]) or "the top level"
        return Issue("missing-key", f"required key {loc[-1]!r} is missing in {where}", doc.locate(loc[:-1]))
    dotted = ".".join(str(p) for p in loc)
    message = err["msg"].removeprefix("Value error, ")
    return Issue("invalid-value", f"{dotted}: {message}" if dotted else message, doc.locate(loc))
