"""The benchmark script runs end to end and writes a complete report (no timing thresholds)."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

from tests.conftest import REPO

BENCH = REPO / "benchmarks" / "bench.py"
SECTIONS = ("controllers", "crowds", "bake", "startup", "exporters", "render", "batch")
MACHINE_KEYS = ("cpu", "logical_cores", "os", "python", "mujoco", "numpy", "quadpipe", "git_commit")
QUICK_TIMEOUT_S = 600


def run_bench(*args: str) -> subprocess.CompletedProcess:
    """Run benchmarks/bench.py with this Python, from the repository root."""
    return subprocess.run(
        [sys.executable, str(BENCH), *args], cwd=REPO, capture_output=True, text=True, timeout=QUICK_TIMEOUT_S
    )


def measured_rows(section: dict) -> list[dict]:
    return [row for row in section["rows"] if row["figures"]]


@pytest.fixture(scope="module")
def quick_report(tmp_path_factory) -> dict:
    """The JSON report of one `--quick` run."""
    path = tmp_path_factory.mktemp("bench") / "quick.json"
    done = run_bench("--quick", "--json", str(path))
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(path.read_text())


@pytest.mark.slow
def test_quick_report_has_every_section_with_finite_figures(quick_report):
    assert quick_report["mode"] == "quick"
    assert set(quick_report["sections"]) == set(SECTIONS)
    for name, section in quick_report["sections"].items():
        assert measured_rows(section), f"{name}: no row was measured: {[r['status'] for r in section['rows']]}"
        for row in measured_rows(section):
            for figure_name, figure in row["figures"].items():
                where = f"{name} {row['labels']} {figure_name}"
                assert figure["unit"], where
                assert figure["samples"], where
                assert all(math.isfinite(v) for v in [figure["value"], *figure["samples"]]), where


@pytest.mark.slow
def test_quick_report_describes_the_machine_and_covers_every_animal_and_controller(quick_report):
    from quadpipe.core import configs

    machine = quick_report["machine"]
    assert all(machine.get(key) not in (None, "") for key in MACHINE_KEYS), machine
    rows = quick_report["sections"]["controllers"]["rows"]
    assert {row["labels"]["animal"] for row in rows} == set(configs.available("animals"))
    assert {row["labels"]["controller"] for row in rows} == set(configs.available("controllers"))
    bare_per_step = [row["figures"]["bare"]["value"] for row in measured_rows({"rows": rows})]
    assert all(value > 0 for value in bare_per_step)
    crowd_sizes = {row["labels"]["dogs"] for row in quick_report["sections"]["crowds"]["rows"]}
    assert crowd_sizes == {1, 10}


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
