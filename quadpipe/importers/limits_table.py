"""Joint-limit tables as CSV or TSV, with the thesis's columns.

    bone     twistmin  twistmax  swing1  swing2
    tails    -20       40        0       20
    neck0    -5        60        0       10

Degrees. Lines starting with `#` are comments. Header names are matched loosely
(`twist_min`, `Twist Min` and `twistmin` are the same column; `os` and `name` mean `bone`).
"""

from __future__ import annotations

import csv
import io
from pathlib import Path

from quadpipe.anatomy.limits import JointLimit, JointLimits, check_row_key, from_degrees
from quadpipe.core.errors import Location, QuadpipeError
from quadpipe.core.limits import MAX_TABLE_FILE_BYTES
from quadpipe.core.textfiles import read_text

COLUMNS = ("bone", "twistmin", "twistmax", "swing1", "swing2")
COLUMN_ALIASES = {"os": "bone", "name": "bone", "role": "bone"}


def _normalise(header: str) -> str:
    key = header.strip().lower().replace("_", "").replace(" ", "").replace("-", "")
    return COLUMN_ALIASES.get(key, key)


def read_limits(path: str | Path) -> JointLimits:
    """Read a limits table; the delimiter is a tab for `.tsv` and a comma for `.csv`.

    Raises:
        QuadpipeError: unreadable file, missing columns, a cell that is not a number, a
            bone listed twice, or limits that make no sense (min above max, negative swing).
    """
    path = Path(path)
    source = str(path)
    text = read_text(path, MAX_TABLE_FILE_BYTES)
    delimiter = "\t" if path.suffix.lower() == ".tsv" else ","
    rows = [
        (number, cells)
        for number, cells in enumerate(csv.reader(io.StringIO(text), delimiter=delimiter), start=1)
        if cells and any(c.strip() for c in cells) and not cells[0].lstrip().startswith("#")
    ]
    if not rows:
        raise QuadpipeError.single(
            "empty-table",
            "the limits table has no rows",
            file=source,
            line=1,
            column=1,
            hint=f"a limits table is a header line naming the columns {' '.join(COLUMNS)}, then one row per bone",
        )
    header_line, header = rows[0]
    columns = [_normalise(h) for h in header]
    missing = [c for c in COLUMNS if c not in columns]
    if missing:
        raise QuadpipeError.single(
            "bad-header",
            f"the header lacks column(s) {', '.join(missing)}",
            file=source,
            line=header_line,
            hint=f"the first non-comment line must name the columns: {' '.join(COLUMNS)}"
            + (" (is the delimiter right? .tsv uses tabs, .csv commas)" if len(header) == 1 else ""),
        )
    index = {c: columns.index(c) for c in COLUMNS}
    limits: dict[str, JointLimit] = {}
    first_lines: dict[str, int] = {}
    for line, cells in rows[1:]:
        bone = cells[index["bone"]].strip() if len(cells) > index["bone"] else ""
        where = Location(source, line, 1)
        if bone in limits:
            raise QuadpipeError.single(
                "duplicate-row", f"bone {bone!r} has two rows (first at line {first_lines[bone]})", where=where
            )
        check_row_key(bone, where)
        _check_row_length(cells, index, where)
        twist_min, twist_max, swing1, swing2 = (_number(cells, index[c], c, source, line, bone) for c in COLUMNS[1:])
        limits[bone] = from_degrees(twist_min, twist_max, swing1, swing2, where=where)
        first_lines[bone] = line
    return JointLimits(limits, source)


def _check_row_length(cells: list[str], index: dict[str, int], where: Location) -> None:
    """A row must reach every column of the header.

    Raises:
        QuadpipeError: `short-row`, naming the columns the row has and those it lacks.
    """
    lacking = [name for name in COLUMNS if index[name] >= len(cells)]
    if lacking:
        having = [name for name in COLUMNS if name not in lacking]
        raise QuadpipeError.single(
            "short-row",
            f"the row has {len(cells)} cell{'s' if len(cells) != 1 else ''} ({', '.join(having) or 'none'}) "
            f"and lacks {', '.join(lacking)}",
            where=where,
            hint=f"give every row the header's columns: {' '.join(COLUMNS)}",
        )


def _number(cells: list[str], column: int, name: str, source: str, line: int, bone: str) -> float:
    text = cells[column].strip() if column < len(cells) else ""
    try:
        return float(text)
    except ValueError:
        raise QuadpipeError.single(
            "bad-number",
            f"{name} of {bone!r} is {text!r}, not a number of degrees",
            file=source,
            line=line,
            column=_column_of(cells, column),
        ) from None


def _column_of(cells: list[str], column: int) -> int:
    """1-based character column where cell `column` starts (one delimiter between cells)."""
    return 1 + sum(len(c) + 1 for c in cells[:column])
