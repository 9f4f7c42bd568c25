"""Every error code quadpipe reports, with what it means and the input it concerns.

An `Issue` (see `quadpipe.core.errors`) carries a stable kebab-case code that scripts, tests and
CI can match. This module is the one list of those codes: each is registered once, in the group
of the input it concerns, with a one-line meaning. `tests/test_error_codes.py` reads the
package's source and fails when a code is raised without being registered here, or registered
without being raised anywhere. `docs/errors.md` is generated from this list; regenerate it with

    python -m quadpipe.core.codes

A code that several inputs share (`unknown-key` in animals, controllers, scenes and batches) is
registered in the first group that uses it: files and YAML.
"""

from __future__ import annotations

import sys
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class CodeGroup:
    """Codes about one kind of input: `title` names it, `about` says where they come from."""

    title: str
    about: str
    codes: dict[str, str]
    """code -> its meaning (a phrase; `(warning)` or `(note)` first when it is not an error)."""


GROUPS: tuple[CodeGroup, ...] = (
    CodeGroup(
        "Files, YAML and names",
        "Any file quadpipe reads or writes, and configs named on the command line (animals, "
        "controllers, scenes, batch plans, role maps).",
        {
            "yaml-syntax": "the file is not valid YAML",
            "yaml-bad-character": "a control character YAML does not allow",
            "yaml-recursive-alias": "a YAML alias inside the collection its anchor names (it would never end)",
            "not-utf8": "a text file (YAML, skeleton, limits table) that is not UTF-8: UTF-16, Latin-1 or binary",
            "not-text": "a text file holding a NUL byte: binary data, or UTF-16 without a byte order mark",
            "limit-exceeded": "an input over one of the limits of `quadpipe/core/limits.py` (file size, YAML aliases or nesting, joints, elements, props, animals, simulated time...)",
            "bad-limit": "a `QUADPIPE_MAX_...` environment variable that is not a positive number",
            "duplicate-key": "a key appears twice in one mapping",
            "file-unreadable": "the file cannot be read",
            "file-not-found": "a file named on the command line or in another file (`extends`, a scene's animal) does not exist",
            "empty-file": "a YAML file (controller, scene, animal, batch plan, role map) holding nothing, or only comments",
            "is-a-folder": "a folder named where a file is expected (the hint names a file inside it)",
            "unknown-key": "a key that does not exist in that place",
            "missing-key": "a required key is missing",
            "invalid-value": "a value of the wrong shape (text instead of a list, ...)",
            "out-of-range": "a number that is not finite or outside its sane range: a body mass or pelvis height, a joint limit, a skeleton coordinate, `--seconds`, a scene value (a negative size, a too steep ramp, a length beyond any scene) or a tunable (in the file or an override) outside its `min`/`max`",
            "unsupported-schema": "the `schema:` version is not one this quadpipe reads",
            "duplicate-name": "two items of one file have the same name (controller elements, parameters or tunables; scene animals and props)",
            "unused-option": "an option for a bare skeleton file (`--mass`, `--limits`, `--roles`) given with an animal name or config",
            "unknown-format": "a file suffix or `--format` that quadpipe cannot read or write",
            "unwritable-output": "an output path that cannot be written (a folder, no permission, a missing drive)",
            "output-collision": "two outputs naming one file, or an output naming an input file",
            "wrong-suffix": "an output whose suffix does not match what is written into it (MJCF into a .glb)",
            "unknown-animal": "an animal name that is not built in (or, for `analyze`, not in the clip)",
            "unknown-controller": "`--controller` or `extends` names no built-in controller",
            "unknown-scene": "`--scene` names no built-in scene",
            "bad-parameter": "a `--set` that is not NAME=VALUE",
        },
    ),
    CodeGroup(
        "Skeleton files",
        "The importers: quadpipe skeleton XML (`.xml`), BVH (`.bvh`), Maya ASCII (`.ma`).",
        {
            "malformed-xml": "the XML is not well formed",
            "bad-element": "an XML element other than one <skeleton> holding <joint>s",
            "missing-attribute": "a <joint> without its name or position",
            "unknown-attribute": "an XML attribute that does not exist on that element",
            "bad-vector": "an XML position, axis or end that is not three numbers",
            "bad-units": "an XML `units` attribute that is not a known length unit",
            "bvh-syntax": "BVH text out of place (a missing name, OFFSET or End Site, an unexpected word)",
            "bvh-truncated": "the BVH file ends before its hierarchy does",
            "bvh-bad-number": "a BVH value that is not a number",
            "bvh-missing-hierarchy": "a BVH file that does not start with HIERARCHY",
            "bvh-unbalanced-braces": "a BVH `}` that closes nothing, or a joint never closed",
            "bvh-bad-channels": "a BVH CHANNELS line with a wrong count or an unknown channel",
            "bvh-bad-motion": "a BVH MOTION section that `--rest-frame` cannot read (no header, too few values)",
            "bvh-units-guessed": "(warning) a BVH file, which declares no unit, read in metres because it spans few units",
            "rest-frame-out-of-range": "a `--rest-frame` the file's motion does not have",
            "no-motion": "`--rest-frame` (or a unit) given for a skeleton format that has no motion (declares its unit)",
            "ma-not-maya-ascii": "the file does not start with the Maya ASCII header",
            "ma-syntax": "a Maya ASCII statement missing a part (createNode without -n)",
            "ma-truncated": "the Maya ASCII file ends inside a statement",
            "ma-unterminated-string": "a Maya ASCII string with no closing quote on its line",
            "ma-unterminated-comment": "a Maya ASCII /* comment that is never closed",
            "ma-bad-units": "a Maya ASCII linear or angular unit that is not known",
            "ma-mixed-units": "the Maya ASCII linear unit changes after lengths were set",
            "ma-bad-number": "a Maya ASCII value that is not a number",
            "ma-bad-value": "a Maya ASCII attribute with the wrong count or kind of values",
            "ma-zero-scale": "a Maya ASCII node scaled by 0, which collapses the joints under it to a point",
            "ma-unknown-parent": "a Maya ASCII parent that is not a node created earlier",
            "ma-ambiguous-name": "a short Maya ASCII node name that several nodes share",
            "ma-unsupported-command": "a Maya ASCII command this reader does not follow (`parent` after creation)",
            "ma-driven-joints": "(warning) Maya ASCII plugs driven by nodes the reader does not evaluate (animation curves, constraints with several targets), read at their saved values",
            "junk-end-sites": "(warning) end sites of zero length, pointing up from a foot or longer than their limb, replaced",
            "empty-skeleton": "a skeleton file with no joints",
        },
    ),
    CodeGroup(
        "Skeletons and role maps",
        "A skeleton checked against the 39-bone reference hierarchy, and the role maps "
        "(`--roles`) or role guesses that name its bones.",
        {
            "duplicate-joint": "two joints with the same name",
            "unknown-parent": "a joint whose parent is not in the file",
            "hierarchy-cycle": "joints that are each other's parents in a loop",
            "unknown-role": "a role name that does not exist",
            "duplicate-role": "one role given to two joints",
            "missing-roles": "roles of the reference hierarchy that no bone has",
            "wrong-parent": "a bone hanging under another parent than the reference hierarchy says",
            "missing-end": "a leaf bone whose end the file does not give",
            "zero-length-bone": "a bone whose end lies on its joint",
            "bad-up-axis": "an up axis other than y or z",
            "zero-axis": 'a joint axis of length zero (`axis="0 0 0"`): it gives no direction',
            "no-forward": "the thorax straight above the pelvis, so the body has no forward direction",
            "mirrored-legs": "a left leg on the animal's right side, or the reverse",
            "unplaced-joints": "(warning) joints with no role, left out of the model",
            "synthesised-roles": "(note) roles the rig has no bone for, made from its neighbours (scapula, toes)",
            "ambiguous-pattern": "a role map pattern that gives one role to several joints",
            "unused-pattern": "(warning) a role map pattern that matches no joint",
            "guessed-chain": "(warning) roles guessed with joints skipped in a chain",
            "guessed-roles": "(note) how the roles of a foreign skeleton were guessed",
            "rest-pose-not-standing": "a skeleton's rest pose whose legs do not hang under the trunk (`--rest-frame` picks a standing frame)",
            "implausible-roles": "roles that fail anatomy: a leg on the side or end its names deny, the head behind the thorax",
        },
    ),
    CodeGroup(
        "Joint limits",
        "Joint limit tables (`configs/limits/*.tsv`, `.csv`) and the limits they give each role.",
        {
            "empty-table": "a limits table with no rows",
            "short-row": "a limits table row with fewer cells than the columns its header names",
            "bad-header": "a limits table header missing columns",
            "duplicate-row": "two rows for one bone",
            "unknown-bone": "a limits table row keyed by a name that is no role, bone or group, so it applies to no joint",
            "bad-number": "a limit that is not a number of degrees",
            "missing-limits": "a kind of joint the table has no row for",
            "bad-limits": "limits that contradict themselves (min above max, a negative swing)",
        },
    ),
    CodeGroup(
        "Animals",
        "Animal configs (`configs/animals/*.yaml`): a skeleton, limits and sizes.",
        {
            "hp-mismatch": "(warning) the skeleton's pelvis height differs from the config's",
            "default-mass": "(note) the mass a skeleton file without --mass is given, by the mammal body-size rule",
            "gait-not-in-repertoire": "(warning) a gait controller run on an animal whose species does not use that gait",
            "mixed-carriage": "(warning) one scene's species carry their tails differently: every tail keeps its rest shape",
            "mixed-repertoires": "the animals of one run offer different gait settings to their one controller",
        },
    ),
    CodeGroup(
        "Expressions",
        "Unit-aware expressions in controllers and scenes (`0.2 bw`, `38/30 s`, `phase(step)`).",
        {
            "expression-syntax": "an expression that cannot be parsed",
            "forbidden-syntax": "an expression using syntax that is not allowed",
            "non-finite-number": "a number that is not finite (nan, inf, 1e309), or a constant part of an expression that overflows (10^10^10) or has no value (sqrt(-1), acos(2))",
            "division-by-zero": "an expression dividing by a constant zero (`0.5 bw / 0`)",
            "unknown-name": "an expression using a name that does not exist",
            "unknown-function": "an expression calling a function that does not exist",
            "unknown-cycle": "phase() of something that is not a cycle element",
            "wrong-arguments": "a function called with the wrong number of arguments",
            "wrong-type": "a value of the wrong kind (a vector where a number is expected, ...)",
            "wrong-dimension": "a value in the wrong unit (an angle where a time is expected, ...)",
            "dimension-mismatch": "an expression mixing units that do not go together",
            "bad-point": "a body point with an unknown anchor (`.tip` instead of `.end`)",
            "unknown-leg": "a leg or group name that does not exist",
            "table-lengths": "a table (`interp`) whose lists of breakpoints and values differ in length",
            "table-size": "a table (`interp`) of fewer than 2 points",
            "table-order": "a table (`interp`) whose breakpoints decrease",
            "table-units": "a table (`interp`) whose breakpoints (or values) mix units",
            "table-not-constant": "a table (`interp`) whose breakpoints or values read the simulation",
        },
    ),
    CodeGroup(
        "Controllers",
        "Controller files (`configs/controllers/*.yaml`), as `quadpipe validate` checks them.",
        {
            "no-controllers": "`validate` given a folder holding no controller file",
            "extends-cycle": "controllers extend each other in a loop",
            "unknown-element-type": "an element `type` that does not exist",
            "template-name": "an element or a parameter with `for_each` whose name lacks {leg}",
            "unknown-placeholder": "a {placeholder} that is not {leg} or {pair}, or one of them without `for_each`",
            "unknown-element": "a reference to an element that does not exist",
            "bad-override": "an override or state that changes an element's type or name",
            "name-clash": "a name already taken by a unit, function, role, leg or another name",
            "bad-name": "a parameter, sensor or cycle name that cannot be used in expressions",
            "parameter-cycle": "parameters defined in terms of each other in a loop",
            "unknown-parameter": "a state or override setting a parameter that does not exist",
            "bad-range": "a tunable whose `min` is above its `max`",
            "tunable-not-constant": "a tunable that is not a constant number (formulas go in `parameters:`)",
            "glob-matches-nothing": "a role glob that matches no joint",
            "no-joint": "a spring on the pelvis, which has no joint",
            "unknown-axis": "a spring joint `role.axis` whose axis is not twist, swing1 or swing2",
            "duplicate-point": "the same body point twice in one mapping",
            "unknown-frame": "a frame that is not heading, world or a role",
            "direction-kind": "a direction with none or several of vector, toward, balance",
            "strength-kind": "a strength with both a force and length2",
            "zero-vector": "a direction vector of length zero",
            "unused-key": "a key that does nothing in this combination (horizon without balance, ...)",
            "nothing-to-do": "a segment with neither a direction nor an elastic",
            "same-point": "a segment whose two ends are the same point",
            "bad-weights": "reaction weights that are not positive plain numbers",
            "parallel-axis": "a cycle whose reference is parallel to its axis",
            "unknown-state": "a state machine naming a state that does not exist",
            "not-switchable": "a state switching or changing a sensor or state machine",
            "state-conflict": "an element changed by two state machines",
            "unused-parameter": "(warning) a parameter no element uses",
            "unused-sensor": "(warning) a sensor no expression uses",
            "unreachable-state": "(warning) a state no transition enters",
        },
    ),
    CodeGroup(
        "Scenes",
        "Scene files (`configs/scenes/*.yaml`): terrain, props, throws, goals and animals.",
        {
            "unknown-terrain-type": "a terrain `type` that does not exist",
            "not-constant": "a scene value that reads the simulation (`t`, a sensor, a body point)",
            "invalid-range": "a [lowest, highest] range given highest first",
            "reserved-name": "a prop named like a part of the scene itself",
            "unknown-animal-ref": "a throw, goal or direction naming an animal that is not in the scene",
            "animal-count": "a number of animals given that does not fill the scene's animals without a species",
            "throw-out-of-reach": "a throw too slow to reach its target from its direction",
            "set-format": "a set file (`terrain: [{type: mesh}]`) whose suffix is not a mesh format quadpipe reads (OBJ, PLY, glTF/GLB, USD)",
            "set-unreadable": "a set file that cannot be read as the mesh format its suffix says, or holds coordinates that are not finite",
            "set-empty": "a set file holding no triangles, or none that cover ground seen from above",
            "direction-bad-point": "a direction's move to a path point that does not exist, or that is not ahead of the animal",
            "direction-too-soon": "a direction's move asked to arrive no later than it starts",
            "direction-bad-curve": "a direction's path `file` that holds no usable curve (no OBJ polyline or USD BasisCurves, too few or too many points)",
            "direction-bad-leader": "a direction's `follow` naming an animal without a path and beats of its own",
            "direction-tight-bend": "(warning) a direction's path bending tighter than its animal can follow at the speed asked there (it cuts the bend)",
        },
    ),
    CodeGroup(
        "Simulation",
        "Running a controller on animals in a scene.",
        {
            "bad-fps": "a frame rate that is not positive or does not divide the physics rate",
            "bad-variation": "a `--variation` outside 0 to 0.2, or a negative `--seed`",
            "simulation-blew-up": "the simulation diverged (a non-finite state, a bad acceleration, a body flung away)",
            "non-finite-force": "a controller element computed a force, a spring target, stiffness or damping that is NaN or infinite",
        },
    ),
    CodeGroup(
        "Clips and outputs",
        "Baked clips (`.npz`), the exporters, `quadpipe render` and `quadpipe analyze`.",
        {
            "bad-clip": "a clip that cannot be exported: no frames, or broken from a frame on",
            "bad-clip-file": "a `.npz` that is not a quadpipe clip of a version this quadpipe reads",
            "bad-clip-sensor": "a clip sensor whose array has the wrong shape",
            "empty-clip": "a clip with no frames to render or replay",
            "bvh-one-animal": "a BVH export of a clip holding several animals",
            "format-unavailable": "an output format whose package is not installed",
            "no-animal": "a clip with no animal for the camera to follow",
            "no-finite-frame": "a clip whose animal has no frame with a finite pose",
            "bad-camera": "a camera mode, distance or smoothing that cannot be used",
            "unknown-overlay": "an overlay name that is not built in",
            "bad-overlay": "an overlay of an unknown kind, with arrays of the wrong shape or no width",
            "bad-size": "an image or video size out of range (or odd, for H.264)",
            "bad-grid": "a contact sheet grid without at least one row and column",
            "unsupported-gl-backend": "a MUJOCO_GL value that quadpipe cannot render with",
            "no-headless-gl": "no OpenGL context can be opened for headless rendering",
            "unsupported-diagram-format": "a footfall diagram file suffix that cannot be drawn",
        },
    ),
    CodeGroup(
        "Batches",
        "Batch plans (`configs/batches/*.yaml`) and `quadpipe batch` runs.",
        {
            "incomplete-plan": "a batch plan without animals or controllers",
            "override-selects-nothing": "a plan override selecting an animal or controller that is not in the plan",
            "duplicate-job": "two jobs that would write the same files",
            "interrupted": "a job cut short because the batch was interrupted",
            "missing-package": "a Dask batch without the `distributed` package installed",
            "scheduler-unreachable": "a Dask scheduler address that cannot be reached",
        },
    ),
    CodeGroup(
        "Preview",
        "The live viewer (`quadpipe preview`).",
        {
            "no-display": "no display to open the preview window on",
            "unsupported-clip-format": "a clip file the preview cannot replay",
        },
    ),
)
"""Every code, grouped by the input it concerns."""

CODES: dict[str, str] = {code: meaning for group in GROUPS for code, meaning in group.codes.items()}
"""Every code with its meaning."""

DOCS_PATH = Path("docs") / "errors.md"
"""The generated page of every code, relative to the repository root."""


def meanings(codes: Iterable[str]) -> dict[str, str]:
    """The meaning of each code, in the order given.

    Raises:
        KeyError: a code that is not registered.
    """
    return {code: CODES[code] for code in codes}


def _escape(text: str) -> str:
    return text.replace("|", "\\|")


def errors_markdown() -> str:
    """The text of docs/errors.md: every code, its meaning, grouped by input."""
    parts = [
        "# Error codes\n",
        "<!-- Generated by `python -m quadpipe.core.codes` from quadpipe/core/codes.py; do not edit. -->\n",
        "Every problem in a file or an option is reported as `file:line:col: error CODE: message`,",
        "with a hint under it when there is one (`--format json` / `github` of `quadpipe validate`",
        "carry the same codes). Codes are stable: scripts and CI may match them. Warnings and notes",
        "do not stop a command. Adding a code: register it in `quadpipe/core/codes.py` and regenerate",
        "this page.\n",
    ]
    for group in GROUPS:
        rows = ["| code | meaning |", "|---|---|"]
        rows += [f"| `{code}` | {_escape(meaning)} |" for code, meaning in group.codes.items()]
        parts.append(f"## {group.title}\n\n{group.about}\n\n" + "\n".join(rows) + "\n")
    return "\n".join(parts)


def write_errors_page(root: Path) -> Path:
    """Write docs/errors.md under a repository root; return its path."""
    path = root / DOCS_PATH
    path.write_text(errors_markdown(), encoding="utf-8")
    return path


if __name__ == "__main__":
    print(write_errors_page(Path(sys.argv[1]) if len(sys.argv) > 1 else Path.cwd()))
