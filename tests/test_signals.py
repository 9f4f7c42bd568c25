"""Interrupted runs: outputs as a transaction, and SIGINT/SIGTERM at random points of a bake and a batch.

Each trial runs the command line as a user would, waits until quadpipe has installed its signal
handlers (read from /proc, so that a trial never lands in the interpreter's own start-up), then
sends the signal after a seeded random delay spanning the whole run: loading, simulation,
export, the final renames, or after the end. Afterwards every output is there and valid or none
is; no staged file is left in the output folder, nothing in the private TMPDIR (no `pymp-*`);
stderr is empty or one `interrupted (SIG...)` line, never a traceback; the exit code is 0 or
128 + the signal.
"""

from __future__ import annotations

import json
import os
import random
import signal
import subprocess
import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import pytest

from quadpipe.core import atomic, signals
from quadpipe.core.errors import QuadpipeError
from quadpipe.core.signals import Interrupted, install_handlers, signals_deferred
from tests.conftest import REPO

TRIALS = 20
"""Seeded trials per command and signal mix."""

PARALLEL_TRIALS = 4
"""Trials run at once (each is a process; most of a trial's time is spent waiting)."""

BAKE_ARGS = ("bake", "-s", "0.5", "-c", "rigid", "-o", "out/x.glb", "-o", "out/x.npz", "-o", "out/x.usdc")
BAKE_FILES = ("x.glb", "x.npz", "x.usdc", "x.metrics.json")

BATCH_ARGS = ("batch", "-a", "dog", "-c", "rigid,spine_walk", "-s", "1.2", "-f", "glb", "-f", "npz", "-o", "out")
BATCH_ARGS += ("-j", "2", "-q")
BATCH_JOBS = ("dog_rigid_flat", "dog_spine_walk_flat")
BATCH_SUFFIXES = (".glb", ".npz", ".metrics.json")

pytestmark = pytest.mark.skipif(not Path("/proc/self/status").exists(), reason="reads signal handlers from /proc")


# --------------------------------------------------------------------------- in-process


def test_a_transaction_writes_every_file_or_none(tmp_path):
    with atomic.transaction():
        atomic.write_text(tmp_path / "a.txt", "a")
        atomic.write_bytes(tmp_path / "b.bin", b"b")
        assert sorted(p.name for p in tmp_path.iterdir() if not p.name.startswith(".")) == []
    assert (tmp_path / "a.txt").read_text() == "a" and (tmp_path / "b.bin").read_bytes() == b"b"
    with pytest.raises(KeyboardInterrupt), atomic.transaction():
        atomic.write_text(tmp_path / "a.txt", "new a")
        atomic.write_text(tmp_path / "c.txt", "c")
        raise KeyboardInterrupt
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.txt", "b.bin"]
    assert (tmp_path / "a.txt").read_text() == "a"


def test_a_failed_write_inside_a_transaction_leaves_the_others_staged(tmp_path):
    with atomic.transaction():
        atomic.write_text(tmp_path / "kept.txt", "kept")
        with pytest.raises(ValueError), atomic.atomic_output(tmp_path / "dropped.txt", "w"):
            raise ValueError("writer failed")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["kept.txt"]


def test_staged_files_of_dead_processes_are_removed_and_live_ones_kept(tmp_path):
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    stale = tmp_path / f".x.glb.tmp-{dead.stdout.strip()}-abcdefgh.part"
    live = tmp_path / f".x.glb.tmp-{os.getppid()}-abcdefgh.part"
    stale.write_text(""), live.write_text("")
    atomic.write_text(tmp_path / "x.glb", "x")
    assert sorted(p.name for p in tmp_path.iterdir()) == [live.name, "x.glb"]


def test_a_commit_refuses_a_target_that_became_a_folder_and_renames_nothing(tmp_path):
    with pytest.raises(QuadpipeError) as caught, atomic.transaction():
        atomic.write_text(tmp_path / "a.txt", "a")
        atomic.write_text(tmp_path / "b.txt", "b")
        (tmp_path / "b.txt").mkdir()
    assert caught.value.issues[0].code == "unwritable-output"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["b.txt"]


def test_a_signal_during_a_deferred_block_is_delivered_after_it(monkeypatch, tmp_path):
    previous = {signum: signal.getsignal(signum) for signum in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)}
    monkeypatch.setattr(signals, "_received", [])
    monkeypatch.setattr(sys, "unraisablehook", sys.unraisablehook)
    install_handlers()
    steps = []
    try:
        with pytest.raises(Interrupted) as caught, signals_deferred():
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(0.05)
            steps.append("block ended")
        assert steps == ["block ended"] and caught.value.exit_code == 143 and caught.value.name == "SIGTERM"
        with pytest.raises(Interrupted), atomic.transaction():  # once interrupted, nothing more is committed
            atomic.write_text(tmp_path / "late.txt", "late")
        assert list(tmp_path.iterdir()) == []
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)


# --------------------------------------------------------------------------- command line


@dataclass(frozen=True)
class Trial:
    """One run of a command: how it ended, and the folder it ran in."""

    returncode: int
    stderr: str
    folder: Path


def _handlers_installed(pid: int) -> bool:
    """Whether the process catches SIGTERM yet (quadpipe's handlers are installed), or is gone."""
    try:
        status = Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return True
    caught = next(line for line in status.splitlines() if line.startswith("SigCgt:"))
    return bool(int(caught.split()[1], 16) >> (signal.SIGTERM - 1) & 1)


def _start(folder: Path, args: tuple[str, ...], *, new_session: bool = False) -> subprocess.Popen:
    """Start `quadpipe ARGS` in `folder` with empty `out/` and private `tmp/` (its TMPDIR)."""
    (folder / "out").mkdir(parents=True)
    (folder / "tmp").mkdir()
    env = dict(os.environ, PYTHONPATH=str(REPO), TMPDIR=str(folder / "tmp"), COLUMNS="200", NO_COLOR="1")
    return subprocess.Popen(
        [sys.executable, "-m", "quadpipe", *args],
        cwd=folder,
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=new_session,
    )


def _run_trial(folder: Path, args: tuple[str, ...], signum: int | None, delay_s: float) -> Trial:
    """Run `quadpipe ARGS` in `folder` (with a private TMPDIR), signalling it after `delay_s`."""
    process = _start(folder, args)
    while not _handlers_installed(process.pid):
        time.sleep(0.002)
    try:
        process.wait(timeout=delay_s)
    except subprocess.TimeoutExpired:
        if signum is not None:
            process.send_signal(signum)
    _, stderr = process.communicate(timeout=120)
    return Trial(process.returncode, stderr, folder)


def _valid(path: Path) -> bool:
    """Whether a complete output holds what its suffix says."""
    data = path.read_bytes()
    if path.name.endswith(".json"):
        return isinstance(json.loads(data), dict)
    if path.suffix == ".npz":
        from quadpipe.exporters.npz import load_clip

        return load_clip(path).frame_count > 0
    magic = {".glb": b"glTF", ".usdc": b"PXR-USDC"}[path.suffix]
    return data.startswith(magic)


def _check(trial: Trial, signum: int, groups: list[list[str]]) -> None:
    """Every group of files whole or absent, nothing else left anywhere, one line or none on stderr."""
    out, tmp = trial.folder / "out", trial.folder / "tmp"
    assert "Traceback" not in trial.stderr and "Error" not in trial.stderr, trial.stderr
    assert trial.returncode in (0, 128 + signum), (trial.returncode, trial.stderr)
    if trial.returncode == 0:
        assert trial.stderr == ""
    else:
        assert trial.stderr.count("\n") == 1, trial.stderr
        assert trial.stderr.startswith(f"interrupted ({signal.Signals(signum).name}): "), trial.stderr
    expected = {name for group in groups for name in group}
    present = {path.name for path in out.iterdir()}
    assert present <= expected, sorted(present - expected)  # no staged file, no staging folder
    for group in groups:
        there = [name for name in group if name in present]
        assert there in ([], group), there
        assert all(_valid(out / name) for name in there)
    if trial.returncode == 0:
        assert present == expected
    assert list(tmp.iterdir()) == []  # no pymp-* folder, no temporary file


def _trials(tmp_path: Path, args: tuple[str, ...], seed: int, duration_s: float) -> list[tuple[int, Trial]]:
    """`TRIALS` runs, each sent SIGINT or SIGTERM (seeded) at a random time up to a little past `duration_s`."""
    rng = random.Random(seed)
    plans = [(rng.choice((signal.SIGINT, signal.SIGTERM)), rng.uniform(0.0, 1.1 * duration_s)) for _ in range(TRIALS)]
    with ThreadPoolExecutor(PARALLEL_TRIALS) as pool:
        trials = pool.map(lambda item: _run_trial(tmp_path / f"t{item[0]}", args, *item[1]), enumerate(plans))
        return [(signum, trial) for (signum, _), trial in zip(plans, trials, strict=True)]


def _duration(tmp_path: Path, args: tuple[str, ...]) -> float:
    """How long an uninterrupted run takes here (it must succeed)."""
    start = time.perf_counter()
    trial = _run_trial(tmp_path / "whole", args, None, 600.0)
    assert trial.returncode == 0, trial.stderr
    return time.perf_counter() - start


@pytest.mark.slow
def test_a_signalled_bake_writes_every_file_or_none(tmp_path):
    duration = _duration(tmp_path, BAKE_ARGS)
    outcomes = []
    for signum, trial in _trials(tmp_path, BAKE_ARGS, seed=17, duration_s=duration):
        _check(trial, signum, [list(BAKE_FILES)])
        outcomes.append(trial.returncode)
    assert any(code != 0 for code in outcomes)


@pytest.mark.slow
def test_a_signalled_batch_writes_whole_jobs_and_leaves_no_staging(tmp_path):
    duration = _duration(tmp_path, BATCH_ARGS)
    outcomes = []
    groups = [[f"{job}{suffix}" for suffix in BATCH_SUFFIXES] for job in BATCH_JOBS]
    for signum, trial in _trials(tmp_path, BATCH_ARGS, seed=1717, duration_s=duration):
        _check(trial, signum, groups)
        outcomes.append(trial.returncode)
    assert any(code != 0 for code in outcomes)


def test_a_batch_removes_what_killed_runs_left(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    pid = dead.stdout.strip()
    leftovers = [out / f".dog_rigid_flat.glb.tmp-{pid}-abcdefgh.glb", out / f".dog_rigid_flat.bin.tmp-{pid}-x1y2z3w4"]
    for path in leftovers:
        path.write_text("half")
    old_staging = out / ".dog_rigid_flat.partial-k2j3h4"
    old_staging.mkdir()
    (old_staging / "dog_rigid_flat.glb").write_text("half")
    from quadpipe.batch import BatchPlan, run_batch

    report = run_batch(BatchPlan(animals=["dog"], controllers=["rigid"], seconds=0.2, output=str(out)), progress=False)
    assert report.exit_code == 0
    assert sorted(p.name for p in out.iterdir()) == ["dog_rigid_flat.glb", "dog_rigid_flat.metrics.json"]


def test_workers_end_quietly_on_a_ctrl_c_to_the_whole_terminal(tmp_path):
    """Ctrl-C reaches every process of the terminal's group: the workers must not print."""
    args = (*BATCH_ARGS[:6], "5", *BATCH_ARGS[7:])
    process = _start(tmp_path, args, new_session=True)
    timer = threading.Timer(4.0, os.killpg, (process.pid, signal.SIGINT))
    timer.start()
    _, stderr = process.communicate(timeout=120)
    timer.cancel()
    assert process.returncode == 130 and stderr.startswith("interrupted (SIGINT): "), stderr
    assert stderr.count("\n") == 1, stderr
    assert list((tmp_path / "tmp").iterdir()) == []
    assert all(not p.name.startswith(".") for p in (tmp_path / "out").iterdir())
