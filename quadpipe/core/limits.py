"""Limits on everything a user's input can make grow, in one place.

Every input that can ask for unbounded work or memory (a file's size, YAML aliases, nesting,
joints, controller elements, scene props, simulated time) is checked against a named `Limit`
here, before the work starts. Going over one is a `limit-exceeded` error that names the limit,
its value and what to do; where a bigger job is legitimate (a longer run, a bigger crowd) the
limit can be raised with an environment variable, `QUADPIPE_MAX_...`, read in one place
(`Limit.value`).

The module is organised by topic, one section each; add a new limit to its topic's section
(or a new section), with a docstring saying its unit and meaning.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

from quadpipe.core.errors import Location, QuadpipeError


@dataclass(frozen=True)
class Limit:
    """An upper bound on something that can grow.

    Attributes:
        what: what is counted, for messages ("YAML nesting depth").
        default: the bound, in `unit`s.
        unit: the unit of the bound ("bytes", "levels", "joints").
        advice: what to do when the input goes over it.
        env: the environment variable that raises it, or None when it is fixed.
    """

    what: str
    default: float
    unit: str
    advice: str
    env: str | None = None

    @property
    def value(self) -> float:
        """The bound in force: `default`, or the environment variable's value when it is set.

        Raises:
            QuadpipeError: `bad-limit` when the variable is set but not a positive number.
        """
        if self.env is None or not os.environ.get(self.env, "").strip():
            return self.default
        text = os.environ[self.env].strip()
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        if not (math.isfinite(value) and value > 0):
            raise QuadpipeError.single(
                "bad-limit",
                f"{self.env}={text!r} is not a positive number",
                hint=f"set it to a number of {self.unit} (the default is {_amount(self.default)}), or unset it",
            )
        return value

    def message(self, amount: float | None = None) -> str:
        """What went over the limit (`amount`: how much the input asked for, if known)."""
        asked = f" ({_amount(amount)} {self.unit})" if amount is not None else ""
        return f"{self.what} is over the limit of {_amount(self.value)} {self.unit}{asked}"

    @property
    def hint(self) -> str:
        """What to do about it, and how to raise the limit when it can be raised."""
        return self.advice + (f"; or raise the limit with {self.env}=N" if self.env else "")

    def exceeded(self, amount: float | None = None, *, where: Location | None = None) -> QuadpipeError:
        """The error for an input that goes over this limit (`amount`: how much it asked for, if known)."""
        return QuadpipeError.single("limit-exceeded", self.message(amount), where=where, hint=self.hint)

    def check(self, amount: float, *, where: Location | None = None) -> None:
        """Raise `exceeded` when `amount` is over the limit (or not a number at all)."""
        if not amount <= self.value:
            raise self.exceeded(amount, where=where)


def _amount(value: float) -> str:
    """A bound for a message: `10000`, `1.5`, `2e+12`."""
    return f"{value:g}" if not float(value).is_integer() or abs(value) >= 1e15 else str(int(value))


# --------------------------------------------------------------------------- files

MAX_YAML_FILE_BYTES = Limit(
    "the YAML file's size",
    8 * 2**20,
    "bytes",
    "a controller, scene, animal, batch plan or role map is a few kilobytes: is this the right file?",
)
"""Size of a YAML file (controller, scene, animal, batch plan, role map), in bytes; the
largest shipped one is about 30 kB."""

MAX_SKELETON_FILE_BYTES = Limit(
    "the skeleton file's size",
    256 * 2**20,
    "bytes",
    "export only the skeleton (no meshes or animation) to a file of its own",
)
"""Size of a skeleton file (.xml, .ma, .bvh), in bytes: Maya scenes may carry meshes, which
the reader skips, so this is generous."""

MAX_TABLE_FILE_BYTES = Limit(
    "the limits table's size",
    4 * 2**20,
    "bytes",
    "a joint-limit table has one row per bone: is this the right file?",
)
"""Size of a joint-limit table (.tsv, .csv), in bytes."""

# --------------------------------------------------------------------------- YAML

MAX_YAML_ALIASES = Limit(
    "the number of YAML aliases (*name)",
    1_000,
    "aliases",
    "write the repeated parts out, or use a controller's `extends` and `for_each`",
)
"""Alias uses (`*name`) in one YAML document."""

MAX_YAML_NODES = Limit(
    "the YAML document's size with every alias expanded",
    1_000_000,
    "values",
    "aliases that repeat aliases multiply (a 'billion laughs' document): write the parts out",
)
"""Values (mappings, lists and scalars) in one YAML document once every alias is replaced by a
copy of what it names; counted before anything is copied."""

MAX_YAML_DEPTH = Limit(
    "the YAML nesting depth",
    100,
    "levels",
    "no quadpipe file nests more than about ten levels: look for an unclosed '[' or '{'",
)
"""Mappings and lists inside each other, in levels."""

# --------------------------------------------------------------------------- expressions

MAX_EXPRESSION_DEPTH = Limit(
    "the expression's nesting depth",
    100,
    "levels",
    "split the expression into parameters",
)
"""Operations, brackets and calls inside each other in one expression, in levels, counting the
parameters it uses as written out in it."""

MAX_EXPRESSION_LENGTH = Limit(
    "the expression's length",
    10_000,
    "characters",
    "split the expression into parameters",
)
"""Characters in one expression's text, not counting the lists of its tables (`interp`), which
`MAX_TABLE_POINTS` bounds instead: a path of hundreds of points is one short expression."""

MAX_TABLE_POINTS = Limit(
    "the table's size",
    20_000,
    "points",
    "give the table (or the path) fewer points: resample it",
)
"""Points (breakpoints, and as many values) in one table of `interp(x, [x0, ...], [y0, ...])`."""

MAX_TABLE_EXPRESSION_LENGTH = Limit(
    "the expression's length with its tables",
    2_000_000,
    "characters",
    "give its tables fewer points: resample them",
)
"""Characters in one expression's text, its tables included: a bound on the text read before its
tables are measured (about 50 characters a point for the largest tables of `MAX_TABLE_POINTS`)."""

# --------------------------------------------------------------------------- skeletons

MAX_JOINTS = Limit(
    "the number of joints",
    2_000,
    "joints",
    "the reference hierarchy needs 39 bones: export only the skeleton's joints (no helpers or props)",
)
"""Joints in one skeleton file; real rigs have a few hundred."""

# --------------------------------------------------------------------------- controllers

MAX_ELEMENTS = Limit(
    "the number of controller elements",
    2_000,
    "elements",
    "the shipped controllers have fewer than 100; merge elements with `for_each` and `sites`",
)
"""Elements of one controller (after `extends` and `for_each`)."""

MAX_PARAMETERS = Limit(
    "the number of controller parameters",
    2_000,
    "parameters",
    "the shipped controllers have fewer than 100",
)
"""Parameters and tunables of one controller (after `extends`)."""

# --------------------------------------------------------------------------- physical sanity


@dataclass(frozen=True)
class SaneRange:
    """The sane values of a physical quantity: finite, from `low` to `high` (inclusive).

    Numbers outside it are not physics quadpipe can simulate (a 1e308 kg dog, a NaN joint
    limit, a hill a million pelvis heights high) even when the file's syntax is right.

    Attributes:
        what: the quantity, for messages ("a body mass").
        low: the smallest sane value, in `unit`s.
        high: the largest sane value, in `unit`s.
        unit: the unit of `low`, `high` and the values checked ("kg").
    """

    what: str
    low: float
    high: float
    unit: str

    def problem(self, value: float) -> str | None:
        """What is wrong with `value` (None: it is sane)."""
        if not math.isfinite(value):
            return f"{value} is not a finite number"
        if not self.low <= value <= self.high:
            return f"{value:g} {self.unit} is not a sane value for {self.what}"
        return None

    @property
    def hint(self) -> str:
        """The valid range, for a hint."""
        return f"{self.what} must be a finite number from {self.low:g} to {self.high:g} {self.unit}"

    def check(self, value: float, name: str, *, where: Location | None = None) -> float:
        """`value` when it is sane; otherwise an `out-of-range` error about `name` (the key or option)."""
        problem = self.problem(value)
        if problem is not None:
            raise QuadpipeError.single("out-of-range", f"{name}: {problem}", where=where, hint=self.hint)
        return value


BODY_MASS_KG = SaneRange("a body mass", 0.001, 20_000.0, "kg")
"""An animal's (or a prop's) mass: from a gram (a shrew weighs 2 g) to 20 tonnes (an elephant
weighs 6)."""

PELVIS_HEIGHT_CM = SaneRange("a pelvis height (HP)", 0.1, 1_000.0, "cm")
"""An animal config's `pelvis_height_cm`: from a millimetre to 10 metres."""

TWIST_LIMIT_DEG = SaneRange("a twist limit", -180.0, 180.0, "deg")
"""A joint's twist minimum or maximum in a limits table: at most half a turn either way."""

SWING_LIMIT_DEG = SaneRange("a swing limit", 0.0, 180.0, "deg")
"""A joint's swing half-range in a limits table: 0 (no such freedom) to half a turn."""

SKELETON_COORDINATE_M = SaneRange("a skeleton coordinate", -1_000.0, 1_000.0, "m")
"""A joint's position or end in a skeleton file, in metres once its units are applied: a
kilometre from the origin is a unit mistake, not an animal."""

FAR_AWAY_HP = 1000.0
"""A body farther than this many pelvis heights from the origin has been flung away: a blow-up."""

SCENE_EXTENT_HP = SaneRange("a scene length", -FAR_AWAY_HP, FAR_AWAY_HP, "HP")
"""A scene's positions, sizes and heights, in pelvis heights of its first animal: a body
farther than `FAR_AWAY_HP` from the origin counts as flung away (a blow-up)."""

MAX_FPS = 10_000.0
"""Recorded frames per second: no physics rate quadpipe uses is higher."""

# --------------------------------------------------------------------------- scenes

MAX_PROPS = Limit(
    "the number of props in the scene",
    1_000,
    "props",
    "every prop is a body MuJoCo simulates: use terrain for large static shapes",
)
"""Props of one scene (after grids are expanded)."""

MAX_TERRAIN_PIECES = Limit(
    "the number of terrain pieces in the scene",
    10_000,
    "pieces",
    "every piece (a stairs step, a ramp, a block) is a box MuJoCo collides with: use fewer, deeper steps",
    env="QUADPIPE_MAX_TERRAIN_PIECES",
)
"""Boxes the terrain of one scene is built from (stairs: one a step and the landing)."""

MAX_SET_TRIANGLES = Limit(
    "the number of triangles in a set file",
    200_000,
    "triangles",
    "decimate the set (a walkable ground needs a few thousand triangles: the height field samples it anyway)",
    env="QUADPIPE_MAX_SET_TRIANGLES",
)
"""Triangles of one mesh set (`terrain: [{type: mesh}]`), read and sampled into a height field."""

MAX_THROWS = Limit(
    "the number of throws in the scene",
    1_000,
    "throws",
    "every throw is a body MuJoCo simulates",
)
"""Throws of one scene (after repeats are expanded)."""

MAX_ANIMALS = Limit(
    "the number of animals in the scene",
    100,
    "animals",
    "simulate fewer animals at once (a batch runs many scenes in parallel)",
    env="QUADPIPE_MAX_ANIMALS",
)
"""Animals in one scene: each is ~40 bodies, and memory and time grow with their number."""

# --------------------------------------------------------------------------- runs

MAX_SIMULATED_SECONDS = Limit(
    "the simulated time",
    3_600,
    "seconds",
    "simulate a shorter time",
    env="QUADPIPE_MAX_SECONDS",
)
"""Simulated time of one run, in seconds (an hour takes hours of computing)."""

MAX_FRAMES = Limit(
    "the number of recorded frames",
    1_000_000,
    "frames",
    "record fewer frames: a shorter time or a lower --fps",
    env="QUADPIPE_MAX_FRAMES",
)
"""Frames of one clip (seconds x fps): the clip is held in memory, ~10 kB a frame per animal."""

MAX_WORKERS = Limit(
    "the number of worker processes",
    256,
    "workers",
    "each worker holds a simulation in memory: one per CPU core is the default and usually fastest",
    env="QUADPIPE_MAX_WORKERS",
)
"""`quadpipe batch --workers` on one machine."""


def check_run(seconds: float, fps: float, *, names: tuple[str, str] = ("seconds", "fps")) -> int:
    """The frames of a recording of `seconds` at `fps` (the start counts as frame 0), checked
    against the run limits before anything is built.

    Args:
        seconds: simulated time, seconds.
        fps: recorded frames per second.
        names: how the messages name the two values (`--seconds`, `--fps` on the command line).

    Raises:
        QuadpipeError: `out-of-range` for a time that is negative or not finite, `bad-fps` for a
            frame rate that is not a positive finite number up to `MAX_FPS`, `limit-exceeded`
            over `MAX_SIMULATED_SECONDS` or `MAX_FRAMES`.
    """
    seconds_name, fps_name = names
    if not (math.isfinite(seconds) and seconds >= 0):
        raise QuadpipeError.single(
            "out-of-range",
            f"{seconds_name}: {seconds:g} is not a simulated time",
            hint=f"give a number of seconds from 0 to {_amount(MAX_SIMULATED_SECONDS.value)}",
        )
    MAX_SIMULATED_SECONDS.check(seconds)
    if not (math.isfinite(fps) and 0 < fps <= MAX_FPS):
        raise QuadpipeError.single(
            "bad-fps",
            f"{fps_name}: {fps:g} is not a frame rate",
            hint=f"give a positive number of frames per second, at most {_amount(MAX_FPS)} (30 is the thesis's)",
        )
    frames = round(seconds * fps)
    MAX_FRAMES.check(frames)
    return frames
