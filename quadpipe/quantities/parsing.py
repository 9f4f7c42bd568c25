"""Parsing expression text: quadpipe's syntax rewritten to Python's, then a whitelisted `ast`.

A unit written after a number binds to it (`38/30 s` is `(38/30)*s`, `x / 2 s` is
`x / (2*s)`), and `^` means a power. The length limit counts the text outside the tables (the
lists of `interp`), which are bounded by their number of points instead. Only a whitelist of syntax is accepted (arithmetic,
comparisons, `and`/`or`/`not`, `a if c else b`, vector literals, calls, names, attributes and
numbers); anything else is refused before evaluation, so no Python object is ever reached.
"""

from __future__ import annotations

import ast
import functools
import io
import tokenize
from dataclasses import dataclass
from typing import Any

from quadpipe.core.limits import (
    MAX_EXPRESSION_DEPTH,
    MAX_EXPRESSION_LENGTH,
    MAX_TABLE_EXPRESSION_LENGTH,
    MAX_TABLE_POINTS,
)
from quadpipe.quantities import units
from quadpipe.quantities.nodes import TABLE_FUNCTION, ExprError, limit_error, nesting_depth


def _is_unit_token(tokens: list[tokenize.TokenInfo], i: int) -> bool:
    token = tokens[i]
    if token.type != tokenize.NAME or token.string not in units.UNITS:
        return False
    after = tokens[i + 1] if i + 1 < len(tokens) else None
    return after is None or after.string not in ("(", ".")


def _unit_run(tokens: list[tokenize.TokenInfo], i: int) -> tuple[list[str], int]:
    """Unit tokens starting at `i` (`bw`, `*`, `HP`, `/`, `rad`, `^`, `2`); returns them and the next index."""
    out = [tokens[i].string]
    i += 1
    while i < len(tokens):
        token = tokens[i]
        if token.string in ("**", "^") and i + 1 < len(tokens):
            j = i + 1
            sign = ""
            if tokens[j].string == "-" and j + 1 < len(tokens):
                sign, j = "-", j + 1
            if tokens[j].type == tokenize.NUMBER:
                out += ["**", f"({sign}{tokens[j].string})"]
                i = j + 1
                continue
            break
        if token.string in ("*", "/") and i + 1 < len(tokens) and _is_unit_token(tokens, i + 1):
            out += [token.string, tokens[i + 1].string]
            i += 2
            continue
        break
    return out, i


def _numeric_run_start(out: list[str], kinds: list[int]) -> int:
    """Index in `out` where the run of numbers joined by * and / ending at the last token starts."""
    start = len(out) - 1
    while start >= 2 and out[start - 1] in ("*", "/") and kinds[start - 2] == tokenize.NUMBER:
        if start >= 3 and out[start - 3] in ("**",):
            break
        start -= 2
    return start


def _tokens(text: str) -> list[tokenize.TokenInfo]:
    """The tokens of an expression's text (no line breaks or indents).

    Raises:
        ExprError: the text cannot be split into tokens.
    """
    try:
        return [
            t
            for t in tokenize.generate_tokens(io.StringIO(text).readline)
            if t.type not in (tokenize.NEWLINE, tokenize.NL, tokenize.ENDMARKER, tokenize.INDENT, tokenize.DEDENT)
        ]
    except (tokenize.TokenError, IndentationError, SyntaxError) as exc:
        raise ExprError("expression-syntax", f"cannot read the expression {text!r}: {exc.args[0]}") from None


def rewrite(text: str) -> str:
    """Turn quadpipe's expression syntax into Python syntax (unit binding, `^` powers).

    Raises:
        ExprError: the text cannot be split into tokens.
    """
    return _rewrite_tokens(_tokens(text), text)


def _rewrite_tokens(tokens: list[tokenize.TokenInfo], text: str) -> str:
    """`rewrite` of the tokens of `text`."""
    out: list[str] = []
    kinds: list[int] = []
    i = 0
    while i < len(tokens):
        token = tokens[i]
        if token.type == tokenize.ERRORTOKEN and not token.string.isspace():
            raise ExprError(
                "expression-syntax", f"cannot read the expression {text!r}: unexpected character {token.string!r}"
            )
        if _is_unit_token(tokens, i) and kinds and kinds[-1] == tokenize.NUMBER:
            start = _numeric_run_start(out, kinds)
            unit_tokens, i = _unit_run(tokens, i)
            number = out[start:]
            del out[start:], kinds[start:]
            out += ["(", "(", *number, ")", "*", *unit_tokens, ")"]
            kinds += [tokenize.OP] * (len(number) + len(unit_tokens) + 4)
            continue
        out.append("**" if token.string == "^" else token.string)
        kinds.append(token.type)
        i += 1
    return " ".join(out)


@dataclass
class _Bracket:
    """An open bracket while scanning tokens: its character, whether it opens a call of
    `TABLE_FUNCTION` (and then its arguments so far), and, for a table, where it starts in the
    text and its items so far."""

    char: str
    table_call: bool = False
    commas: int = 0
    start: int = -1
    items: int = 0
    pending: bool = True


def table_lists(text: str) -> list[tuple[int, int]]:
    """The tables of an expression, as (characters, items): each list given to
    `TABLE_FUNCTION` after its first argument, from its `[` to its `]`.

    Raises:
        ExprError: the text cannot be split into tokens.
    """
    return _table_lists(_tokens(text), text)


def _table_lists(tokens: list[tokenize.TokenInfo], text: str) -> list[tuple[int, int]]:
    """`table_lists` of the tokens of `text`."""
    line_starts = [0]
    for line in text.splitlines(keepends=True):
        line_starts.append(line_starts[-1] + len(line))
    tables: list[tuple[int, int]] = []
    stack: list[_Bracket] = []
    for index, token in enumerate(tokens):
        inner = stack[-1] if stack else None
        if inner is not None and inner.start >= 0 and token.string not in (",", "]") and inner.pending:
            inner.items, inner.pending = inner.items + 1, False
        if token.string == "(":
            before = tokens[index - 1] if index else None
            called = before is not None and before.type == tokenize.NAME and before.string == TABLE_FUNCTION
            stack.append(_Bracket("(", table_call=called))
        elif token.string == "[":
            in_table_call = inner is not None and inner.table_call and inner.commas >= 1
            start = line_starts[token.start[0] - 1] + token.start[1] if in_table_call else -1
            stack.append(_Bracket("[", start=start))
        elif token.string in (")", "]") and stack:
            closed = stack.pop()
            if closed.start >= 0:
                tables.append((line_starts[token.end[0] - 1] + token.end[1] - closed.start, closed.items))
        elif token.string == "," and inner is not None:
            inner.commas, inner.pending = inner.commas + 1, True
    return tables


def _check_length(tokens: list[tokenize.TokenInfo], text: str) -> None:
    """Refuse an expression over the length limits: its text without its tables
    (`MAX_EXPRESSION_LENGTH`) and the points of each table (`MAX_TABLE_POINTS`); its whole
    text (`MAX_TABLE_EXPRESSION_LENGTH`) is checked before it is split into `tokens`.

    Raises:
        ExprError: `limit-exceeded`.
    """
    tables = _table_lists(tokens, text)
    own = len(text) - sum(characters for characters, _ in tables)
    if own > MAX_EXPRESSION_LENGTH.value:
        raise limit_error(MAX_EXPRESSION_LENGTH, own)
    largest = max((items for _, items in tables), default=0)
    if largest > MAX_TABLE_POINTS.value:
        raise limit_error(MAX_TABLE_POINTS, largest)


def _syntax_hint(text: str) -> str:
    """A hint for a syntax error, from common mistakes."""
    try:
        tokens = [
            t
            for t in tokenize.generate_tokens(io.StringIO(text).readline)
            if t.type in (tokenize.NAME, tokenize.NUMBER, tokenize.OP)
        ]
    except (tokenize.TokenError, SyntaxError):
        return "check brackets and operators"
    for a, b in zip(tokens, tokens[1:]):
        if a.type == tokenize.NAME and b.type == tokenize.NAME:
            return f"two names side by side ({a.string} {b.string}): to give a name a unit, multiply: `{a.string} * {b.string}`"
        if a.string == ")" and b.type == tokenize.NAME:
            return f"a unit goes right after a number (`2 cm`); after brackets multiply: `(...) * 1 {b.string}`"
    if "{" in text:
        return "placeholders like {leg} only work in elements with `for_each`"
    return "check brackets and operators; units go right after a number (`2 cm`, `38/30 s`)"


_ALLOWED_NODES = (
    ast.Expression, ast.BinOp, ast.UnaryOp, ast.BoolOp, ast.Compare, ast.IfExp, ast.Call, ast.Name,
    ast.Attribute, ast.Constant, ast.List, ast.Subscript, ast.Load,
    ast.Add, ast.Sub, ast.Mult, ast.Div, ast.Pow, ast.USub, ast.UAdd, ast.Not, ast.And, ast.Or,
    ast.Lt, ast.LtE, ast.Gt, ast.GtE, ast.Eq, ast.NotEq,
)  # fmt: skip


PARSED_TREES_KEPT = 8192
"""Expression trees `parse` keeps, by text: a controller's expressions repeat across its legs,
its parents and every load of it (a `walk` simulation parsed 2,225 texts, 0.9 s)."""


@functools.lru_cache(maxsize=PARSED_TREES_KEPT)
def parse(text: str) -> ast.expr:
    """Parse expression text into a whitelisted Python AST (cached by text: callers read the
    tree and never change it).

    Raises:
        ExprError: syntax errors (`expression-syntax`) and refused syntax (`forbidden-syntax`).
    """
    if not text.strip():
        raise ExprError("expression-syntax", "the expression is empty", "write a number with a unit, like `2 cm`")
    if len(text) > MAX_TABLE_EXPRESSION_LENGTH.value:
        raise limit_error(MAX_TABLE_EXPRESSION_LENGTH, len(text))
    tokens = _tokens(text)
    _check_length(tokens, text)
    code = _rewrite_tokens(tokens, text)
    try:
        tree = ast.parse(code, mode="eval")
    except SyntaxError as exc:
        raise ExprError(
            "expression-syntax", f"cannot read the expression {text!r}: {exc.msg}", _syntax_hint(text)
        ) from None
    except (RecursionError, MemoryError):
        raise limit_error(MAX_EXPRESSION_DEPTH) from None
    body: ast.AST = tree.body
    depth = nesting_depth(body, lambda node: _allowed_children(node, text))
    if depth > MAX_EXPRESSION_DEPTH.value:
        raise limit_error(MAX_EXPRESSION_DEPTH, depth)
    return tree.body


def _allowed_children(node: ast.AST, text: str) -> list[ast.AST]:
    """The children of a node of the parsed `text`, once it is checked against the whitelist.

    Raises:
        ExprError: `forbidden-syntax`.
    """
    if not isinstance(node, _ALLOWED_NODES):
        raise ExprError(
            "forbidden-syntax",
            f"{type(node).__name__.lower()} is not allowed in expressions: {text!r}",
            "expressions may use numbers with units, + - * / ^, comparisons, and/or/not, `a if c else b`, [x, y, z] and the listed functions",
        )
    if isinstance(node, ast.Constant) and (isinstance(node.value, bool) or not isinstance(node.value, (int, float))):
        raise ExprError(
            "forbidden-syntax",
            f"only numbers may appear literally in {text!r}",
            "remove the quotes or the text value",
        )
    return list(ast.iter_child_nodes(node))


def referenced_names(value: Any) -> set[str]:
    """Bare names an expression value mentions (to order parameters); empty if it does not parse."""
    texts = value if isinstance(value, list) else [value]
    return set().union(*(_names_in(text) for text in texts if isinstance(text, str)))


@functools.lru_cache(maxsize=PARSED_TREES_KEPT)
def _names_in(text: str) -> frozenset[str]:
    """`referenced_names` of one text (cached by text, as `parse`: a path's table is thousands of nodes)."""
    try:
        tree = parse(text)
    except ExprError:
        return frozenset()
    return frozenset(node.id for node in ast.walk(tree) if isinstance(node, ast.Name))
