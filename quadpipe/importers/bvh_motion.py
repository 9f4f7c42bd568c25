"""One frame of a BVH file's MOTION section, as a pose of its joints (`--rest-frame N`).

    MOTION
    Frames: 3
    Frame Time: 0.0333333
    0 65.56 0 0 0 0 ...      (one line per frame, one number per channel, joints in file order)

Each joint's local transform is a translation (its position channels, else its OFFSET) then
its rotation channels in the order its CHANNELS line lists them, intrinsic: a joint with
`Zrotation Xrotation Yrotation` turns by Rz Rx Ry (column vectors), as BVH writers mean it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import NoReturn, Protocol

import numpy as np

from quadpipe.anatomy.skeleton import JointRecord
from quadpipe.core.errors import QuadpipeError


class _Token(Protocol):
    """A word of the file and where it is (the BVH reader's tokens)."""

    @property
    def text(self) -> str: ...

    @property
    def line(self) -> int: ...

    @property
    def column(self) -> int: ...


class _Joint(Protocol):
    """A parsed BVH joint: what posing it needs."""

    @property
    def name(self) -> str: ...

    @property
    def parent(self) -> str | None: ...

    @property
    def offset(self) -> tuple[float, float, float]: ...

    @property
    def end_offset(self) -> tuple[float, float, float] | None: ...

    @property
    def channels(self) -> tuple[str, ...]: ...


@dataclass(frozen=True)
class Motion:
    """The tokens from the word MOTION to the end of the file."""

    source: str
    tokens: Sequence[_Token]
    line_count: int

    def fail(self, token: _Token | None, code: str, message: str, hint: str | None = None) -> NoReturn:
        raise QuadpipeError.single(
            code,
            message,
            file=self.source,
            line=token.line if token else self.line_count,
            column=token.column if token else None,
            hint=hint,
        )

    def frame(self, index: int, channel_count: int) -> list[float]:
        """The values of frame `index` (from 0).

        Raises:
            QuadpipeError: `bvh-bad-motion` for a missing or malformed MOTION header, too few
                values, or a value that is not a number; `rest-frame-out-of-range` for a frame
                the file does not have.
        """
        tokens = list(self.tokens)
        header = [t.text.lower() for t in tokens[:5]]
        if header[:2] != ["motion", "frames:"] or header[3:5] != ["frame", "time:"] or len(tokens) < 6:
            self.fail(
                tokens[0] if tokens else None,
                "bvh-bad-motion",
                "--rest-frame needs a MOTION section: MOTION, Frames: N, Frame Time: t, then the frames",
                "use a file with motion, or leave --rest-frame out to use the OFFSET pose",
            )
        frames = self.count(tokens[2])
        if not 0 <= index < frames:
            self.fail(
                tokens[2],
                "rest-frame-out-of-range",
                f"--rest-frame {index}: the file has {frames} frame(s), numbered 0 to {frames - 1}",
                "pick a frame where the animal stands on its four legs",
            )
        start = 6 + index * channel_count
        values = tokens[start : start + channel_count]
        if len(values) < channel_count:
            self.fail(
                values[0] if values else None,
                "bvh-bad-motion",
                f"frame {index} has {len(values)} value(s); the CHANNELS lines need {channel_count}",
                "the MOTION section is cut short, or a CHANNELS line does not match the data",
            )
        return [self.number(token) for token in values]

    def count(self, token: _Token) -> int:
        if not token.text.isdigit():
            self.fail(token, "bvh-bad-motion", f"Frames: needs a whole number, found {token.text!r}")
        return int(token.text)

    def number(self, token: _Token) -> float:
        try:
            value = float(token.text)
        except ValueError:
            value = math.nan
        if not math.isfinite(value):
            self.fail(
                token, "bvh-bad-number", f"{token.text!r} is not a number (MOTION)", "write a plain decimal number"
            )
        return value


def axis_rotation(axis: str, degrees: float) -> np.ndarray:
    """Right-handed rotation about x, y or z (column vectors)."""
    c, s = math.cos(math.radians(degrees)), math.sin(math.radians(degrees))
    i, j = {"x": (1, 2), "y": (2, 0), "z": (0, 1)}[axis]
    matrix = np.eye(3)
    matrix[i, i] = matrix[j, j] = c
    matrix[i, j], matrix[j, i] = -s, s
    return matrix


def pose_at(
    motion: Motion, joints: Sequence[_Joint], records: Sequence[JointRecord], frame: int
) -> tuple[JointRecord, ...]:
    """The joints' records posed as in frame `frame` of the motion."""
    values = iter(motion.frame(frame, sum(len(j.channels) for j in joints)))
    placed: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    posed = []
    for joint, record in zip(joints, records):
        translation = np.asarray(joint.offset, dtype=float)
        turn = np.eye(3)
        for channel in joint.channels:
            value = next(values)
            if channel.endswith("position"):
                translation["xyz".index(channel[0])] = value
            else:
                turn = turn @ axis_rotation(channel[0], value)
        parent_turn, parent_point = placed.get(joint.parent or "", (np.eye(3), np.zeros(3)))
        point = parent_point + parent_turn @ translation
        orientation = parent_turn @ turn
        placed[joint.name] = (orientation, point)
        end = None if joint.end_offset is None else point + orientation @ np.asarray(joint.end_offset, dtype=float)
        posed.append(replace(record, position=_vector(point), end=None if end is None else _vector(end)))
    return tuple(posed)


def _vector(point: np.ndarray) -> tuple[float, float, float]:
    return float(point[0]), float(point[1]), float(point[2])
