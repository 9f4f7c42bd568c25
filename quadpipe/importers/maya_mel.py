"""MEL, the language of Maya ASCII (`.ma`) files: tokens, statements, and the values in them.

`MelScript` splits a file into statements (token lists ended by `;`), reads numbers and yes/no
words, and raises every error at the token's line and column; `quadpipe.importers.maya_ascii`
runs the statements that build a skeleton.
"""

from __future__ import annotations

import bisect
import math
import re
from collections.abc import Iterator
from dataclasses import dataclass
from typing import NoReturn

from quadpipe.core.errors import QuadpipeError

TRUE_WORDS = {"yes", "true", "on", "1"}
FALSE_WORDS = {"no", "false", "off", "0"}
"""How MEL writes booleans (case-insensitive)."""

_TOKEN = re.compile(
    r"""
      (?P<space>\s+)
    | (?P<comment>//[^\n]*|/\*.*?\*/)
    | (?P<open_comment>/\*)
    | (?P<string>"(?:[^"\\\n]|\\.)*")
    | (?P<open_string>")
    | (?P<semicolon>;)
    | (?P<word>[^\s;"]+)
    """,
    re.VERBOSE | re.DOTALL,
)
_ESCAPE = re.compile(r"\\(.)", re.DOTALL)
_ESCAPES = {"n": "\n", "t": "\t", "r": "\r"}


@dataclass(frozen=True)
class Token:
    """One MEL token: a word, or a quoted string (unescaped, without its quotes)."""

    text: str
    quoted: bool
    line: int
    column: int


class MelScript:
    """The statements of one MEL text, and its values read with errors at their line and column."""

    def __init__(self, source: str, text: str) -> None:
        self.source = source
        self.text = text
        self.line_starts = [0] + [m.end() for m in re.finditer("\n", text)]

    def fail(self, token: Token | None, code: str, message: str, hint: str | None = None) -> NoReturn:
        """Raise a `QuadpipeError` at a token's line and column (the file itself when None)."""
        raise QuadpipeError.single(
            code,
            message,
            file=self.source,
            line=token.line if token else None,
            column=token.column if token else None,
            hint=hint,
        )

    def position(self, offset: int) -> tuple[int, int]:
        """(line, column), both from 1, of a character offset in the text."""
        line = bisect.bisect_right(self.line_starts, offset)
        return line, offset - self.line_starts[line - 1] + 1

    def token(self, match: re.Match[str]) -> Token:
        """The token a regex match stands for; an unclosed string or comment is an error."""
        line, column = self.position(match.start())
        kind = match.lastgroup
        if kind == "string":
            text = _ESCAPE.sub(lambda m: _ESCAPES.get(m.group(1), m.group(1)), match.group()[1:-1])
            return Token(text, True, line, column)
        if kind == "open_string":
            self.fail(
                Token('"', False, line, column),
                "ma-unterminated-string",
                "this string has no closing quote on its line",
                'close the string with " (write a line break inside a string as \\n)',
            )
        if kind == "open_comment":
            self.fail(
                Token("/*", False, line, column),
                "ma-unterminated-comment",
                "this /* comment is never closed",
                "close it with */",
            )
        return Token(match.group(), False, line, column)

    def statements(self) -> Iterator[list[Token]]:
        """Statements (token lists) separated by `;`; a missing final `;` means a cut file.

        Statements that `ignorable` skips are scanned without building their tokens (mesh
        data can be millions of numbers).
        """
        pending: list[Token] = []
        skipping = False
        for match in _TOKEN.finditer(self.text):
            kind = match.lastgroup
            if kind in ("space", "comment") or (skipping and kind in ("word", "string")):
                continue
            if kind == "semicolon":
                if pending and not skipping:
                    yield pending
                pending, skipping = [], False
                continue
            pending.append(self.token(match))
            skipping = self.ignorable(pending)
        if pending:
            self.fail(
                pending[0],
                "ma-truncated",
                f"the file ends inside this {pending[0].text!r} statement (no closing ';')",
                "the file was cut short: save or export it again",
            )

    def ignorable(self, pending: list[Token]) -> bool:
        """Whether a statement begun with these tokens can be skipped unread (a reader that runs
        only some commands says which); `statements` then builds none of its tokens."""
        return False

    def one_value(self, target: Token, values: list[Token]) -> Token:
        """The one value given to `target` (an error when there are none or several)."""
        if len(values) != 1:
            self.fail(
                values[0] if values else target, "ma-bad-value", f"{target.text!r} takes one value, found {len(values)}"
            )
        return values[0]

    def number(self, token: Token) -> float:
        """A token's finite number (an error for anything else)."""
        try:
            value = float(token.text)
        except ValueError:
            value = math.nan
        if not math.isfinite(value):
            self.fail(token, "ma-bad-number", f"{token.text!r} is not a number", "write a plain decimal number")
        return value

    def boolean(self, token: Token) -> bool:
        """A token's yes/no word as a bool (an error for anything else)."""
        word = token.text.lower()
        if word not in TRUE_WORDS | FALSE_WORDS:
            self.fail(token, "ma-bad-value", f"{token.text!r} is not yes/no", "write yes or no")
        return word in TRUE_WORDS


def flag_values(statement: list[Token], flags: set[str]) -> list[tuple[Token, Token]]:
    """(flag, value) pairs for the flags in `flags` (each takes one value)."""
    pairs = []
    for index, token in enumerate(statement[:-1]):
        if token.text in flags and not token.quoted:
            pairs.append((token, statement[index + 1]))
    return pairs


def strip_type_flag(values: list[Token]) -> list[Token]:
    """Drop `-type "double3"` (and similar) from a setAttr value list."""
    kept: list[Token] = []
    skip = False
    for token in values:
        if skip:
            skip = False
        elif token.text in ("-type", "-typ") and not token.quoted:
            skip = True
        else:
            kept.append(token)
    return kept
