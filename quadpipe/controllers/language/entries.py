"""What reading a controller produces: its elements and parameters, and where each key was written.

An element keeps an `Origin`, the layers of YAML its keys come from (the element as written,
then each `override:` and state patch laid over it), so that any later check can point at the
`file:line:col` where the offending key was written.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

from quadpipe.core.errors import Location
from quadpipe.core.yamlio import YamlDocument


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
            if (
                isinstance(node, dict)
                and part in node
                or isinstance(node, list)
                and isinstance(part, int)
                and 0 <= part < len(node)
            ):
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
        layers = self.layers[self._last_replacing(path) :]
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

    def patched(self, layer: Layer) -> Origin:
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
class Bound:
    """One end of a tunable's range, as written, and where."""

    value: Any
    where: Location


@dataclass(frozen=True)
class ParameterEntry:
    """A parameter or a tunable as written: its value, description and position.

    Attributes:
        tunable: whether it comes from `tunables:`; then `low` and `high` are its range
            (None only where a file left one out and no parent gave it, which is reported).
        replaces: the entry of that name in the controller this one extends, if any: its
            value is what the parent's formulas and elements were written for.
    """

    value: Any
    description: str
    where: Location
    file: str
    tunable: bool = False
    low: Bound | None = None
    high: Bound | None = None
    replaces: ParameterEntry | None = None

    @property
    def first(self) -> ParameterEntry:
        """The entry of this name in the first controller of the `extends` chain that wrote it."""
        return self if self.replaces is None else self.replaces.first


@dataclass
class MergedController:
    """A controller with its `extends` chain merged, before meaning is checked.

    Attributes:
        name: the controller's name.
        description: its description.
        sources: files read, the requested one first.
        parameters: name -> entry, tunables included (children replace parents').
        groups: leg groups, built-in ones included.
        elements: name -> entry, in order (parents' first, replaced ones in place).
    """

    name: str
    description: str
    sources: list[str]
    parameters: dict[str, ParameterEntry]
    groups: dict[str, tuple[str, ...]]
    elements: dict[str, ElementEntry]
