"""Where text becomes data: every text file quadpipe reads is decoded here.

`read_text` refuses a file over its size limit before reading it, then `decode` accepts UTF-8
(a byte order mark is dropped) and nothing else: UTF-16, Latin-1 or binary data is a
`not-utf8` error, and a NUL byte (binary data, or UTF-16 without its byte order mark) a
`not-text` error, each located at the first bad byte with what to do about it.

`missing_file` is the one answer for a named file that is not there: `file-not-found`, or
`is-a-folder` (with a file inside it to give instead) when the name is a folder's.
"""

from __future__ import annotations

import codecs
from collections.abc import Iterable
from pathlib import Path

from quadpipe.core.errors import Issue, Location, QuadpipeError
from quadpipe.core.limits import Limit

SAVE_AS_UTF8 = "save the file as UTF-8 text (in most editors: Save As, encoding UTF-8)"
"""The hint of every decoding error."""

_UTF16_BOMS = (codecs.BOM_UTF16_LE, codecs.BOM_UTF16_BE)


def read_text(path: str | Path, limit: Limit, what: str = "") -> str:
    """Read a text file whole: its size checked against `limit` first, then decoded as UTF-8.

    `what` names the kind of file in messages (`batch plan`).

    Raises:
        QuadpipeError: `file-not-found`, `is-a-folder`, `file-unreadable`, `limit-exceeded`
            (too big), `not-utf8` or `not-text`.
    """
    path = Path(path)
    if path.is_dir() or not path.exists():
        raise QuadpipeError([missing_file(path, what, suffixes=(path.suffix,))])
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


def missing_file(
    path: Path,
    what: str,
    *,
    name: str | None = None,
    where: Location | None = None,
    suffixes: Iterable[str] = (),
    hint: str | None = None,
) -> Issue:
    """The issue for a file that is not there: a folder of that name, or nothing.

    Args:
        path: where the file was looked for.
        what: the kind of file, for the message (`controller`, `skeleton`); empty: just "file".
        name: the name as the user wrote it (default: `path`).
        where: where it was named (default: the path itself).
        suffixes: the suffixes such a file has, to suggest one inside a folder.
        hint: the hint for a missing file.
    """
    shown = name if name is not None else str(path)
    kind = f"{what} file" if what else "file"
    where = where if where is not None else Location(shown)
    if not path.is_dir():
        return Issue("file-not-found", f"{kind} {shown!r} does not exist", where, hint)
    wanted = {suffix.lower() for suffix in suffixes if suffix}
    inside = sorted(item.name for item in path.iterdir() if item.is_file() and item.suffix.lower() in wanted)
    if inside:
        more = f" ({len(inside)} there)" if len(inside) > 1 else ""
        advice = f"give a file inside it, e.g. {str(Path(shown) / inside[0])!r}{more}"
    else:
        advice = f"give the {kind} itself" + (f" ({', '.join(sorted(wanted))})" if wanted else "")
    return Issue("is-a-folder", f"{kind} {shown!r} is a folder, not a file", where, advice)
