"""Seeded mutation fuzzing of the shipped controllers, scenes and animals, in process.

Each case takes one shipped file, applies one or two seeded mutations to its text (a scalar
replaced by NaN, infinity, 1e308, zero, "", a mapping, a list, a random word or an absurd
expression; a key deleted or duplicated; the text truncated; a tab, NUL or non-UTF-8 byte
inserted; a value nested thousands deep), then loads, checks and builds it for the dog as the
command line would:

- a controller: `load_controller`, then `compile_for` the dog standing in the flat scene;
- a scene: `load_scene`, `build_scene` for the dog, and the world compiled by MuJoCo;
- an animal: `load_animal`, `build_animal`, and its model compiled by MuJoCo.

Every case must end in success or in a `QuadpipeError` (the user's answer), within
`CASE_TIME_LIMIT_S`, without a library warning (numpy's RuntimeWarnings leaked into messages);
and a success must hold no NaN or infinite number (a compiled constant,
a mass, a limit, a position, a model array that the unmutated file keeps finite). A failure
lists every bad case as `seed file mutation -> what happened`, and reproduces with
`python -m tests.test_fuzz SEED` (which prints the mutated text and the traceback).
"""

from __future__ import annotations

import dataclasses
import functools
import math
import random
import shutil
import signal
import string
import sys
import traceback
import warnings
from collections import Counter
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from tests.conftest import REPO

CASES = 600
"""Number of seeded cases (each one file, one or two mutations)."""

CHUNK = 50
"""Cases per test item, so that pytest-xdist spreads them over the workers."""

CASE_TIME_LIMIT_S = 10
"""A case still running after this long has hung."""

NESTING_DEPTH = 3000
"""How deep the `deep nesting` mutations nest brackets, braces or parentheses."""

NUMBER_BIAS = 0.7
"""How often the scalar replaced is one holding a digit (a quantity) rather than any scalar."""

REPLACEMENTS = (
    ".nan",
    ".inf",
    "-.inf",
    "nan",
    "inf",
    "1e308",
    "-1e308",
    "0",
    '""',
    "{a: 1}",
    "[1, 2]",
    "1/0",
    "1e308*1e308",
    "10^10^10",
    "0 * bw / 0",
    "-1",
    "1e-308",
)
"""What a scalar may be replaced by (besides a random word and deep nesting)."""

CONFIGS = REPO / "configs"
KINDS = ("controllers", "scenes", "animals")
CHEAP_CONTROLLERS = ("rigid", "point_target", "postures", "spine_walk")
"""Controllers that compile in a fraction of a second: drawn three times as often as the others."""


class Hang(Exception):
    """Raised by the alarm when a case runs past its time limit."""


@dataclasses.dataclass(frozen=True)
class Case:
    """One fuzz case: a shipped file and the text its mutations made of it."""

    seed: int
    kind: str
    name: str
    mutations: tuple[str, ...]
    data: bytes

    @property
    def label(self) -> str:
        return f"seed {self.seed} {self.kind}/{self.name}.yaml [{'; '.join(self.mutations)}]"


# ------------------------------------------------------------------ mutations


def _nodes(node: yaml.Node, parent: yaml.Node | None = None) -> Iterator[tuple[yaml.Node, yaml.Node | None]]:
    """Every node of a composed document with its parent collection."""
    yield node, parent
    if isinstance(node, yaml.MappingNode):
        for key, value in node.value:
            yield from _nodes(key, node)
            yield from _nodes(value, node)
    elif isinstance(node, yaml.SequenceNode):
        for item in node.value:
            yield from _nodes(item, node)


def _pairs(root: yaml.Node) -> list[tuple[yaml.MappingNode, yaml.Node, yaml.Node]]:
    """Every key/value pair of every mapping: (mapping, key, value)."""
    return [
        (node, key, value)
        for node, _ in _nodes(root)
        if isinstance(node, yaml.MappingNode)
        for key, value in node.value
    ]


def _splice(text: str, start: int, end: int, new: str) -> str:
    return text[:start] + new + text[end:]


def replace_scalar(text: str, root: yaml.Node, rng: random.Random) -> tuple[str, str]:
    """A value (not a key) replaced by an absurd one."""
    keys = {id(key) for _, key, _ in _pairs(root)}
    scalars = [node for node, _ in _nodes(root) if isinstance(node, yaml.ScalarNode) and id(node) not in keys]
    numbers = [node for node in scalars if any(c.isdigit() for c in node.value)]
    node = rng.choice(numbers if numbers and rng.random() < NUMBER_BIAS else scalars)
    choice = rng.random()
    if choice < 0.1:
        new = "".join(rng.choice(string.ascii_letters + string.digits + " _-*/^()") for _ in range(rng.randint(1, 12)))
    elif choice < 0.15:
        new = "[" * NESTING_DEPTH + "1" + "]" * NESTING_DEPTH
    elif choice < 0.2:
        new = "(" * NESTING_DEPTH + "1" + ")" * NESTING_DEPTH
    else:
        new = rng.choice(REPLACEMENTS)
    old = text[node.start_mark.index : node.end_mark.index]
    if new == old:  # a replacement must change the file
        new = next(replacement for replacement in REPLACEMENTS if replacement != old)
    return _splice(text, node.start_mark.index, node.end_mark.index, new), f"{old[:30]!r} -> {new[:30]!r}"


def delete_key(text: str, root: yaml.Node, rng: random.Random) -> tuple[str, str]:
    """A key deleted with its value: its whole line(s) in a block mapping, with its comma in a flow one."""
    mapping, key, value = rng.choice(_pairs(root))
    start, end = key.start_mark.index, value.end_mark.index
    if mapping.flow_style:
        end += 2 if text[end : end + 2] == ", " else 0
    else:
        line_start = text.rfind("\n", 0, start) + 1
        start = line_start if not text[line_start:start].strip() else start
        end = end if text[end - 1 : end] == "\n" else text.find("\n", end) + 1 or len(text)
    return _splice(text, start, end, ""), f"delete {key.value!r}"


def duplicate_key(text: str, root: yaml.Node, rng: random.Random) -> tuple[str, str]:
    """A key written twice in its mapping, with the same value."""
    mapping, key, value = rng.choice(_pairs(root))
    end = value.end_mark.index
    snippet = text[key.start_mark.index : end].rstrip("\n")
    if mapping.flow_style:
        insert = ", " + snippet
    elif text[end - 1 : end] == "\n":
        insert = " " * key.start_mark.column + snippet + "\n"
    else:
        insert = "\n" + " " * key.start_mark.column + snippet
    return _splice(text, end, end, insert), f"duplicate {key.value!r}"


def deep_nesting(text: str, root: yaml.Node, rng: random.Random) -> tuple[str, str]:
    """A value replaced by a mapping nested thousands deep."""
    pairs = _pairs(root)
    _, key, value = rng.choice(pairs)
    new = "{a: " * NESTING_DEPTH + "1" + "}" * NESTING_DEPTH
    return _splice(
        text, value.start_mark.index, value.end_mark.index, new
    ), f"{key.value!r} nested {NESTING_DEPTH} deep"


TEXT_MUTATIONS: dict[str, Callable[[str, yaml.Node, random.Random], tuple[str, str]]] = {
    "replace_scalar": replace_scalar,
    "delete_key": delete_key,
    "duplicate_key": duplicate_key,
    "deep_nesting": deep_nesting,
}
TEXT_WEIGHTS = {"replace_scalar": 6, "delete_key": 2, "duplicate_key": 1, "deep_nesting": 0.5}


def truncate(data: bytes, rng: random.Random) -> tuple[bytes, str]:
    """The file cut at a random byte."""
    at = rng.randrange(len(data))
    return data[:at], f"truncated at byte {at}"


def insert_byte(data: bytes, rng: random.Random) -> tuple[bytes, str]:
    """A tab at the start of a line, a NUL, or a byte that is not UTF-8, somewhere."""
    byte = rng.choice((b"\t", b"\0", b"\xff", b"\xe9"))
    if byte == b"\t":
        starts = [0] + [i + 1 for i, c in enumerate(data) if c == ord("\n") and i + 1 < len(data)]
        at = rng.choice(starts)
    else:
        at = rng.randrange(len(data) + 1)
    return data[:at] + byte + data[at:], f"{byte!r} inserted at byte {at}"


@functools.cache
def make_case(seed: int) -> Case:
    """The seed's file and its mutated bytes: one mutation, or two one time in four.

    Text mutations need a text that still parses; a byte mutation (truncation, an odd byte)
    comes last. Cached (a `Case` is frozen): the seeds' test items and the test of the mutations
    themselves share one making of each case.
    """
    rng = random.Random(seed)
    kind = KINDS[seed % len(KINDS)]
    names = sorted(p.stem for p in (CONFIGS / kind).glob("*.yaml"))
    if kind == "controllers":
        names += [name for name in CHEAP_CONTROLLERS for _ in range(2)]
    name = rng.choice(names)
    text = (CONFIGS / kind / f"{name}.yaml").read_text()
    mutations: list[str] = []
    for _ in range(2 if rng.random() < 0.25 else 1):
        root = _composed(text)
        if root is None or rng.random() < 0.2:
            data, what = rng.choice((truncate, insert_byte))(text.encode(), rng)
            return Case(seed, kind, name, (*mutations, what), data)
        mutation = rng.choices(list(TEXT_WEIGHTS), weights=list(TEXT_WEIGHTS.values()))[0]
        text, what = TEXT_MUTATIONS[mutation](text, root, rng)
        mutations.append(what)
    return Case(seed, kind, name, tuple(mutations), text.encode())


def _composed(text: str) -> yaml.Node | None:
    """The text's YAML node tree, or None where it no longer parses (or holds no document)."""
    try:
        return yaml.compose(text)
    except (yaml.YAMLError, RecursionError):
        return None


# ------------------------------------------------------------------ checks


WALK_DEPTH = 100
"""How deep `non_finite` looks into nested objects (an expression tree may nest thousands deep)."""


def non_finite(value: Any, where: str = "", seen: set[int] | None = None) -> list[str]:
    """Paths of the NaN or infinite numbers held in `value` (dataclasses, pydantic models,
    mappings, sequences, numpy arrays), callables and MuJoCo objects left out."""
    seen = set() if seen is None else seen
    if where.count(".") + where.count("[") > WALK_DEPTH:
        return []
    if isinstance(value, bool | int | str | bytes | type(None)) or callable(value):
        return []
    if isinstance(value, float | np.floating):
        return [] if math.isfinite(value) else [f"{where} = {value}"]
    if isinstance(value, np.ndarray):
        if value.dtype.kind in "fc" and not np.isfinite(value).all():
            return [f"{where} holds {value.ravel()[~np.isfinite(value.ravel())][0]}"]
        return []
    if id(value) in seen:
        return []
    seen.add(id(value))
    if isinstance(value, dict) or hasattr(value, "items") and not hasattr(value, "__dict__"):
        return [bad for key, item in value.items() for bad in non_finite(item, f"{where}[{key!r}]", seen)]
    if isinstance(value, list | tuple | set | frozenset):
        return [bad for i, item in enumerate(value) for bad in non_finite(item, f"{where}[{i}]", seen)]
    if type(value).__module__.startswith("mujoco"):
        return []
    fields = vars(value) if hasattr(value, "__dict__") else {}
    return [bad for key, item in fields.items() for bad in non_finite(item, f"{where}.{key}", seen)]


def model_non_finite(model: Any, allowed: frozenset[str]) -> list[str]:
    """The compiled MuJoCo model's float arrays holding NaN or infinity, beyond `allowed`."""
    bad = []
    for name in dir(model):
        if name.startswith("_") or name in allowed:
            continue
        value = getattr(model, name, None)
        if isinstance(value, np.ndarray) and value.dtype.kind == "f" and not np.isfinite(value).all():
            bad.append(f"model.{name}")
    return bad


@functools.cache
def _dog() -> Any:
    from quadpipe.animals.library import load_animal
    from quadpipe.animals.model import build_animal

    return build_animal(load_animal("dog"))


@functools.cache
def _flat_placements() -> Any:
    from quadpipe.world import build_scene, load_scene

    return build_scene(load_scene("flat"), _dog()).placements


@functools.cache
def _baseline_non_finite(kind: str, name: str) -> frozenset[str]:
    """Model arrays that hold non-finite numbers for the unmutated file (MuJoCo's own infinities)."""
    return frozenset(
        name.removeprefix("model.")
        for name in model_non_finite(_build(kind, CONFIGS / kind / f"{name}.yaml")[1], frozenset())
    )


def _build(kind: str, path: Path) -> tuple[Any, Any]:
    """Load, check and build one file as the command line would: (what was built, its compiled model or None)."""
    if kind == "controllers":
        from quadpipe.controllers.runtime.runtime import compile_for

        compiled, _ = compile_for(str(path), _flat_placements())
        return compiled, None
    if kind == "scenes":
        from quadpipe.world import build_scene, load_scene

        setup = build_scene(load_scene(path), _dog())
        held = (setup.headings, setup.throws, setup.prop_velocities, setup.goal_parameters)
        return held, setup.spec.compile()
    from quadpipe.animals.library import load_animal
    from quadpipe.animals.model import build_animal

    built = build_animal(load_animal(path))
    held = (built.animal, built.radius, built.radii, built.masses, built.timestep, built.tau)
    return held, built.spec.compile()


def _alarm(signum: int, frame: Any) -> None:
    raise Hang()


def run_case(case: Case, folder: Path) -> str | None:
    """None when the case ends well; otherwise what went wrong, in one line."""
    from quadpipe.core.errors import QuadpipeError

    path = folder / case.kind / f"{case.name}.yaml"
    path.write_bytes(case.data)
    previous = signal.signal(signal.SIGALRM, _alarm)
    signal.alarm(CASE_TIME_LIMIT_S)
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            held, model = _build(case.kind, path)
    except QuadpipeError:
        return _leaked(caught)
    except Hang:
        return f"hang: still running after {CASE_TIME_LIMIT_S} s"
    except BaseException as exc:  # noqa: BLE001 - any other exception is the bug being looked for
        if isinstance(exc, KeyboardInterrupt):
            raise
        return f"{type(exc).__name__}: {str(exc).splitlines()[0][:120] if str(exc) else ''}"
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
    bad = non_finite(held, "")
    if model is not None:
        bad += model_non_finite(model, _baseline_non_finite(case.kind, case.name))
    return f"accepted non-finite: {', '.join(bad[:3])}" if bad else _leaked(caught)


def _leaked(caught: list[warnings.WarningMessage]) -> str | None:
    """A library warning that reached the user (None when there was none)."""
    if not caught:
        return None
    first = caught[0]
    return f"warning leaked: {first.category.__name__}: {first.message} ({Path(first.filename).name}:{first.lineno})"


@pytest.fixture(scope="module")
def fuzz_folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder laid out like configs/: the mutated files go in, next to the real skeletons and limits."""
    return make_folder(tmp_path_factory.mktemp("fuzz"))


def make_folder(folder: Path) -> Path:
    for kind in KINDS:
        (folder / kind).mkdir()
    for shared in ("skeletons", "limits"):
        shutil.copytree(CONFIGS / shared, folder / shared)
    return folder


def failure_report(failures: list[tuple[Case, str]]) -> str:
    """The failures, one line each, with counts by what went wrong."""
    counts = Counter(outcome.split(":")[0] for _, outcome in failures)
    lines = [f"{len(failures)} fuzz cases failed ({', '.join(f'{n} {what}' for what, n in counts.most_common())}):"]
    lines += [f"  {case.label} -> {outcome}" for case, outcome in failures]
    lines.append("reproduce one with: PYTHONPATH=. python -m tests.test_fuzz SEED")
    return "\n".join(lines)


@pytest.mark.parametrize("first", range(0, CASES, CHUNK), ids=lambda first: f"seeds{first}-{first + CHUNK - 1}")
def test_mutated_files_end_in_success_or_a_clear_error(first: int, fuzz_folder: Path) -> None:
    failures = []
    for seed in range(first, first + CHUNK):
        case = make_case(seed)
        outcome = run_case(case, fuzz_folder)
        if outcome is not None:
            failures.append((case, outcome))
    assert not failures, failure_report(failures)


def test_the_mutations_reach_every_kind_and_change_the_text() -> None:
    """The fuzzer is not vacuous: every file kind and mutation is drawn, and each case differs from its file."""
    cases = [make_case(seed) for seed in range(CASES)]
    assert {case.kind for case in cases} == set(KINDS)
    assert all(case.data != (CONFIGS / case.kind / f"{case.name}.yaml").read_bytes() for case in cases)
    drawn = " ".join(m for case in cases for m in case.mutations)
    for word in ("->", "delete", "duplicate", "nested", "truncated", "inserted", "'nan'", "'10^10^10'"):
        assert word in drawn, f"no mutation with {word!r} among {CASES} cases"


def main(seeds: list[int]) -> None:
    """Run some seeds verbosely: the mutated text's changes and the full traceback."""
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        folder = make_folder(Path(tmp))
        for seed in seeds:
            case = make_case(seed)
            print(case.label)
            try:
                path = folder / case.kind / f"{case.name}.yaml"
                path.write_bytes(case.data)
                _build(case.kind, path)
            except Exception:  # noqa: BLE001 - shown to the developer
                traceback.print_exc()
            print("outcome:", run_case(case, folder) or "ok")


if __name__ == "__main__":
    main([int(arg) for arg in sys.argv[1:]])
