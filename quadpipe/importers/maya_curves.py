"""Maya animation curves (`animCurveTA`, `animCurveTL`, `animCurveTU`), for `--rest-frame`.

    createNode animCurveTA -n "L_Knee_rotateX";
        setAttr -s 3 ".ktv[0:2]"  1 0 12 35.5 24 0;
    connectAttr "L_Knee_rotateX.o" "L_Knee.rx";

A curve's `.ktv` (keyTimeValue) holds (frame, value) pairs, values in the file's units (degrees
or radians as `currentUnit -a` says, lengths in its linear unit). With `rest_frame=N`, the
Maya reader (`quadpipe.importers.maya_ascii`) sets every attribute a curve drives to the
curve's key at frame N: the rest pose is that frame of the animation. Between keys the value
depends on the curve's tangents, which this reader does not evaluate, so N must be a key of
every curve that drives a joint (mocap baked to Maya has a key on every frame).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

from quadpipe.core.errors import Issue, Location

CURVE_TYPES = ("animCurveTA", "animCurveTL", "animCurveTU")
"""Curves of time: to an angle, a length, a plain number."""

KEYS_ATTRIBUTE = re.compile(r"^(?:ktv|keyTimeValue)(?:\[[0-9:]*\])?$")
"""The attribute holding a curve's keys: `.ktv[0:23]`, `.ktv`."""

OUTPUT_PLUGS = {"o", "output"}
"""A curve's output plug."""

SHOWN_CURVES = 5
"""How many curves a message lists before writing '...'."""


@dataclass
class AnimCurve:
    """One animation curve: its keys (frame -> value, file units) and where it is created."""

    name: str
    line: int
    keys: dict[float, float] = field(default_factory=dict)

    def add_keys(self, numbers: list[float]) -> bool:
        """Add (frame, value) pairs; False when the numbers do not pair up."""
        if len(numbers) % 2:
            return False
        self.keys.update(zip(numbers[0::2], numbers[1::2]))
        return True

    def span(self) -> str:
        """Its keyed frames, for messages: `1..24 (24 keys)`."""
        frames = sorted(self.keys)
        if not frames:
            return "no keys"
        return f"{frames[0]:g}..{frames[-1]:g} ({len(frames)} keys)"


def rest_frame_issues(source: str, frame: int, curves: list[AnimCurve], driving: int) -> list[Issue]:
    """Why frame `frame` cannot be taken as the rest pose: no curve drives a joint, or some
    driving curves have no key at that frame (all listed in one issue)."""
    if driving == 0:
        return [
            Issue(
                "no-motion",
                "the file has no animation curve driving its joints, so there is no frame to take as the rest pose",
                Location(source),
                "leave out --rest-frame, or keep the animation in the .ma file (connected animCurve nodes)",
            )
        ]
    unkeyed = [curve for curve in curves if float(frame) not in curve.keys]
    if not unkeyed:
        return []
    shown = ", ".join(f"{curve.name} ({curve.span()})" for curve in unkeyed[:SHOWN_CURVES])
    shown += " ..." if len(unkeyed) > SHOWN_CURVES else ""
    return [
        Issue(
            "rest-frame-out-of-range",
            f"frame {frame} is not a key of {len(unkeyed)} animation curve(s) driving the joints: {shown}",
            Location(source, unkeyed[0].line),
            "pick a frame where every curve has a key (between keys the value depends on tangents "
            "this reader does not evaluate), or bake the animation to keys in Maya",
        )
    ]
