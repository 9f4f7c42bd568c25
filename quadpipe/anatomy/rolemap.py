"""Which joint of a skeleton file plays which role: role maps, and guessing when there is none.

A role map is a small YAML file:

    units: cm          # optional: the file's length unit (BVH declares none)
    up: y              # optional: the file's up axis
    roles:             # joint name (shell glob, case-insensitive) -> role
      Hips: pelvis
      "*:L_UpperLeg": lh_hip
      "*_end": ~       # no role: these joints stay unplaced
      Spine1: [spine0, spine1, spine2]    # a chain: spread over this bone and the ones below
      "*UpperArm": [shoulder, elbow, wrist]   # leg roles without a leg: the joint's side decides

Without a role map, roles written in the file are used (the quadpipe XML format has them);
when the file has none, `guess_roles` (`quadpipe.anatomy.role_guess`) places them from the
joints' names (left/right only) and from the hierarchy and the rest positions (everything
else); `resolve_roles` decides between the three. Chains, leg roles given by side and
synthesised roles are worked out by `quadpipe.anatomy.rig`. See docs/formats.md.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from fnmatch import fnmatchcase
from pathlib import Path
from typing import Annotated, Any

import yaml
from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, field_validator

from quadpipe.anatomy.rig import LEG_KINDS, RoleValue, roles_in
from quadpipe.anatomy.role_guess import RoleGuess, guess_roles
from quadpipe.anatomy.role_names import short_name, unknown_role_hint
from quadpipe.anatomy.roles import PARENT, ROLES
from quadpipe.anatomy.skeleton import UNIT_TO_METRES, UP_AXES, RawSkeleton, check_structure
from quadpipe.core.errors import Issue, Location, QuadpipeError, did_you_mean
from quadpipe.core.yamlio import described_value, load_yaml, validate_document

GLOB_CHARACTERS = "*?["
"""Characters that make a role-map key a pattern rather than a plain name."""

SHOWN_JOINTS = 5
"""How many joint names a message lists before writing '...'."""

# -- role map files -------------------------------------------------------------------------


def _role_entry(value: object) -> object:
    """A role map's value as written, refused in plain words unless it is a role (text), a list
    of roles, or null (checked before pydantic tries each kind, which would report each)."""
    if value is None or isinstance(value, str):
        return value
    if isinstance(value, list) and value and all(isinstance(item, str) for item in value):
        return value
    if isinstance(value, list):
        raise ValueError(f"a chain of roles must be a non-empty list of roles (text), not {described_value(value)}")
    raise ValueError(f"must be text, not {described_value(value)}")


RoleEntry = Annotated[str | list[str] | None, BeforeValidator(_role_entry)]
"""One value of a role map's `roles`: a role, a chain of roles, or null."""


class RoleMapModel(BaseModel):
    """Schema of a role map YAML file."""

    model_config = ConfigDict(extra="forbid")

    units: str | None = Field(None, description="Length unit of the skeleton file: m, cm, mm, in or ft.")
    up: str | None = Field(None, description="Up axis of the skeleton file: y or z.")
    roles: dict[str, RoleEntry] | None = Field(
        None,
        description="Joint name or shell glob (case-insensitive) -> role, or a list of roles spread over the "
        "joint's bone and the unmapped bones below it; a leg role without its leg (`elbow`) takes the "
        "joint's side; null leaves the joint unplaced (an extra bone).",
    )

    @field_validator("units")
    @classmethod
    def _known_unit(cls, value: str | None) -> str | None:
        if value is not None and value not in UNIT_TO_METRES:
            raise ValueError(f"unit {value!r} is unknown; use one of {', '.join(UNIT_TO_METRES)}")
        return value

    @field_validator("up")
    @classmethod
    def _known_up(cls, value: str | None) -> str | None:
        if value is not None and value not in UP_AXES:
            raise ValueError(f"up axis {value!r} is unknown; use one of {', '.join(UP_AXES)}")
        return value


@dataclass(frozen=True)
class RolePattern:
    """One `pattern: role` line of a role map (`role` None leaves matching joints unplaced; a
    tuple is a chain of roles)."""

    pattern: str
    role: RoleValue | None
    where: Location

    @property
    def sided(self) -> bool:
        """Whether its roles include a leg role without its leg, which each joint's side completes."""
        return self.role is not None and any(role in LEG_KINDS for role in roles_in(self.role))

    @property
    def is_glob(self) -> bool:
        """Whether the key is a shell glob rather than a plain joint name."""
        return any(c in self.pattern for c in GLOB_CHARACTERS)

    def matches(self, name: str) -> bool:
        """Case-insensitive match against a joint name, or the name without namespace or DAG path."""
        pattern = self.pattern.casefold()
        candidates = {name.casefold(), short_name(name).casefold()}
        if self.is_glob:
            return any(fnmatchcase(c, pattern) for c in candidates)
        return pattern in candidates


@dataclass(frozen=True)
class RoleMap:
    """A loaded role map; `patterns` is None when the file has no `roles` key."""

    source: str
    units: str | None
    up: str | None
    patterns: tuple[RolePattern, ...] | None


def load_role_map(path: str | Path) -> RoleMap:
    """Read and check a role map YAML file.

    Raises:
        QuadpipeError: YAML or schema errors, and `unknown-role` for every role that is not
            one of the 39, each at its line with a "did you mean" hint.
    """
    doc = load_yaml(path, "role map", RoleMapModel)
    model = validate_document(RoleMapModel, doc)
    patterns = None
    if model.roles is not None:
        patterns = tuple(
            RolePattern(pattern, role if not isinstance(role, list) else tuple(role), doc.locate(("roles", pattern)))
            for pattern, role in model.roles.items()
        )
        _check_roles(patterns)
    return RoleMap(doc.file, model.units, model.up, patterns)


def _check_roles(patterns: Sequence[RolePattern]) -> None:
    issues = [
        Issue(
            "unknown-role",
            f"{role!r} (for {p.pattern!r}) is not a role of the reference hierarchy",
            p.where,
            unknown_role_hint(role),
        )
        for p in patterns
        if p.role is not None
        for role in roles_in(p.role)
        if role not in PARENT and role not in LEG_KINDS
    ]
    if issues:
        raise QuadpipeError(issues)


def apply_role_map(raw: RawSkeleton, role_map: RoleMap) -> tuple[dict[str, RoleValue], tuple[Issue, ...]]:
    """Roles of the joints matched by a role map's patterns.

    A joint takes the role of the pattern that names it exactly (case-insensitive), else of
    the first glob in file order that matches it.

    Returns:
        joint name -> role (or chain of roles), and warnings for patterns that match no joint.

    Raises:
        QuadpipeError: `ambiguous-pattern` when one pattern gives its role to several
            joints (a pattern whose leg roles the side completes may match one joint a side),
            `duplicate-role` when two patterns give the same role.
    """
    patterns = role_map.patterns or ()
    chosen: dict[str, RolePattern] = {}
    for joint in raw.joints:
        exact = [p for p in patterns if not p.is_glob and p.matches(joint.name)]
        pattern = exact[0] if exact else next((p for p in patterns if p.is_glob and p.matches(joint.name)), None)
        if pattern is not None:
            chosen[joint.name] = pattern
    issues = _role_conflicts(chosen)
    if issues:
        raise QuadpipeError(issues)
    used = {id(p) for p in chosen.values()}
    names = [j.name for j in raw.joints]
    warnings = tuple(
        Issue(
            "unused-pattern",
            f"{p.pattern!r} matches no joint of {Path(raw.source).name}",
            p.where,
            did_you_mean(p.pattern, names, listing=False) or None,
            severity="warning",
        )
        for p in patterns
        if id(p) not in used
    )
    return {name: p.role for name, p in chosen.items() if p.role is not None}, warnings


def _role_conflicts(chosen: Mapping[str, RolePattern]) -> list[Issue]:
    by_role: dict[RoleValue, list[tuple[str, RolePattern]]] = {}
    for name, pattern in chosen.items():
        if pattern.role is not None:
            by_role.setdefault(pattern.role, []).append((name, pattern))
    issues = []
    for role, holders in by_role.items():
        if len(holders) < (3 if holders[0][1].sided else 2):
            continue
        (first_name, first), (second_name, second) = holders[0], holders[1]
        if first is second:
            names = ", ".join(repr(n) for n, _ in holders[:SHOWN_JOINTS])
            names += " ..." if len(holders) > SHOWN_JOINTS else ""
            issues.append(
                Issue(
                    "ambiguous-pattern",
                    f"{first.pattern!r} gives role {role} to {len(holders)} joints: {names}",
                    first.where,
                    "make the pattern match one joint (write the full name)",
                )
            )
        else:
            issues.append(
                Issue(
                    "duplicate-role",
                    f"role {role} is given to {first_name!r} "
                    f"(by {first.pattern!r}, line {first.where.line}) "
                    f"and to {second_name!r} (by {second.pattern!r})",
                    second.where,
                    "each role belongs to exactly one joint",
                )
            )
    return issues


# -- putting it together --------------------------------------------------------------------


@dataclass(frozen=True)
class RoleResolution:
    """The result of `resolve_roles`: what `assemble` needs, and warnings for the user.

    Attributes:
        raw: the skeleton with the role map's units and up axis applied (and the file's own
            roles removed when a role map gives roles).
        roles: joint name -> role (or chain of roles), for joints the file gives no role.
        warnings: unused role-map patterns, guessed chains that skipped joints.
        guess: the guess, when roles were guessed.
    """

    raw: RawSkeleton
    roles: dict[str, RoleValue]
    warnings: tuple[Issue, ...] = ()
    guess: RoleGuess | None = None


def resolve_roles(raw: RawSkeleton, role_map: str | Path | None = None) -> RoleResolution:
    """Decide every joint's role: from a role map, else from the file, else by guessing.

    A role map with `roles` replaces the file's own roles; one without `roles` only sets
    units or the up axis. Roles are guessed when neither the map nor the file gives all 39;
    roles the file does give win over guessed ones.

    Raises:
        QuadpipeError: a bad role map; `missing-roles` (with what was guessed) when guessing
            cannot place all 39 roles.
    """
    if role_map is not None:
        loaded = load_role_map(role_map)
        raw = replace(raw, units=loaded.units or raw.units, up=loaded.up or raw.up)
        if loaded.patterns is not None:
            raw = replace(raw, joints=tuple(replace(j, role=None) for j in raw.joints))
            roles, warnings = apply_role_map(raw, loaded)
            return RoleResolution(raw, roles, warnings)
    file_roles = {j.role: j.name for j in raw.joints if j.role}
    if set(ROLES) <= set(file_roles):
        return RoleResolution(raw, {})
    check_structure(raw)
    guess = guess_roles(raw)
    if any(role not in file_roles for role in guess.missing) or guess.problems:
        raise QuadpipeError(guess.issues(raw))
    named = {j.name for j in raw.joints if j.role}
    roles = {name: role for name, role in guess.roles.items() if name not in named and role not in file_roles}
    warnings = tuple(
        Issue(
            "guessed-chain",
            f"roles guessed with joints skipped: {note}",
            raw.where(),
            "check the skipped joints; a role map (--roles) fixes the choice",
            severity="warning",
        )
        for note in guess.skips
    )
    return RoleResolution(raw, roles, warnings, guess)


def role_map_text(
    roles: Mapping[str, str],
    *,
    source: str | None = None,
    missing: Sequence[str] = (),
    units: str | None = None,
    up: str | None = None,
) -> str:
    """A role map YAML document giving `roles` (joint name -> role), in hierarchy order.

    Joint names are escaped so that none of them reads as a glob.
    """
    order = {role: index for index, role in enumerate(ROLES)}
    entries = sorted(roles.items(), key=lambda item: order.get(item[1], len(order)))
    header = [
        f"# Role map{f' for {Path(source).name}' if source else ''}, written by quadpipe.",
        "# Keys are joint names (shell globs, case-insensitive); values are roles (`quadpipe roles`).",
        "# Check it, then pass it with --roles.",
    ]
    if missing:
        header.append(f"# Not placed yet: {', '.join(missing)}")
    data: dict[str, Any] = {}
    if units:
        data["units"] = units
    if up:
        data["up"] = up
    data["roles"] = {_escape_glob(name): role for name, role in entries}
    return "\n".join(header) + "\n" + yaml.safe_dump(data, sort_keys=False, allow_unicode=True, width=1000)


def _escape_glob(name: str) -> str:
    return re.sub(r"([*?\[])", r"[\1]", name)


def write_role_map(path: str | Path, roles: Mapping[str, str], **options: Any) -> None:
    """Write `role_map_text(roles, **options)` to a file (atomically)."""
    from quadpipe.core.atomic import write_text

    write_text(path, role_map_text(roles, **options))
