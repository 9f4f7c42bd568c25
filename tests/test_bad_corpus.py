"""The bad-input corpus: every case is a bad input a user or a CI job may give, and its answer.

Each case is a folder `tests/fixtures/bad_corpus/<group>/<case>/` holding:

- `case.yaml`: `args` (the command line after `quadpipe`), optionally `exit` (default 1),
  `timeout_s` (default 60: a hang fails the case), `stdin`, `env` (extra variables), `creates`
  (files the command may leave, e.g. a valid output next to a refused one), `mask` (regexes for
  what changes from run to run, such as a batch summary's wall-clock column), `generate` (inputs
  too big or too binary to commit, made by a named recipe in `GENERATORS`, e.g.
  `{file: big.xml, recipe: many_joints_xml, count: 10000}`);
- `expected.txt`: the exact standard error, then the standard output if any after a line
  `--- stdout ---` (`{tmp}` stands for the case's folder, `{repo}` for the repository);
- its input files, copied into a fresh folder where the command runs.

Each case runs in its own process group (a hung case is killed with its workers) and must end
with its expected exit code and message, without a Python traceback or a
numpy/MuJoCo warning, within its time limit, and leave nothing behind: no file in its folder
beyond its inputs and `creates`, nothing in its private temporary directory (`TMPDIR`), and no
`MUJOCO_LOG.TXT`.

Regenerate the expected messages after a deliberate wording change with
`QUADPIPE_BLESS=1 .venv/bin/python -m pytest tests/test_bad_corpus.py`, then read the diff.
"""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
import yaml

from tests.conftest import FIXTURES, REPO

CORPUS = FIXTURES / "bad_corpus"
DEFAULT_TIMEOUT_S = 60.0
"""A case still running after this long has hung."""

LEAKS = ("Traceback (most recent call last)", "RuntimeWarning", "UserWarning", "DeprecationWarning")
"""Text that must never reach a user: a traceback or a library warning."""


def many_joints_xml(path: Path, count: int) -> None:
    """A quadpipe skeleton XML with one chain of `count` joints."""
    lines = ['<?xml version="1.0" encoding="utf-8"?>', '<skeleton name="long" units="cm" up="y" version="1">']
    lines.append('  <joint name="j0" position="0 50 0" axis="1 0 0"/>')
    lines += [f'  <joint name="j{i}" parent="j{i - 1}" position="0 50 {i}" axis="1 0 0"/>' for i in range(1, count)]
    lines.append("</skeleton>")
    path.write_text("\n".join(lines) + "\n")


def many_joints_ma(path: Path, count: int) -> None:
    """A Maya ASCII file with one chain of `count` joints."""
    lines = ["//Maya ASCII 2024 scene", 'requires maya "2024";', "currentUnit -l centimeter -a degree -t film;"]
    for i in range(count):
        parent = f' -p "j{i - 1}"' if i else ""
        lines += [f'createNode joint -n "j{i}"{parent};', '\tsetAttr ".t" -type "double3" 1 0 0 ;']
    path.write_text("\n".join(lines) + "\n")


def alias_bomb_yaml(path: Path, levels: int) -> None:
    """A "billion laughs" YAML document: each level repeats the one below nine times."""
    lines = ['a0: &a0 ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]']
    lines += [f"a{i}: &a{i} [{', '.join([f'*a{i - 1}'] * 9)}]" for i in range(1, levels)]
    path.write_text("\n".join(lines) + "\n")


def deep_yaml(path: Path, depth: int) -> None:
    """A YAML document nested `depth` flow sequences deep."""
    path.write_text("schema: 1\nname: deep\nparameters:\n  x: " + "[" * depth + "1" + "]" * depth + "\n")


def binary_file(path: Path, size: int) -> None:
    """`size` bytes that are not text in any encoding (seeded)."""
    path.write_bytes(bytes((i * 131 + 7) % 256 for i in range(size)))


def utf16_yaml(path: Path, text: str) -> None:
    """`text` written as UTF-16 (with its byte order mark)."""
    path.write_bytes(text.encode("utf-16"))


def latin1_yaml(path: Path, text: str) -> None:
    """`text` written as Latin-1 (not UTF-8 where it has accents)."""
    path.write_bytes(text.encode("latin-1"))


def deep_bvh(path: Path, depth: int) -> None:
    """A BVH skeleton of one chain `depth` joints deep, with one frame of motion."""
    lines = [
        "HIERARCHY",
        "ROOT j0",
        "{",
        "OFFSET 0 0 0",
        "CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation",
    ]
    for i in range(1, depth):
        lines += [f"JOINT j{i}", "{", "OFFSET 0 1 0", "CHANNELS 3 Zrotation Xrotation Yrotation"]
    lines += ["End Site", "{", "OFFSET 0 1 0", "}"] + ["}"] * depth
    lines += ["MOTION", "Frames: 1", "Frame Time: 0.0333333", " ".join(["0"] * (3 + 3 * depth))]
    path.write_text("\n".join(lines) + "\n")


def many_props_scene(path: Path, count: int) -> None:
    """A scene of `count` small spheres in a row ahead of the animal."""
    lines = ["schema: 1", "name: many_props", "props:"]
    lines += [
        f"  - {{name: p{i}, type: sphere, at: [{4 + i * 0.01:.2f} HP, 0, 0.1 HP], size: [0.05 HP], mass: 0.1 kg}}"
        for i in range(count)
    ]
    path.write_text("\n".join(lines) + "\n")


def repeated_expression(path: Path, head: str, tail: str, count: int) -> None:
    """The shipped `rigid` controller with its neck force written as head*count + `0.5 bw` + tail*count."""
    text = (REPO / "configs" / "controllers" / "rigid.yaml").read_text()
    assert "value: 0.5 bw" in text
    path.write_text(text.replace("value: 0.5 bw", f"value: {head * count}0.5 bw{tail * count}", 1))


def shipped(path: Path, source: str, replace: list[list[str]] | None = None, cut: str | None = None) -> None:
    """A copy of a file of the repository (`source`: `configs/animals/dog.yaml`), each `[old, new]`
    of `replace` applied once, and the copy ending right after the first `cut` (a truncated file).

    Every `old` and `cut` must occur in the file, so a case whose edit no longer applies fails loudly.
    """
    text = (REPO / source).read_text()
    for old, new in replace or []:
        assert old in text, f"{source} has no {old!r} to replace"
        text = text.replace(old, new, 1)
    if cut is not None:
        assert cut in text, f"{source} has no {cut!r} to cut after"
        text = text[: text.index(cut) + len(cut)]
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)


def folder(path: Path) -> None:
    """An empty folder (git keeps none), e.g. a directory given where a file is expected."""
    path.mkdir(parents=True)


def clip_npz(
    path: Path,
    header: dict[str, Any] | None = None,
    nan: list[str] | None = None,
    frames: dict[str, int] | None = None,
    drop: list[str] | None = None,
) -> None:
    """The corpus's base clip (`clips/base.npz`: the dog, 0.2 s of `rigid`, 7 frames) with edits.

    `header`: top-level keys of the JSON header replaced; `nan`: arrays whose frame 3 becomes
    NaN; `frames`: arrays cut to that many frames; `drop`: arrays left out.
    """
    import json

    import numpy as np

    with np.load(CORPUS / "clips" / "base.npz", allow_pickle=False) as clip:
        arrays = {name: clip[name] for name in clip.files}
    arrays["header"] = np.array(json.dumps(json.loads(str(arrays["header"])) | (header or {})))
    for name in nan or []:
        arrays[name] = arrays[name].astype(float)
        arrays[name][3] = np.nan
    for name, count in (frames or {}).items():
        arrays[name] = arrays[name][:count]
    for name in drop or []:
        del arrays[name]
    with path.open("wb") as out:
        np.savez(out, **arrays)


GENERATORS: dict[str, Callable[..., None]] = {
    f.__name__: f
    for f in (
        many_joints_xml,
        many_joints_ma,
        alias_bomb_yaml,
        deep_yaml,
        binary_file,
        utf16_yaml,
        latin1_yaml,
        deep_bvh,
        many_props_scene,
        repeated_expression,
        shipped,
        folder,
        clip_npz,
    )
}
"""Recipes for inputs made at test time, by name."""


def case_folders() -> list[Path]:
    """Every case of the corpus, sorted (group/case)."""
    return sorted(p.parent for p in CORPUS.glob("*/*/case.yaml"))


def case_id(folder: Path) -> str:
    return f"{folder.parent.name}/{folder.name}"


def load_case(folder: Path) -> dict[str, Any]:
    """A case's `case.yaml`, checked for its keys."""
    case = yaml.safe_load((folder / "case.yaml").read_text())
    unknown = set(case) - {"args", "exit", "timeout_s", "stdin", "env", "creates", "generate", "mask", "why"}
    assert not unknown, f"{case_id(folder)}: unknown keys {sorted(unknown)}"
    assert isinstance(case.get("args"), list), f"{case_id(folder)}: `args` must be a list"
    return case


def prepare(folder: Path, case: dict[str, Any], work: Path) -> set[str]:
    """Copy the inputs into `work`, make the generated ones, and return the input file names."""
    for item in folder.iterdir():
        if item.name not in ("case.yaml", "expected.txt"):
            (shutil.copytree if item.is_dir() else shutil.copy2)(item, work / item.name)
    for spec in case.get("generate") or []:
        spec = dict(spec)
        GENERATORS[spec.pop("recipe")](work / spec.pop("file"), **spec)
    return {str(p.relative_to(work)) for p in work.rglob("*")}


STDOUT_MARK = "--- stdout ---\n"
"""In `expected.txt`, what follows this line is the standard output (`validate` reports there)."""


def shown(result: subprocess.CompletedProcess[str], work: Path, masks: list[str] | None = None) -> str:
    """What the user saw: standard error, then standard output after `STDOUT_MARK` if there was any,
    with the case's folder as `{tmp}`, the repository as `{repo}`, and what the case's `mask`
    regexes match (wall-clock times) as `{masked}`."""
    text = result.stderr + (STDOUT_MARK + result.stdout if result.stdout else "")
    for mask in masks or []:
        text = re.sub(mask, "{masked}", text)
    return text.replace(str(work), "{tmp}").replace(str(REPO), "{repo}")


def run_quadpipe(case: dict[str, Any], work: Path, env: dict[str, str]) -> subprocess.CompletedProcess[str]:
    """Run the case's command in its own process group; on a hang, kill the group (workers too) and fail."""
    timeout = case.get("timeout_s", DEFAULT_TIMEOUT_S)
    with subprocess.Popen(
        [sys.executable, "-m", "quadpipe", *map(str, case["args"])],
        cwd=work,
        env=env,
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    ) as process:
        try:
            stdout, stderr = process.communicate(case.get("stdin"), timeout=timeout)
        except subprocess.TimeoutExpired:
            os.killpg(process.pid, signal.SIGKILL)
            process.communicate()
            pytest.fail(f"hung: still running after {timeout} s")
        finally:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(process.pid, signal.SIGKILL)
    return subprocess.CompletedProcess(process.args, process.returncode, stdout, stderr)


@pytest.mark.parametrize("folder", case_folders(), ids=case_id)
def test_bad_input_gets_its_one_clear_answer(folder: Path, tmp_path: Path, request: pytest.FixtureRequest) -> None:
    case = load_case(folder)
    work = tmp_path / "work"
    work.mkdir()
    # A short private TMPDIR: multiprocessing puts its sockets there, and a Unix socket's path
    # must stay under ~100 characters (pytest's tmp_path is too deep for that).
    private_tmp = Path(tempfile.mkdtemp(prefix="qp-"))
    request.addfinalizer(lambda: shutil.rmtree(private_tmp, ignore_errors=True))
    inputs = prepare(folder, case, work)
    env = dict(os.environ, COLUMNS="200", NO_COLOR="1", TMPDIR=str(private_tmp), PYTHONPATH=str(REPO))
    env.update({k: str(v) for k, v in (case.get("env") or {}).items()})
    result = run_quadpipe(case, work, env)
    seen = shown(result, work, case.get("mask"))
    expected_path = folder / "expected.txt"
    if os.environ.get("QUADPIPE_BLESS"):
        expected_path.write_text(seen)
    for leak in LEAKS:
        assert leak not in result.stderr + result.stdout, f"{leak!r} reached the user:\n{result.stderr}"
    assert result.returncode == case.get("exit", 1), result.stderr
    assert seen == expected_path.read_text()
    left = {str(p.relative_to(work)) for p in work.rglob("*")} - inputs - set(case.get("creates") or [])
    assert not left, f"left behind in the working folder: {sorted(left)}"
    assert not list(private_tmp.iterdir()), f"left in TMPDIR: {sorted(p.name for p in private_tmp.iterdir())}"


def test_the_corpus_covers_every_command_and_file_kind() -> None:
    """At least 150 cases, and every command of the CLI is tried with bad input."""
    from quadpipe.cli import app

    commands = {c.name or c.callback.__name__.replace("_", "-") for c in app.registered_commands}  # type: ignore[union-attr]  # typer names blender_script blender-script
    tried = {str(load_case(f)["args"][0]) for f in case_folders() if load_case(f)["args"]}
    assert len(case_folders()) >= 150
    assert commands - tried == set(), f"commands never given bad input: {sorted(commands - tried)}"
