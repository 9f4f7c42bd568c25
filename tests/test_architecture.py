"""The package's layers, read from its import graph: no cycles, no import of a higher layer.

Every `import` counts, at module level or inside a function (a lazy import is still a
dependency), under `if TYPE_CHECKING:` too. The layers are listed in `LAYERS`, lowest first;
docs/architecture.md draws the same picture.
"""

from __future__ import annotations

import ast
import re
from functools import cache
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parent.parent / "quadpipe"

LAYERS: dict[str, int] = {
    "quadpipe.core": 0,
    "quadpipe.anatomy": 1,
    "quadpipe.clip": 1,
    "quadpipe.bodies": 1,
    "quadpipe.importers": 2,
    "quadpipe.animals": 3,
    "quadpipe.quantities": 4,
    "quadpipe.world": 5,
    "quadpipe.controllers.language": 6,
    "quadpipe.controllers.runtime": 7,
    "quadpipe.sim": 8,
    "quadpipe.exporters": 9,
    "quadpipe.render": 9,
    "quadpipe.analysis": 9,
    "quadpipe.batch": 10,
    "quadpipe.preview": 10,
    "quadpipe.cli": 11,
    "quadpipe.__main__": 11,
    "quadpipe": 11,
}
"""Layer of each subpackage (the longest matching prefix wins); a module may import its own
layer and the ones below. `quadpipe` itself (the curated API in `__init__.py`) and the CLI sit on
top."""

MAX_MODULE_LINES = 600
"""A module longer than this should be split (the guideline is ~500 lines)."""


def module_name(path: Path) -> str:
    """`quadpipe/world/scene.py` -> `quadpipe.world.scene`; a package's `__init__` is the package."""
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


@cache
def modules() -> dict[str, Path]:
    """Every module of the package, by dotted name."""
    return {module_name(p): p for p in sorted(PACKAGE.rglob("*.py"))}


def imported_modules(name: str) -> set[str]:
    """The quadpipe modules that module `name` imports (resolved to modules, not names)."""
    path = modules()[name]
    tree = ast.parse(path.read_text(), str(path))
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")
                anchor = anchor[: len(anchor) - node.level + 1]
                base = ".".join([*anchor, base] if base else anchor)
            found.add(base)
            found.update(f"{base}.{alias.name}" for alias in node.names)
    return {m for m in found if m in modules() and m != name}


def layer_of(name: str) -> int:
    """The layer of a module: that of the longest prefix listed in `LAYERS`."""
    prefixes = [p for p in LAYERS if name == p or name.startswith(p + ".")]
    assert prefixes, f"{name} belongs to no layer: add its subpackage to LAYERS"
    return LAYERS[max(prefixes, key=len)]


@pytest.mark.parametrize("name", sorted(modules()))
def test_no_module_imports_a_higher_layer(name: str) -> None:
    higher = sorted(m for m in imported_modules(name) if layer_of(m) > layer_of(name))
    assert not higher, f"{name} (layer {layer_of(name)}) imports higher layers: {higher}"


def test_the_import_graph_has_no_cycle() -> None:
    graph = {name: imported_modules(name) for name in modules()}
    state: dict[str, int] = {}
    path: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        path.append(node)
        for nxt in sorted(graph[node]):
            # a package's __init__ re-exporting its own modules is not a cycle through them
            if node == nxt.rpartition(".")[0] or nxt == node.rpartition(".")[0]:
                continue
            if state.get(nxt) == 1:
                return [*path[path.index(nxt) :], nxt]
            if nxt not in state and (cycle := visit(nxt)):
                return cycle
        path.pop()
        state[node] = 2
        return None

    for start in sorted(graph):
        if start not in state and (cycle := visit(start)):
            pytest.fail("import cycle: " + " -> ".join(cycle))


def test_every_module_is_in_a_layer_and_not_too_long() -> None:
    too_long = {
        n: len(p.read_text().splitlines())
        for n, p in modules().items()
        if len(p.read_text().splitlines()) > MAX_MODULE_LINES
    }
    for name in modules():
        layer_of(name)
    assert not too_long, f"modules over {MAX_MODULE_LINES} lines, split them: {too_long}"


def test_the_architecture_page_draws_the_same_layers() -> None:
    """docs/architecture.md's picture: each layer's line names every subpackage of that layer."""
    page = (PACKAGE.parent / "docs" / "architecture.md").read_text()
    picture = page.split("## Layers", 1)[1].split("```")[1]
    lines = {int(m.group(1)): m.group(2) for m in re.finditer(r"^\s*(\d+)\s{2}(.+)$", picture, flags=re.M)}
    for package, layer in LAYERS.items():
        short = package.removeprefix("quadpipe.") if package != "quadpipe" else "quadpipe"
        assert short in lines.get(layer, ""), f"docs/architecture.md does not draw {short} on layer {layer}"
