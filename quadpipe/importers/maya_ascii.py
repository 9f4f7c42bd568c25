"""Maya ASCII (`.ma`) skeletons: joints and the group transforms above them.

A `.ma` file is a MEL script (split into statements by `quadpipe.importers.maya_mel`). This
reader runs the few commands that build a skeleton and skips the rest:

    currentUnit -l centimeter -a degree -t film;
    createNode transform -n "dog_grp";
        setAttr ".t" -type "double3" 25 0 -40 ;
    createNode joint -n "Pelvis" -p "dog_grp";
        setAttr ".t" -type "double3" 0 65.56 0 ;
        setAttr ".jo" -type "double3" 0 -90 0 ;
    connectAttr "Pelvis.s" "Spine1.is";

World positions follow Maya's own matrices (row vectors, `p' = p * M`; Maya node docs):

- joint:     [S] [RA] [R] [JO] [IS] [T]
- transform: [SP]^-1 [S] [SH] [SP] [ST] [RP]^-1 [RA] [R] [RP] [RT] [T]

with `R` in the node's rotate order, `RA` (rotate axis) and `JO` (joint orient) in xyz order,
and `IS` the inverse of the scale connected to the joint's `.is` (segment scale compensate).
A joint's main axis is its world-space local Z axis (Maya's bend axis for joints oriented
"xyz, y up"). Joints without children come back as ordinary joints: `assemble` takes a leaf
bone's end from its single child.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from quadpipe.anatomy.skeleton import JointRecord, RawSkeleton
from quadpipe.core import limits
from quadpipe.core.errors import Issue, Location, QuadpipeError, did_you_mean
from quadpipe.core.textfiles import read_text
from quadpipe.importers.maya_matrices import euler_matrix, scale_matrix, shear_matrix, translation_matrix
from quadpipe.importers.maya_mel import MelScript, Token, flag_values, strip_type_flag

MAYA_HEADER = "//Maya"
"""Maya refuses `.ma` files that do not start with these six characters."""

LINEAR_UNITS: dict[str, tuple[str, float]] = {
    "mm": ("mm", 1.0),
    "millimeter": ("mm", 1.0),
    "cm": ("cm", 1.0),
    "centimeter": ("cm", 1.0),
    "m": ("m", 1.0),
    "meter": ("m", 1.0),
    "in": ("in", 1.0),
    "inch": ("in", 1.0),
    "ft": ("ft", 1.0),
    "foot": ("ft", 1.0),
    "yd": ("m", 0.9144),
    "yard": ("m", 0.9144),
    "km": ("m", 1000.0),
    "kilometer": ("m", 1000.0),
    "mi": ("m", 1609.344),
    "mile": ("m", 1609.344),
}
"""Maya's linear unit names -> (quadpipe unit, factor that turns file values into it)."""

ANGULAR_UNITS: dict[str, float] = {"deg": math.pi / 180.0, "degree": math.pi / 180.0, "rad": 1.0, "radian": 1.0}
"""Maya's angular unit names -> radians per unit."""

ROTATE_ORDERS = ("xyz", "yzx", "zxy", "xzy", "yxz", "zyx")
"""Values of the `rotateOrder` enum, in Maya's numbering."""

TRACKED_TYPES = ("joint", "transform")
"""Node types that make up the skeleton's DAG; every other node is skipped."""

CONSTRAINT_TYPES = ("parentConstraint", "pointConstraint")
"""Constraints this reader evaluates (with one target): they place the joint they drive, by
the target's world matrix and the `.tg[0].tot`/`.tg[0].tor` offset (parent), or its world
position and the `.o` offset (point)."""

CONSTRAINT_OUTPUTS = {"ct", "ctx", "cty", "ctz", "cr", "crx", "cry", "crz"}
"""A constraint's output plugs (constraintTranslate, constraintRotate)."""

TARGET_PLUG = re.compile(r"^(?:tg|target)\[(\d+)\]\.")
"""A constraint's input plug from its target `index`: `tg[0].tt`, `tg[0].tpm`, ..."""

_VECTORS = {
    "t": "translate",
    "r": "rotate",
    "s": "scale",
    "jo": "jointOrient",
    "ra": "rotateAxis",
    "rp": "rotatePivot",
    "sp": "scalePivot",
    "rpt": "rotatePivotTranslate",
    "spt": "scalePivotTranslate",
    "tg[0].tot": "tg[0].targetOffsetTranslate",
    "tg[0].tor": "tg[0].targetOffsetRotate",
    "o": "offset",
}
_SHEAR_PARTS = {"shxy": "shearXY", "shxz": "shearXZ", "shyz": "shearYZ"}
ANGULAR_ATTRIBUTES = {"r", "jo", "ra", "tg[0].tor"}
"""Vector attributes holding angles (in the file's angular unit)."""

ONE_VECTORS = {"s"}
"""Vector attributes whose default is (1, 1, 1) rather than zero."""

CURRENT_UNIT_FLAGS = {"-l", "-linear", "-a", "-angle", "-t", "-time", "-ua", "-updateAnimation"}
"""Flags of `currentUnit` that take a value."""


def _attribute_table() -> dict[str, tuple[str, int | None]]:
    """Short and long attribute names -> (vector attribute, component index or None)."""
    table: dict[str, tuple[str, int | None]] = {}
    for short, long in _VECTORS.items():
        table[short] = table[long] = (short, None)
        for index, axis in enumerate("xyz"):
            table[short + axis] = table[long + axis.upper()] = (short, index)
    table["sh"] = table["shear"] = ("sh", None)
    for index, (short, long) in enumerate(_SHEAR_PARTS.items()):
        table[short] = table[long] = ("sh", index)
    return table


ATTRIBUTES = _attribute_table()
ROTATE_ORDER_NAMES = {"ro", "rotateOrder"}
SSC_NAMES = {"ssc", "segmentScaleCompensate"}
SCALE_NAMES = {"s", "scale"}
INVERSE_SCALE_NAMES = {"is", "inverseScale"}


@dataclass
class _Node:
    """A joint or transform with the attributes that place it."""

    name: str
    kind: str
    parent: _Node | None
    line: int
    values: dict[str, list[float]] = field(default_factory=dict)
    rotate_order: str = "xyz"
    scale_compensate: bool = True
    scale_source: _Node | None = None

    @property
    def path(self) -> str:
        """Full DAG path, `|group|joint`."""
        names = []
        node: _Node | None = self
        while node is not None:
            names.append(node.name)
            node = node.parent
        return "|" + "|".join(reversed(names))

    def vector(self, key: str) -> np.ndarray:
        """An attribute's three values, or its default."""
        default = [1.0, 1.0, 1.0] if key in ONE_VECTORS else [0.0, 0.0, 0.0]
        return np.asarray(self.values.get(key, default), dtype=float)


class _Reader(MelScript):
    """Runs the skeleton-building commands of one `.ma` file."""

    def __init__(self, source: str, text: str) -> None:
        super().__init__(source, text)
        self.nodes: list[_Node] = []
        self.nodes_named: dict[str, list[_Node]] = {}
        self.joint_count = 0
        self.current: _Node | None = None
        self.unit = "cm"
        self.unit_factor = 1.0
        self.radians_per_unit = ANGULAR_UNITS["degree"]
        self.linear_set_at: int | None = None
        self.connections: list[tuple[Token, Token]] = []
        self.commands: dict[str, Callable[[list[Token]], None]] = {
            "createNode": self.create_node,
            "setAttr": self.set_attr,
            "connectAttr": self.connect_attr,
            "currentUnit": self.current_unit,
            "select": self.select,
            "parent": self.parent_command,
        }

    def ignorable(self, pending: list[Token]) -> bool:
        """Whether a statement begun with these tokens cannot matter to the skeleton."""
        command = pending[0].text
        if command not in self.commands:
            return True
        last = pending[-1]
        if command != "setAttr" or not last.quoted or any(t.quoted for t in pending[1:-1]):
            return False  # only setAttr's attribute (its first string) can tell
        node_ref, _, attr = last.text.partition(".")
        known = attr in ATTRIBUTES or attr in ROTATE_ORDER_NAMES or attr in SSC_NAMES
        return not known or (not node_ref and self.current is None)

    # -- commands -------------------------------------------------------------------------

    def run(self) -> None:
        for statement in self.statements():
            self.commands[statement[0].text](statement)

    def current_unit(self, statement: list[Token]) -> None:
        for flag, value in flag_values(statement, CURRENT_UNIT_FLAGS):
            if flag.text in ("-l", "-linear"):
                self.set_linear_unit(value)
            elif flag.text in ("-a", "-angle"):
                if value.text not in ANGULAR_UNITS:
                    self.fail(value, "ma-bad-units", f"angular unit {value.text!r} is unknown", "use degree or radian")
                self.radians_per_unit = ANGULAR_UNITS[value.text]

    def set_linear_unit(self, value: Token) -> None:
        if value.text not in LINEAR_UNITS:
            self.fail(
                value, "ma-bad-units", f"linear unit {value.text!r} is unknown", did_you_mean(value.text, LINEAR_UNITS)
            )
        unit, factor = LINEAR_UNITS[value.text]
        if self.linear_set_at is not None and (unit, factor) != (self.unit, self.unit_factor):
            self.fail(
                value,
                "ma-mixed-units",
                f"the linear unit changes to {value.text!r} after lengths were set (line {self.linear_set_at})",
                "keep one currentUnit statement at the top of the file",
            )
        self.unit, self.unit_factor = unit, factor

    def create_node(self, statement: list[Token]) -> None:
        flags = dict(flag_values(statement, {"-n", "-name", "-p", "-parent"}))
        kind = next((t.text for t in statement[1:] if not t.text.startswith("-") and t not in flags.values()), None)
        name = next((v for f, v in flags.items() if f.text in ("-n", "-name")), None)
        parent_ref = next((v for f, v in flags.items() if f.text in ("-p", "-parent")), None)
        if kind not in TRACKED_TYPES + CONSTRAINT_TYPES:
            self.current = None
            return
        if name is None:
            self.fail(
                statement[0],
                "ma-syntax",
                f"createNode {kind} without a -n name",
                'name the node: createNode joint -n "L_Hip";',
            )
        parent = self.resolve(parent_ref, what="parent") if parent_ref is not None else None
        node = _Node(name.text, kind, parent, statement[0].line)
        if kind == "joint":
            self.joint_count += 1
            if self.joint_count > limits.MAX_JOINTS.value:
                raise limits.MAX_JOINTS.exceeded(where=Location(self.source, name.line, name.column))
        self.nodes.append(node)
        self.nodes_named.setdefault(node.name, []).append(node)
        self.current = node

    def select(self, statement: list[Token]) -> None:
        names = [t for t in statement[1:] if not t.text.startswith("-")]
        self.current = self.find(names[-1].text) if names else None

    def set_attr(self, statement: list[Token]) -> None:
        attr_index = next((i for i, t in enumerate(statement) if t.quoted), None)
        if attr_index is None:
            return
        target_token = statement[attr_index]
        node_ref, _, attr = target_token.text.partition(".")
        node = self.current if not node_ref else self.find(node_ref)
        if node is None:
            return
        values = strip_type_flag(statement[attr_index + 1 :])
        if not values:
            return  # `setAttr -l on ".tx";`, `setAttr -av ".rx";`: flags only, the value stays
        if attr in ATTRIBUTES:
            self.set_vector(node, target_token, attr, values)
        elif attr in ROTATE_ORDER_NAMES:
            number = self.number(self.one_value(target_token, values))
            if number not in range(len(ROTATE_ORDERS)):
                self.fail(
                    values[0],
                    "ma-bad-value",
                    f"rotate order {values[0].text} is not 0-5",
                    "0 xyz, 1 yzx, 2 zxy, 3 xzy, 4 yxz, 5 zyx",
                )
            node.rotate_order = ROTATE_ORDERS[int(number)]
        elif attr in SSC_NAMES:
            node.scale_compensate = self.boolean(self.one_value(target_token, values))

    def set_vector(self, node: _Node, target: Token, attr: str, values: list[Token]) -> None:
        key, component = ATTRIBUTES[attr]
        wanted = 1 if component is not None else 3
        if len(values) != wanted:
            self.fail(
                values[0] if values else target,
                "ma-bad-value",
                f"'.{attr}' takes {wanted} number(s), found {len(values)}",
                f'write it as setAttr ".{attr}"' + (' -type "double3" x y z;' if wanted == 3 else " value;"),
            )
        scale = self.radians_per_unit if key in ANGULAR_ATTRIBUTES else 1.0
        numbers = [self.number(v) * scale for v in values]
        if key == "s" and 0.0 in numbers:
            self.fail(
                values[numbers.index(0.0)],
                "ma-zero-scale",
                f"{node.name!r} is scaled by 0, which collapses it and every joint under it to a point",
                "give the node a non-zero scale (1 1 1) in Maya, or freeze its transformations, and export again",
            )
        current = list(node.vector(key))
        if component is None:
            current = numbers
        else:
            current[component] = numbers[0]
        node.values[key] = current
        if key not in ANGULAR_ATTRIBUTES and key not in ("s", "sh"):
            self.linear_set_at = self.linear_set_at or target.line

    def connect_attr(self, statement: list[Token]) -> None:
        plugs = [t for t in statement[1:] if t.quoted]
        if len(plugs) >= 2:
            self.connections.append((plugs[0], plugs[1]))

    def parent_command(self, statement: list[Token]) -> None:
        names = [t for t in statement[1:] if not t.text.startswith("-")]
        for child in names[:-1]:
            if self.find(child.text) is not None:
                self.fail(
                    child,
                    "ma-unsupported-command",
                    f"'parent' moves {child.text!r} after it was created; this reader does not follow that",
                    "create the node under its parent with createNode -p (re-save the file from Maya)",
                )

    # -- node names -----------------------------------------------------------------------

    def find(self, ref: str) -> _Node | None:
        """The tracked node a name or DAG path refers to (None if untracked or ambiguous)."""
        matches = self.matches(ref)
        return matches[0] if len(matches) == 1 else None

    def matches(self, ref: str) -> list[_Node]:
        """The tracked nodes a name, a partial DAG path (`a|b`) or a full one (`|a|b`) names."""
        named = self.nodes_named.get(ref.rsplit("|", 1)[-1], [])
        if ref.startswith("|"):
            return [n for n in named if n.path == ref]
        if "|" in ref:
            return [n for n in named if n.path.endswith("|" + ref)]
        return list(named)

    def resolve(self, token: Token, *, what: str) -> _Node:
        matches = self.matches(token.text)
        if not matches:
            self.fail(
                token,
                "ma-unknown-parent",
                f"{what} {token.text!r} is not a joint or transform created earlier in the file",
                did_you_mean(token.text.rsplit("|", 1)[-1], {n.name for n in self.nodes}, listing=False)
                or "create the parent before its children",
            )
        if len(matches) > 1:
            paths = ", ".join(n.path for n in matches)
            self.fail(
                token, "ma-ambiguous-name", f"{what} {token.text!r} could be any of {paths}", "name it by its DAG path"
            )
        return matches[0]

    def link_inverse_scales(self) -> None:
        for source, target in self.connections:
            source_ref, _, source_attr = source.text.rpartition(".")
            target_ref, _, target_attr = target.text.rpartition(".")
            if source_attr in SCALE_NAMES and target_attr in INVERSE_SCALE_NAMES:
                node = self.find(target_ref)
                if node is not None:
                    node.scale_source = self.find(source_ref)

    # -- result ---------------------------------------------------------------------------

    def link_drivers(self) -> _Drivers:
        """Direct connections copied into the attributes they drive, and the constraints that
        place nodes; what cannot be evaluated is listed."""
        drivers = _Drivers()
        for source, target in self.connections:
            source_ref, _, source_attr = source.text.partition(".")
            target_ref, _, target_attr = target.text.partition(".")
            source_node, target_node = self.find(source_ref), self.find(target_ref)
            if target_node is None:
                continue
            if target_node.kind in CONSTRAINT_TYPES:
                index = TARGET_PLUG.match(target_attr)
                if index is not None and source_node is not None and source_node.kind in TRACKED_TYPES:
                    drivers.targets.setdefault(id(target_node), {})[int(index.group(1))] = source_node
                continue
            if target_attr not in ATTRIBUTES or target_node.kind not in TRACKED_TYPES:
                continue
            if source_node is not None and source_node.kind in CONSTRAINT_TYPES and source_attr in CONSTRAINT_OUTPUTS:
                drivers.constrained[id(target_node)] = source_node
            elif (
                source_node is not None
                and source_attr in ATTRIBUTES
                and _copy(source_node, source_attr, target_node, target_attr)
            ):
                continue
            else:
                drivers.unevaluated.append(f"{target.text} (from {source.text})")
        return drivers

    def skeleton(self, name: str) -> RawSkeleton:
        self.link_inverse_scales()
        drivers = self.link_drivers()
        worlds = {id(node): drivers.world(node) for node in self.nodes}
        joints = [n for n in self.nodes if n.kind == "joint"]
        names = _unique_names(joints)
        records = []
        for joint in joints:
            world = worlds[id(joint)]
            ancestor = joint.parent
            while ancestor is not None and ancestor.kind != "joint":
                ancestor = ancestor.parent
            z_axis = world[2, :3]
            norm = float(np.linalg.norm(z_axis))
            records.append(
                JointRecord(
                    name=names[id(joint)],
                    parent=names[id(ancestor)] if ancestor else None,
                    position=tuple(float(v) * self.unit_factor for v in world[3, :3]),  # type: ignore[arg-type]
                    axis=tuple(float(v) / norm for v in z_axis) if norm > 1e-12 else None,  # type: ignore[arg-type]
                    line=joint.line,
                )
            )
        if not records:
            raise QuadpipeError.single(
                "empty-skeleton",
                "the file creates no joint nodes",
                file=self.source,
                hint='a skeleton is made of createNode joint -n "..." statements',
            )
        return RawSkeleton(
            name=name,
            source=self.source,
            joints=tuple(records),
            units=self.unit,
            up="y",
            warnings=drivers.warnings(self.source),
        )


def _copy(source: _Node, source_attr: str, target: _Node, target_attr: str) -> bool:
    """Copy a connected attribute's value (`ctrl.t` -> `joint.t`, `ctrl.ry` -> `joint.rx`);
    False when the plugs do not have the same shape (a vector into one component)."""
    source_key, source_index = ATTRIBUTES[source_attr]
    target_key, target_index = ATTRIBUTES[target_attr]
    if (source_index is None) != (target_index is None):
        return False
    value = source.vector(source_key)
    current = list(target.vector(target_key))
    if target_index is None:
        current = list(value)
    else:
        current[target_index] = float(value[source_index])
    target.values[target_key] = current
    return True


@dataclass
class _Drivers:
    """Constraints placing nodes, their targets, and the driven plugs that stay as saved."""

    constrained: dict[int, _Node] = field(default_factory=dict)
    targets: dict[int, dict[int, _Node]] = field(default_factory=dict)
    unevaluated: list[str] = field(default_factory=list)
    worlds: dict[int, np.ndarray] = field(default_factory=dict)
    evaluating: set[int] = field(default_factory=set)

    def world(self, node: _Node) -> np.ndarray:
        """A node's world matrix: its parent's times its own, or what its constraint gives."""
        if id(node) in self.worlds:
            return self.worlds[id(node)]
        self.evaluating.add(id(node))
        parent_world = self.world(node.parent) if node.parent else np.eye(4)
        world = local_matrix(node) @ parent_world
        constraint = self.constrained.get(id(node))
        if constraint is not None:
            world = self.constrain(node, constraint, world)
        self.evaluating.discard(id(node))
        self.worlds[id(node)] = world
        return world

    def constrain(self, node: _Node, constraint: _Node, world: np.ndarray) -> np.ndarray:
        """`world` as the constraint changes it (unchanged, and listed, when it cannot be evaluated)."""
        targets = self.targets.get(id(constraint), {})
        target = targets.get(0)
        if len(targets) != 1 or target is None or id(target) in self.evaluating:
            why = f"{len(targets)} targets" if len(targets) != 1 else "its target depends on the node itself"
            self.unevaluated.append(f"{node.name} (by {constraint.kind} {constraint.name!r}: {why})")
            return world
        target_world = self.world(target)
        if constraint.kind == "parentConstraint":
            offset = euler_matrix(constraint.vector("tg[0].tor")) @ translation_matrix(constraint.vector("tg[0].tot"))
            return offset @ target_world
        placed = world.copy()
        placed[3, :3] = target_world[3, :3] + constraint.vector("o")
        return placed

    def warnings(self, source: str) -> tuple[Issue, ...]:
        """One warning naming every driven plug read at its saved value."""
        if not self.unevaluated:
            return ()
        shown = "; ".join(self.unevaluated[:8]) + (" ..." if len(self.unevaluated) > 8 else "")
        return (
            Issue(
                "ma-driven-joints",
                f"{len(self.unevaluated)} plug(s) driven by nodes this reader does not evaluate, read as saved: {shown}",
                Location(source),
                "bake the rig's pose into the joints in Maya (or delete those constraints/curves) if it looks wrong",
                severity="warning",
            ),
        )


def _unique_names(joints: list[_Node]) -> dict[int, str]:
    """Short names where they are unique among joints, full DAG paths where they are not."""
    counts: dict[str, int] = {}
    for joint in joints:
        counts[joint.name] = counts.get(joint.name, 0) + 1
    return {id(j): j.name if counts[j.name] == 1 else j.path for j in joints}


def local_matrix(node: _Node) -> np.ndarray:
    """A node's matrix relative to its parent, by Maya's formula for joints or transforms."""
    rotate_axis = euler_matrix(node.vector("ra"))
    rotate = euler_matrix(node.vector("r"), node.rotate_order)
    scale = scale_matrix(node.vector("s"))
    translate = translation_matrix(node.vector("t"))
    if node.kind == "joint":
        inverse_scale = np.eye(4)
        if node.scale_compensate and node.scale_source is not None:
            inverse_scale = np.linalg.inv(scale_matrix(node.scale_source.vector("s")))
        return scale @ rotate_axis @ rotate @ euler_matrix(node.vector("jo")) @ inverse_scale @ translate
    scale_pivot = translation_matrix(node.vector("sp"))
    rotate_pivot = translation_matrix(node.vector("rp"))
    return (
        np.linalg.inv(scale_pivot)
        @ scale
        @ shear_matrix(node.vector("sh"))
        @ scale_pivot
        @ translation_matrix(node.vector("spt"))
        @ np.linalg.inv(rotate_pivot)
        @ rotate_axis
        @ rotate
        @ rotate_pivot
        @ translation_matrix(node.vector("rpt"))
        @ translate
    )


def read_skeleton(path: str | Path) -> RawSkeleton:
    """Read the joints of a Maya ASCII file, with world positions and main axes.

    Raises:
        QuadpipeError: not a Maya ASCII file, a cut-off file, an unterminated string, a bad
            number or value, an unknown or ambiguous parent, an unknown unit.
    """
    path = Path(path)
    text = read_text(path, limits.MAX_SKELETON_FILE_BYTES)
    reader = _Reader(str(path), text)
    if not text.startswith(MAYA_HEADER):
        reader.fail(
            Token("", False, 1, 1),
            "ma-not-maya-ascii",
            f"the file does not start with {MAYA_HEADER!r}, so it is not a Maya ASCII file",
            "export the scene from Maya as Maya ASCII (.ma); Maya itself refuses files without this header",
        )
    reader.run()
    return reader.skeleton(path.name.split(".")[0])
