"""The benchmark script runs end to end and writes a complete report (no timing thresholds).

Every section runs in this process on the smallest plan that still touches everything the
quick one does: each shipped controller on the dog and each animal under `spine_walk` (one
repetition of a few steps each), crowds of one and two dogs (every variant: threads, worker
processes, rollout), a short bake through the command line, every exporter, a few rendered
frames, and a batch of the dog under every controller. Only `--quick`'s own start-up section
runs through `main`, to check the command line and the JSON file it writes.
"""

from __future__ import annotations

import importlib
import json
import math
import subprocess
import sys
from dataclasses import replace
from pathlib import Path
from types import ModuleType

import pytest

from tests.conftest import REPO

BENCH = REPO / "benchmarks" / "bench.py"
SECTIONS = ("controllers", "crowds", "bake", "startup", "exporters", "render", "batch")
MACHINE_KEYS = ("cpu", "logical_cores", "os", "python", "mujoco", "numpy", "quadpipe", "git_commit")
COMMAND_TIMEOUT_S = 600


def run_bench(*args: str) -> subprocess.CompletedProcess:
    """Run benchmarks/bench.py with this Python, from the repository root."""
    return subprocess.run(
        [sys.executable, str(BENCH), *args], cwd=REPO, capture_output=True, text=True, timeout=COMMAND_TIMEOUT_S
    )


def measured_rows(section: dict) -> list[dict]:
    return [row for row in section["rows"] if row["figures"]]


@pytest.fixture(scope="module")
def bench() -> ModuleType:
    """benchmarks/bench.py as the module `bench`, importable by name while the tests run (its
    crowd worker processes are spawned and import it)."""
    with pytest.MonkeyPatch.context() as patch:
        patch.syspath_prepend(str(BENCH.parent))
        yield importlib.import_module("bench")
        sys.modules.pop("bench", None)


@pytest.fixture(scope="module")
def smoke_plan(bench: ModuleType):
    """`--quick`, smaller: one repetition of a few steps, crowds of 1 and 2 dogs, a 0.5 s clip,
    2 rendered frames, a batch of the dog alone; the same animals and controllers."""
    return replace(
        bench.QUICK,
        name="smoke",
        repeats=1,
        controller_seconds=0.02,
        crowd_sizes=(1, 2),
        crowd_repeats=1,
        crowd_seconds=0.02,
        clip_seconds=0.5,
        bake_runs=1,
        startup_runs=1,
        export_repeats=1,
        render_repeats=1,
        render_frames=2,
        batch_animals=("dog",),
        batch_seconds=0.05,
    )


@pytest.fixture(scope="module")
def smoke_report(bench: ModuleType, smoke_plan) -> dict:
    """The report of every section on `smoke_plan`, as bench.py builds it for its JSON file."""
    return bench.run_benchmarks(smoke_plan, list(bench.SECTIONS))


@pytest.mark.slow
def test_every_section_reports_finite_figures(smoke_report, smoke_plan):
    assert smoke_report["mode"] == smoke_plan.name
    assert set(smoke_report["sections"]) == set(SECTIONS)
    for name, section in smoke_report["sections"].items():
        assert measured_rows(section), f"{name}: no row was measured: {[r['status'] for r in section['rows']]}"
        for row in measured_rows(section):
            for figure_name, figure in row["figures"].items():
                where = f"{name} {row['labels']} {figure_name}"
                assert figure["unit"], where
                assert figure["samples"], where
                assert all(math.isfinite(v) for v in [figure["value"], *figure["samples"]]), where


@pytest.mark.slow
def test_the_report_describes_the_machine_and_covers_every_animal_and_controller(smoke_report, smoke_plan):
    from quadpipe.core import configs

    machine = smoke_report["machine"]
    assert all(machine.get(key) not in (None, "") for key in MACHINE_KEYS), machine
    rows = smoke_report["sections"]["controllers"]["rows"]
    assert {row["labels"]["animal"] for row in rows} == set(configs.available("animals"))
    assert {row["labels"]["controller"] for row in rows} == set(configs.available("controllers"))
    failed = [(row["labels"], row["status"]) for row in rows if not row["figures"]]
    assert not failed, failed
    bare_per_step = [row["figures"]["bare"]["value"] for row in measured_rows({"rows": rows})]
    assert all(value > 0 for value in bare_per_step)
    crowd_sizes = {row["labels"]["dogs"] for row in smoke_report["sections"]["crowds"]["rows"]}
    assert crowd_sizes == set(smoke_plan.crowd_sizes)


def test_quick_writes_a_json_report_that_compare_reads(tmp_path: Path):
    path = tmp_path / "quick.json"
    done = run_bench("--quick", "--only", "startup", "--json", str(path))
    assert done.returncode == 0, done.stderr[-3000:]
    written = json.loads(path.read_text())
    assert written["mode"] == "quick" and set(written["sections"]) == {"startup"}
    assert measured_rows(written["sections"]["startup"])
    compared = run_bench("--compare", str(path), str(path))
    assert compared.returncode == 0, compared.stderr
    assert "startup | quadpipe --help | wall" in compared.stdout


def report(value: float, *, commit: str = "abc", mode: str = "quick") -> dict:
    """A minimal report with one figure, as bench.py writes them."""
    figure = {"value": value, "unit": "us/step", "better": "lower", "samples": [value]}
    row = {"labels": {"animal": "dog", "controller": "rigid"}, "figures": {"with": figure}, "status": "ok"}
    section = {"title": "t", "rows": [row], "notes": [], "wall_s": 1.0}
    return {
        "schema": 1,
        "mode": mode,
        "started": "now",
        "machine": {"cpu": "x", "git_commit": commit},
        "sections": {"controllers": section},
    }


def test_compare_prints_new_over_old_ratios_and_verdicts(tmp_path: Path):
    old, new = tmp_path / "old.json", tmp_path / "new.json"
    old.write_text(json.dumps(report(100.0)))
    new.write_text(json.dumps(report(250.0, commit="def")))
    done = run_bench("--compare", str(old), str(new))
    assert done.returncode == 0, done.stderr
    line = next(line for line in done.stdout.splitlines() if "controllers | dog rigid | with" in line)
    assert "2.50" in line and "worse" in line
    assert "git_commit differs: abc -> def" in done.stdout


def test_compare_refuses_a_file_that_is_not_a_report(tmp_path: Path):
    other = tmp_path / "other.json"
    other.write_text(json.dumps({"hello": 1}))
    done = run_bench("--compare", str(other), str(other))
    assert done.returncode != 0
    assert "not a quadpipe benchmark report" in done.stderr


def test_pool_keeps_every_runs_samples_and_their_median(bench: ModuleType):
    first, second = report(100.0, commit="abc"), report(300.0, commit="abc")
    pooled = bench.pool_reports([first, second])
    figure = pooled["sections"]["controllers"]["rows"][0]["figures"]["with"]
    assert figure["samples"] == [100.0, 300.0] and figure["value"] == 200.0
    assert [run["git_commit"] for run in pooled["pooled_from"]] == ["abc", "abc"]
    assert first["sections"]["controllers"]["rows"][0]["figures"]["with"]["samples"] == [100.0], "the runs stay as read"


def test_the_report_names_the_tree_whose_code_it_timed(bench: ModuleType, tmp_path: Path, monkeypatch):
    """A run with another checkout's `quadpipe` first on the path (comparing two commits with
    one bench.py) records that checkout, not the script's."""
    import importlib.machinery

    other = tmp_path / "quadpipe" / "__init__.py"
    spec = importlib.machinery.ModuleSpec("quadpipe", None, origin=str(other))
    monkeypatch.setattr(bench.importlib.util, "find_spec", lambda name: spec if name == "quadpipe" else None)
    assert bench.measured_tree() == tmp_path.resolve()
