"""Where text becomes data: every text file quadpipe reads is decoded here.

`read_text` refuses a file over its size limit before reading it, then `decode` accepts UTF-8
(a byte order mark is dropped) and nothing else: UTF-16, Latin-1 or binary data is a
`not-utf8` error, and a NUL byte (binary data, or UTF-16 without its byte order mark) a
`not-text` error, each located at the first bad byte with what to do about it.
"""

from __future__ import annotations

import codecs
from pathlib import Path

from quadpipe.core.errors import Location, QuadpipeError
from quadpipe.core.limits import Limit

SAVE_AS_UTF8 = "save the file as UTF-8 text (in most editors: Save As, encoding UTF-8)"
"""The hint of every decoding error."""

_UTF16_BOMS = (codecs.BOM_UTF16_LE, codecs.BOM_UTF16_BE)


def read_text(path: str | Path, limit: Limit) -> str:
    """Read a text file whole: its size checked against `limit` first, then decoded as UTF-8.

    Raises:
        QuadpipeError: `file-unreadable`, `limit-exceeded` (too big), `not-utf8` or `not-text`.
    """
    path = Path(path)
    try:
        size = path.stat().st_size
        if size > limit.value:
            raise limit.exceeded(size, where=Location(str(path)))
        data = path.read_bytes()
    except OSError as exc:
        raise QuadpipeError.single(
            "file-unreadable", f"cannot read {path}: {exc.strerror or exc}", file=str(path)
        ) from None
    return decode(data, str(path))


def decode(data: bytes, file: str) -> str:
    """UTF-8 bytes as text, without a leading byte order mark.

    Raises:
        QuadpipeError: `not-utf8` at the first byte that is not UTF-8, `not-text` at the
            first NUL byte.
    """
    bom = len(codecs.BOM_UTF8) if data.startswith(codecs.BOM_UTF8) else 0
    try:
        text = data[bom:].decode("utf-8")
    except UnicodeDecodeError as exc:
        offset = bom + exc.start
        raise QuadpipeError.single(
            "not-utf8",
            f"the file is not UTF-8 text: byte 0x{data[offset]:02x} at offset {offset} {_guess(data)}",
            where=_location(data, offset, file),
            hint=SAVE_AS_UTF8,
        ) from None
    nul = text.find("\0")
    if nul >= 0:
        offset = bom + len(text[:nul].encode("utf-8"))
        raise QuadpipeError.single(
            "not-text",
            f"the file holds a NUL byte at offset {offset}: it is binary data or UTF-16, not text",
            where=_location(data, offset, file),
            hint=SAVE_AS_UTF8,
        )
    return text


def _guess(data: bytes) -> str:
    """What the bytes probably are, to end the `not-utf8` message."""
    if data.startswith(_UTF16_BOMS):
        return "(the file starts with a UTF-16 byte order mark: it is UTF-16)"
    if b"\0" in data[:4096]:
        return "(it holds NUL bytes: binary data or UTF-16)"
    return "(perhaps Latin-1 or Windows-1252)"


def _location(data: bytes, offset: int, file: str) -> Location:
    """The line and character column of the byte at `offset` (1-based)."""
    line_start = max(data.rfind(b"\n", 0, offset) + 1, len(codecs.BOM_UTF8) if data.startswith(codecs.BOM_UTF8) else 0)
    column = len(data[line_start:offset].decode("utf-8", errors="replace")) + 1
    return Location(file, data.count(b"\n", 0, offset) + 1, column)
