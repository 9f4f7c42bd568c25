"""BVH (Biovision hierarchy) skeletons: the HIERARCHY section, and one frame of MOTION on request.

    HIERARCHY
    ROOT Bip01 Pelvis
    {
        OFFSET 0 65.56 0
        CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
        JOINT Bip01 L Thigh
        {
            OFFSET 7.5 -3.56 -3
            CHANNELS 3 Zrotation Xrotation Yrotation
            ...
                End Site
                {
                    OFFSET 0 -1.2 2.5
                }
        }
    }
    MOTION
    ...

A joint's rest position is the sum of the OFFSETs from the root down to it; an End Site
gives its joint's `end`. Joint names run to the end of their line (`Bip01 L Thigh`). With
`rest_frame=N` the pose is frame N of the MOTION section instead (frames count from 0): each
joint turns by its rotation channels in the order its CHANNELS line lists them (intrinsic,
`Zrotation Xrotation Yrotation` is Rz Rx Ry), and position channels replace its OFFSET.
BVH declares neither units nor axes: quadpipe reads y up and centimetres, or metres when the
skeleton spans under `METRE_GUESS_SPAN` units (said in a warning); a role map's `units:` or
the `units` argument says otherwise. Joints carry no main axis.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import NoReturn

from quadpipe.anatomy.skeleton import JointRecord, RawSkeleton
from quadpipe.core import limits
from quadpipe.core.errors import Issue, Location, QuadpipeError
from quadpipe.core.textfiles import read_text
from quadpipe.importers.bvh_motion import Motion, pose_at

CHANNEL_NAMES = {f"{axis}{kind}" for axis in "xyz" for kind in ("position", "rotation")}
"""Valid CHANNELS entries, lower-cased."""

METRE_GUESS_SPAN = 10.0
"""A skeleton spanning less than this many file units is read in metres (10 cm is no quadruped)."""

_WORD = re.compile(r"\S+")

Vector = tuple[float, float, float]


@dataclass(frozen=True)
class _Token:
    text: str
    line: int
    column: int


@dataclass
class _Joint:
    """A joint being read: filled in as its body is parsed."""

    name: str
    parent: str | None
    line: int
    origin: Vector
    position: Vector | None = None
    end: Vector | None = None
    channels_seen: bool = False
    offset: Vector = (0.0, 0.0, 0.0)
    end_offset: Vector | None = None
    channels: tuple[str, ...] = ()

    def record(self) -> JointRecord:
        """The joint as read, once parsed (the parser requires every joint's OFFSET)."""
        assert self.position is not None, "`_Parser.joint` requires every joint's OFFSET"
        return JointRecord(name=self.name, parent=self.parent, position=self.position, end=self.end, line=self.line)


def _moved(point: Vector, offset: Vector) -> Vector:
    """`point` moved by `offset`."""
    return point[0] + offset[0], point[1] + offset[1], point[2] + offset[2]


class _Parser:
    """Reader of the HIERARCHY section."""

    def __init__(self, source: str, text: str) -> None:
        self.source = source
        self.lines = text.splitlines()
        self.tokens: list[_Token] = []
        for number, line in enumerate(self.lines, start=1):
            self.tokens.extend(_Token(m.group(), number, m.start() + 1) for m in _WORD.finditer(line))
        self.index = 0
        self.joints: list[_Joint] = []

    def fail(self, token: _Token | None, code: str, message: str, hint: str | None = None) -> NoReturn:
        line = token.line if token else max(len(self.lines), 1)
        raise QuadpipeError.single(
            code, message, file=self.source, line=line, column=token.column if token else None, hint=hint
        )

    def peek(self) -> _Token | None:
        return self.tokens[self.index] if self.index < len(self.tokens) else None

    def take(self, inside: _Joint | None) -> _Token:
        """The next token; the end of the file inside a joint means the file was cut short."""
        token = self.peek()
        if token is None:
            where = f"inside joint {inside.name!r} (opened at line {inside.line})" if inside else "inside the hierarchy"
            self.fail(None, "bvh-truncated", f"the file ends {where}", "the file was cut short, or a '}' is missing")
        self.index += 1
        return token

    def expect_open(self, inside: _Joint) -> None:
        token = self.take(inside)
        if token.text != "{":
            self.fail(
                token,
                "bvh-syntax",
                f"expected '{{' after {inside.name!r}, found {token.text!r}",
                "each ROOT, JOINT and End Site line is followed by a '{' line",
            )

    def rest_of_line(self, keyword: _Token) -> str:
        """The text after `keyword` on its line (a joint name); a trailing `{` is left as a token."""
        words = []
        while (token := self.peek()) is not None and token.line == keyword.line and token.text != "{":
            words.append(token)
            self.index += 1
        if not words:
            self.fail(keyword, "bvh-syntax", f"{keyword.text} has no name", f"write the name after {keyword.text}")
        line = self.lines[keyword.line - 1]
        return line[words[0].column - 1 : words[-1].column - 1 + len(words[-1].text)]

    def number(self, token: _Token, what: str) -> float:
        try:
            value = float(token.text)
        except ValueError:
            value = math.nan
        if not math.isfinite(value):
            self.fail(
                token, "bvh-bad-number", f"{token.text!r} is not a number ({what})", "write a plain decimal number"
            )
        return value

    def offset(self, inside: _Joint, what: str) -> Vector:
        x, y, z = (self.number(self.take(inside), what) for _ in range(3))
        return x, y, z

    def parse(self) -> list[_Joint]:
        first = self.peek()
        if first is None or first.text.upper() != "HIERARCHY":
            self.fail(
                first,
                "bvh-missing-hierarchy",
                "a BVH file starts with the word HIERARCHY",
                "is this a BVH file? the skeleton must come first, before MOTION",
            )
        self.index += 1
        while (token := self.peek()) is not None:
            keyword = token.text.upper()
            if keyword == "MOTION":
                break
            self.index += 1
            if keyword == "ROOT":
                self.joint(token, None)
            elif token.text == "}":
                self.fail(
                    token,
                    "bvh-unbalanced-braces",
                    "this '}' closes nothing",
                    "remove it, or find the '{' it should close",
                )
            else:
                self.fail(token, "bvh-syntax", f"expected ROOT or MOTION, found {token.text!r}")
        if not self.joints:
            self.fail(first, "bvh-syntax", "the HIERARCHY has no ROOT joint", "add ROOT <name> { OFFSET x y z ... }")
        return self.joints

    def joint(self, keyword: _Token, parent: _Joint | None) -> None:
        """Read a ROOT and every joint under it, with a stack of the open joints (not recursion)."""
        stack = [self.open_joint(keyword, parent)]
        while stack:
            joint = stack[-1]
            token = self.take(joint)
            keyword_text = token.text.upper()
            if token.text == "}":
                self.require_offset(token, joint)
                stack.pop()
            elif keyword_text == "OFFSET":
                joint.offset = self.offset(joint, f"OFFSET of {joint.name!r}")
                joint.position = _moved(joint.origin, joint.offset)
            elif keyword_text == "CHANNELS":
                self.channels(token, joint)
            elif keyword_text == "JOINT":
                self.require_offset(token, joint)
                stack.append(self.open_joint(token, joint))
            elif keyword_text == "END":
                self.end_site(token, joint)
            elif keyword_text in ("ROOT", "MOTION", "HIERARCHY"):
                self.fail(
                    token,
                    "bvh-unbalanced-braces",
                    f"joint {joint.name!r} (opened at line {joint.line}) is not closed before {token.text}",
                    "add the missing '}'",
                )
            else:
                self.fail(
                    token,
                    "bvh-syntax",
                    f"unexpected {token.text!r} in joint {joint.name!r}",
                    "a joint holds OFFSET, CHANNELS, JOINT and End Site",
                )

    def open_joint(self, keyword: _Token, parent: _Joint | None) -> _Joint:
        """A new joint from its ROOT or JOINT line and the '{' after it."""
        origin = parent.position if parent and parent.position else (0.0, 0.0, 0.0)
        joint = _Joint(self.rest_of_line(keyword), parent.name if parent else None, keyword.line, origin)
        if len(self.joints) >= limits.MAX_JOINTS.value:
            raise limits.MAX_JOINTS.exceeded(where=Location(self.source, keyword.line, keyword.column))
        self.joints.append(joint)
        self.expect_open(joint)
        return joint

    def require_offset(self, token: _Token, joint: _Joint) -> Vector:
        """The joint's position; failing when its OFFSET has not been read yet."""
        if joint.position is None:
            self.fail(
                token,
                "bvh-syntax",
                f"joint {joint.name!r} has no OFFSET before this point",
                "write OFFSET x y z right after the joint's '{'",
            )
        return joint.position

    def channels(self, keyword: _Token, joint: _Joint) -> None:
        if joint.channels_seen:
            self.fail(keyword, "bvh-bad-channels", f"joint {joint.name!r} has two CHANNELS lines")
        joint.channels_seen = True
        count_token = self.take(joint)
        if not count_token.text.isdigit():
            self.fail(
                count_token,
                "bvh-bad-channels",
                f"CHANNELS needs a count, found {count_token.text!r}",
                "write CHANNELS 3 Zrotation Xrotation Yrotation",
            )
        names = []
        while (token := self.peek()) is not None and token.line == keyword.line:
            names.append(token)
            self.index += 1
        if len(names) != int(count_token.text):
            self.fail(
                count_token,
                "bvh-bad-channels",
                f"CHANNELS says {count_token.text} but lists {len(names)} channel(s)",
                "the count must match the channel names on the same line",
            )
        joint.channels = tuple(name.text.lower() for name in names)
        for name in names:
            if name.text.lower() not in CHANNEL_NAMES:
                self.fail(
                    name,
                    "bvh-bad-channels",
                    f"{name.text!r} is not a channel",
                    "channels are Xposition, Yposition, Zposition, Xrotation, Yrotation, Zrotation",
                )

    def end_site(self, keyword: _Token, joint: _Joint) -> None:
        position = self.require_offset(keyword, joint)
        site = self.take(joint)
        if site.text.upper() != "SITE" or site.line != keyword.line:
            self.fail(keyword, "bvh-syntax", "expected 'End Site'")
        if joint.end is not None:
            self.fail(
                keyword, "bvh-syntax", f"joint {joint.name!r} has a second End Site", "keep one End Site per joint"
            )
        self.expect_open(joint)
        offset_token = self.take(joint)
        if offset_token.text.upper() != "OFFSET":
            self.fail(
                offset_token,
                "bvh-syntax",
                f"expected OFFSET in the End Site of {joint.name!r}, found {offset_token.text!r}",
            )
        joint.end_offset = self.offset(joint, f"End Site of {joint.name!r}")
        joint.end = _moved(position, joint.end_offset)
        closing = self.take(joint)
        if closing.text != "}":
            self.fail(
                closing,
                "bvh-unbalanced-braces",
                f"the End Site of {joint.name!r} is not closed: found {closing.text!r} where '}}' belongs",
                "an End Site holds only its OFFSET",
            )

    def motion(self) -> Motion:
        """The MOTION section's tokens (after `parse`), for `pose_at`."""
        return Motion(self.source, self.tokens[self.index :], len(self.lines))


def read_skeleton(path: str | Path, *, rest_frame: int | None = None, units: str | None = None) -> RawSkeleton:
    """Read the joint hierarchy of a BVH file (y up, no axes), posed at `rest_frame` if given.

    Args:
        path: the file.
        rest_frame: a frame of the MOTION section to take as the rest pose (from 0).
        units: the file's length unit; None guesses centimetres or metres from its size.

    Raises:
        QuadpipeError: no HIERARCHY, a cut-off file, unbalanced braces, a bad number, a
            CHANNELS line that does not add up, a MOTION section without that frame, or
            anything else out of place.
    """
    path = Path(path)
    text = read_text(path, limits.MAX_SKELETON_FILE_BYTES)
    parser = _Parser(str(path), text)
    joints = parser.parse()
    records = tuple(j.record() for j in joints)
    if rest_frame is not None:
        records = pose_at(parser.motion(), joints, records, rest_frame)
    warnings: tuple[Issue, ...] = ()
    if units is None:
        units, warnings = _guess_units(str(path), records)
    return RawSkeleton(
        name=path.name.split(".")[0], source=str(path), joints=records, units=units, up="y", warnings=warnings
    )


def _guess_units(source: str, records: tuple[JointRecord, ...]) -> tuple[str, tuple[Issue, ...]]:
    """Centimetres, or metres (with a warning saying so) for a skeleton spanning few units."""
    points = [p for j in records for p in (j.position, j.end) if p is not None]
    span = max(max(p[axis] for p in points) - min(p[axis] for p in points) for axis in range(3))
    if span >= METRE_GUESS_SPAN:
        return "cm", ()
    warning = Issue(
        "bvh-units-guessed",
        f"BVH declares no unit and the skeleton spans {span:.3g} units: read as metres",
        Location(source),
        "a role map with `units: cm` (or in, mm, ft) says otherwise",
        severity="warning",
    )
    return "m", (warning,)
