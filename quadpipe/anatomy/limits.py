"""Joint limits by role: the thesis's table (§3.2, Fig. 9), format-free.

A limits table has rows keyed by a bone name. A row applies to a role when its key is, in
order of precedence:

1. the role itself (`lf_elbow`): one bone of one leg;
2. the role without its leg prefix (`elbow`, `neck0`): that bone on every leg;
3. a group: the role's kind without its index, optionally plural (`tails`, `spines`, `necks`,
   `hpha`, `fpha`): every bone of that group not matched by 1 or 2.

All angles are stored in radians. `twist` turns about the joint's main axis; the swings are
symmetric (`-swing..+swing`) about the two axes across it: swing1 about the body's forward
axis, swing2 about the vertical (thesis: "swing1 usually along the spine, swing2 vertical").
A swing of 0 means no such degree of freedom.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable
from dataclasses import dataclass

from quadpipe.anatomy.roles import PARENT, ROLES, kind_of
from quadpipe.core.errors import Location, QuadpipeError, did_you_mean
from quadpipe.core.limits import SWING_LIMIT_DEG, TWIST_LIMIT_DEG

JOINTED_ROLES: tuple[str, ...] = tuple(role for role in ROLES if PARENT[role] is not None)
"""Every role but the pelvis (the free-floating root) has a joint to its parent."""


def _row_keys_of(role: str) -> tuple[str, ...]:
    """The row keys that apply to `role`, most precise first (see module docstring)."""
    kind = kind_of(role)
    base = re.sub(r"\d+$", "", kind)
    return (role, kind, base, base + "s")


ROW_KEYS: frozenset[str] = frozenset(key for role in JOINTED_ROLES for key in _row_keys_of(role))
"""Every row key that applies to some role: a row keyed otherwise is never used."""


def check_row_key(key: str, where: Location) -> None:
    """Refuse a row key that applies to no role (a misspelt bone: `kneee`).

    Raises:
        QuadpipeError: `unknown-bone` at the row.
    """
    if key not in ROW_KEYS:
        raise QuadpipeError.single(
            "unknown-bone",
            f"no bone is called {key!r}: this row would apply to none",
            where=where,
            hint=did_you_mean(key, sorted(ROW_KEYS), listing=False)
            or "key a row by a role (lf_elbow), a bone on every leg (elbow) or a group (spines)",
        )


@dataclass(frozen=True)
class JointLimit:
    """Limits of one joint, in radians."""

    twist_min: float
    twist_max: float
    swing1: float
    swing2: float
    where: Location | None = None

    @property
    def dof(self) -> int:
        """Degrees of freedom: the twist hinge plus each non-zero swing."""
        return 1 + (self.swing1 > 0) + (self.swing2 > 0)


@dataclass(frozen=True)
class JointLimits:
    """A limits table: row key -> `JointLimit`, and the file it came from."""

    rows: dict[str, JointLimit]
    source: str = "<limits>"

    def row_for(self, role: str) -> str | None:
        """The key of the row that applies to `role` (see module docstring), or None."""
        for key in _row_keys_of(role):
            if key in self.rows:
                return key
        return None

    def for_role(self, role: str) -> JointLimit:
        """Limits for one role; a missing row is a `QuadpipeError`."""
        key = self.row_for(role)
        if key is None:
            raise self._missing([role])
        return self.rows[key]

    def resolve(self, roles: Iterable[str] = JOINTED_ROLES) -> dict[str, JointLimit]:
        """Limits for every given role, reporting all missing rows at once (one per kind)."""
        roles = list(roles)
        missing = [role for role in roles if self.row_for(role) is None]
        if missing:
            kinds = dict.fromkeys(kind_of(role) for role in missing)
            raise QuadpipeError([self._missing([r for r in missing if kind_of(r) == k]).issues[0] for k in kinds])
        return {role: self.for_role(role) for role in roles}

    def _missing(self, roles: list[str]) -> QuadpipeError:
        kind = kind_of(roles[0])
        group = re.sub(r"\d+$", "", kind)
        return QuadpipeError.single(
            "missing-limits",
            f"the limits table has no row for {kind!r} (role{'s' if len(roles) > 1 else ''} {', '.join(roles)})",
            file=self.source,
            hint=f"add a row {kind!r} (or a group row {group + 's'!r}) with twist min/max and swings",
        )


def from_degrees(
    twist_min: float, twist_max: float, swing1: float, swing2: float, where: Location | None = None
) -> JointLimit:
    """Build a `JointLimit` from the table's degrees, checking the values make sense.

    Raises:
        QuadpipeError: `out-of-range` for a limit that is not finite or beyond half a turn,
            `bad-limits` for a twist min above its max or a negative swing.
    """
    for name, value in (("twist min", twist_min), ("twist max", twist_max)):
        TWIST_LIMIT_DEG.check(value, name, where=where)
    if swing1 < 0 or swing2 < 0:
        raise QuadpipeError.single(
            "bad-limits",
            "swings are symmetric half-ranges and cannot be negative",
            where=where,
            hint="write e.g. 10 for -10..+10",
        )
    for name, value in (("swing1", swing1), ("swing2", swing2)):
        SWING_LIMIT_DEG.check(value, name, where=where)
    if twist_min > twist_max:
        raise QuadpipeError.single(
            "bad-limits", f"twist min {twist_min} is above twist max {twist_max}", where=where, hint="swap them"
        )
    return JointLimit(
        math.radians(twist_min), math.radians(twist_max), math.radians(swing1), math.radians(swing2), where
    )
