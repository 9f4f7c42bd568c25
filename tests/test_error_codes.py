"""Every error code the package can raise is registered in `quadpipe.core.codes`, and every
registered code is raised somewhere.

The codes are read from the source (its AST), not by running it. A code is whatever is passed
in the position of a `code: str` parameter: `Issue(...)`, `QuadpipeError.single(...)`,
`ExprError(...)`, and helpers such as the parsers' `fail(token, code, ...)` or the controller
checker's `error(code, ...)`. The argument may be a string, `a if cond else b`, a local variable
assigned such values, or an f-string whose placeholders have a known finite set of values
(`PLACEHOLDER_CHOICES`); a parameter or an `.code` attribute only passes on a code raised
elsewhere. Anything else is reported as unreadable, so a new way of making codes cannot hide.
"""

from __future__ import annotations

import ast
import itertools
import re
from collections import defaultdict
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path

from quadpipe.core import codes

REPO = Path(__file__).resolve().parent.parent
PACKAGE = REPO / "quadpipe"

PLACEHOLDER_CHOICES: dict[str, tuple[str, ...]] = {
    # core.configs.find_config(kind, name): the kinds of config looked up by name.
    "kind[:-1]": ("animal", "controller", "scene"),
    # The scene's tagged lists: only terrain items carry a `type` the user writes (props,
    # throws and animals get their tag from the keys they have, so it is always known).
    "what": ("terrain",),
}
"""Placeholders of f-string codes (their source text) -> the values they can take."""

CODE_PATTERN = re.compile(r"[a-z][a-z0-9]*(-[a-z0-9]+)*")
"""Codes are kebab-case."""


def _code_index(function: ast.FunctionDef, *, bound: bool) -> int | None:
    """The position of a `code: str` parameter in calls (`self`/`cls` not counted when bound)."""
    params = function.args.posonlyargs + function.args.args
    if bound and params:
        params = params[1:]
    for index, param in enumerate(params):
        if param.arg == "code" and param.annotation is not None and ast.unparse(param.annotation) == "str":
            return index
    return None


def _field_index(cls: ast.ClassDef) -> int | None:
    """The position of a `code: str` field of a dataclass-like class body."""
    fields = [
        (s.target.id, s.annotation) for s in cls.body if isinstance(s, ast.AnnAssign) and isinstance(s.target, ast.Name)
    ]
    for index, (name, annotation) in enumerate(fields):
        if name == "code" and ast.unparse(annotation) == "str":
            return index
    return None


def _code_shaped(expr: ast.expr) -> bool:
    """Whether an argument reads as a code (a kebab-case string, or a choice of them)."""
    if isinstance(expr, ast.IfExp):
        return _code_shaped(expr.body) and _code_shaped(expr.orelse)
    return (
        isinstance(expr, ast.Constant)
        and isinstance(expr.value, str)
        and CODE_PATTERN.fullmatch(expr.value) is not None
    )


def _replaces_fields(func: ast.expr) -> bool:
    """Whether a call is `dataclasses.replace`, whose keywords are the dataclass's fields (a
    lowered `Program`'s `code` is its instructions, not an error code)."""
    return (isinstance(func, ast.Name) and func.id == "replace") or (
        isinstance(func, ast.Attribute) and func.attr == "replace" and ast.unparse(func.value) == "dataclasses"
    )


@dataclass
class Callables:
    """What each name refers to: a set of code positions (None: takes no code)."""

    by_module: dict[str, dict[str, set[int | None]]] = field(
        default_factory=lambda: defaultdict(lambda: defaultdict(set))
    )
    by_class: dict[str, dict[str, int | None]] = field(default_factory=lambda: defaultdict(dict))
    anywhere: dict[str, set[int]] = field(default_factory=lambda: defaultdict(set))

    def add(self, module: str, name: str, index: int | None) -> None:
        self.by_module[module][name].add(index)
        if index is not None:
            self.anywhere[name].add(index)


def callables(trees: dict[str, ast.Module]) -> Callables:
    """Every function, method and class of the sources, with the position of its code."""
    found = Callables()
    for module, tree in trees.items():
        classes = [node for node in ast.walk(tree) if isinstance(node, ast.ClassDef)]
        methods_of_classes = {id(s) for cls in classes for s in cls.body if isinstance(s, ast.FunctionDef)}
        for node in ast.walk(tree):
            if isinstance(node, ast.ClassDef):
                methods = {s.name: s for s in node.body if isinstance(s, ast.FunctionDef)}
                for name, method in methods.items():
                    found.by_class[node.name][name] = _code_index(method, bound=True)
                init = methods.get("__init__")
                found.add(module, node.name, _code_index(init, bound=True) if init else _field_index(node))
            elif isinstance(node, ast.FunctionDef):
                found.add(module, node.name, _code_index(node, bound=id(node) in methods_of_classes))
    return found


@dataclass
class Scan:
    """The codes found (code -> places) and the code arguments that could not be read."""

    raised: dict[str, list[str]] = field(default_factory=lambda: defaultdict(list))
    unreadable: list[str] = field(default_factory=list)


class _CodeFinder(ast.NodeVisitor):
    """Walks one module, tracking the enclosing functions, and records every code passed."""

    def __init__(self, module: str, known: Callables, scan: Scan):
        self.module = module
        self.known = known
        self.scan = scan
        self.functions: list[ast.FunctionDef] = []

    def visit_FunctionDef(self, node: ast.FunctionDef) -> None:
        self.functions.append(node)
        self.generic_visit(node)
        self.functions.pop()

    def visit_Call(self, node: ast.Call) -> None:
        where = f"{self.module}:{node.lineno}"
        argument = self.code_argument(node, where)
        if argument is not None:
            for code in self.values(argument, where):
                self.scan.raised[code].append(where)
        self.generic_visit(node)

    def positions(self, func: ast.expr) -> set[int | None]:
        """Where the code goes in a call of `func` (empty: not a call we know)."""
        if isinstance(func, ast.Name):
            name = func.id
        elif isinstance(func, ast.Attribute):
            name = func.attr
            owner = func.value
            if isinstance(owner, ast.Name) and name in self.known.by_class.get(owner.id, {}):
                return {self.known.by_class[owner.id][name]}
        else:
            return set()
        if name.startswith("__"):  # super().__init__(...): a class's code is found by its name
            return set()
        local = self.known.by_module[self.module]
        if name in local:
            return local[name]
        return set(self.known.anywhere.get(name, ()))

    def code_argument(self, node: ast.Call, where: str) -> ast.expr | None:
        for keyword in node.keywords:
            if keyword.arg == "code" and not _replaces_fields(node.func):
                return keyword.value
        positions = {index for index in self.positions(node.func) if index is not None}
        if len(positions) > 1:  # a name defined elsewhere with different signatures: where is a code?
            positions = {index for index in positions if index < len(node.args) and _code_shaped(node.args[index])}
        if len(positions) > 1:
            self.scan.unreadable.append(
                f"{where}: {ast.unparse(node.func)} takes its code at positions {sorted(positions)}"
            )
            return None
        if not positions:
            return None
        index = positions.pop()
        return node.args[index] if index < len(node.args) else None

    def values(self, expr: ast.expr, where: str) -> set[str]:
        """The codes an argument can be; forwarded codes give none."""
        if isinstance(expr, ast.Constant) and isinstance(expr.value, str):
            return {expr.value}
        if isinstance(expr, ast.IfExp):
            return self.values(expr.body, where) | self.values(expr.orelse, where)
        if isinstance(expr, ast.JoinedStr):
            return self.expand(expr, where)
        if isinstance(expr, ast.Attribute) and expr.attr == "code":
            return set()
        if isinstance(expr, ast.Name) and self.functions:
            function = self.functions[-1]
            arguments = function.args
            if expr.id in {a.arg for a in arguments.posonlyargs + arguments.args + arguments.kwonlyargs}:
                return set()
            assigned = [
                node.value
                for node in ast.walk(function)
                if isinstance(node, ast.Assign)
                and any(isinstance(t, ast.Name) and t.id == expr.id for t in node.targets)
            ]
            if assigned:
                return set().union(*(self.values(value, where) for value in assigned))
        self.scan.unreadable.append(f"{where}: cannot tell which code {ast.unparse(expr)!r} is")
        return set()

    def expand(self, text: ast.JoinedStr, where: str) -> set[str]:
        pieces: list[tuple[str, ...]] = []
        for part in text.values:
            if isinstance(part, ast.Constant):
                pieces.append((str(part.value),))
                continue
            assert isinstance(part, ast.FormattedValue)
            placeholder = ast.unparse(part.value)
            if placeholder not in PLACEHOLDER_CHOICES:
                self.scan.unreadable.append(
                    f"{where}: the f-string code placeholder {{{placeholder}}} has no entry in PLACEHOLDER_CHOICES"
                )
                return set()
            pieces.append(PLACEHOLDER_CHOICES[placeholder])
        return {"".join(choice) for choice in itertools.product(*pieces)}


def scan_sources(sources: dict[str, str]) -> Scan:
    """Every code raised in the given module sources (module name -> text)."""
    trees = {module: ast.parse(text, module) for module, text in sources.items()}
    known = callables(trees)
    scan = Scan()
    for module, tree in trees.items():
        _CodeFinder(module, known, scan).visit(tree)
    return scan


def package_sources() -> dict[str, str]:
    return {str(path.relative_to(REPO)): path.read_text(encoding="utf-8") for path in sorted(PACKAGE.rglob("*.py"))}


@cache
def package_scan() -> Scan:
    return scan_sources(package_sources())


# --------------------------------------------------------------------------- the registry


def test_every_code_argument_can_be_read() -> None:
    assert package_scan().unreadable == []


def test_every_raised_code_is_registered() -> None:
    unregistered = {code: places for code, places in package_scan().raised.items() if code not in codes.CODES}
    assert unregistered == {}, "register these in quadpipe/core/codes.py"


def test_every_registered_code_is_raised_somewhere() -> None:
    assert sorted(set(codes.CODES) - set(package_scan().raised)) == [], (
        "dead codes: remove them from quadpipe/core/codes.py"
    )


def test_each_code_is_registered_once_in_kebab_case_with_a_meaning() -> None:
    registered = [code for group in codes.GROUPS for code in group.codes]
    assert len(registered) == len(set(registered))
    assert [code for code in registered if not CODE_PATTERN.fullmatch(code)] == []
    assert [code for code, meaning in codes.CODES.items() if not meaning.strip()] == []


def test_controller_issue_codes_come_from_the_registry() -> None:
    from quadpipe.controllers.language.validate import ISSUE_CODES

    assert codes.meanings(ISSUE_CODES) == ISSUE_CODES


def test_committed_errors_page_is_up_to_date() -> None:
    committed = (REPO / codes.DOCS_PATH).read_text(encoding="utf-8")
    assert committed == codes.errors_markdown(), "run: python -m quadpipe.core.codes"


# --------------------------------------------------------------------------- the scanner itself


def test_scan_finds_a_code_that_is_not_registered() -> None:
    helper = (
        "from quadpipe.core.errors import QuadpipeError\n"
        "class Reader:\n"
        "    def fail(self, token: object, code: str, message: str) -> None:\n"
        "        raise QuadpipeError.single(code, message)\n"
        "    def read(self, flag: bool) -> None:\n"
        "        code = 'bogus-alpha' if flag else 'unknown-key'\n"
        "        raise QuadpipeError.single(code, 'x')\n"
        "    def more(self) -> None:\n"
        "        self.fail(None, 'bogus-beta', 'y')\n"
    )
    # `fail` is defined elsewhere with the code first (expressions) and second (the parsers).
    caller = "def read(reader: object) -> None:\n    reader.fail(None, 'bogus-gamma', 'a message')\n"
    scan = scan_sources({**package_sources(), "quadpipe/bogus.py": helper, "quadpipe/caller.py": caller})
    assert scan.unreadable == []
    assert {"bogus-alpha", "bogus-beta", "bogus-gamma"} <= {code for code in scan.raised if code not in codes.CODES}
    assert "quadpipe/bogus.py:6" not in scan.raised["unknown-key"]  # the assignment is not a call...
    assert "quadpipe/bogus.py:7" in scan.raised["unknown-key"]  # ...the call that uses it is


def test_scan_expands_f_string_codes_and_refuses_unknown_placeholders() -> None:
    source = (
        "from quadpipe.core.errors import Issue\n"
        "def check(kind: str, other: str) -> list[Issue]:\n"
        "    return [Issue(f'unknown-{kind[:-1]}', 'm'), Issue(f'bad-{other}', 'm')]\n"
    )
    scan = scan_sources(
        {"quadpipe/core/errors.py": (PACKAGE / "core" / "errors.py").read_text(), "quadpipe/x.py": source}
    )
    assert set(scan.raised) == {"unknown-animal", "unknown-controller", "unknown-scene"}
    assert len(scan.unreadable) == 1 and "{other}" in scan.unreadable[0]
