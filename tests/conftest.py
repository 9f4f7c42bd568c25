"""Shared test helpers: built animals are cached per session (building is deterministic)."""

from __future__ import annotations

import functools
import os
import subprocess
import sys
import warnings
from pathlib import Path
from unittest import mock

import pytest

REPO = Path(__file__).resolve().parent.parent
FIXTURES = REPO / "tests" / "fixtures"

os.environ["PYTHONPATH"] = os.pathsep.join(filter(None, [str(REPO), os.environ.get("PYTHONPATH")]))
"""Every subprocess a test starts (the CLI, the benchmarks, the demo) imports this checkout's
quadpipe, not whichever checkout the environment's editable install points at."""


@functools.cache
def built_animal(name: str):
    """The `BuiltAnimal` of a built-in animal (cached)."""
    from quadpipe.animals.library import load_animal
    from quadpipe.animals.model import build_animal

    return build_animal(load_animal(name))


def run_cli(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    """Run `python -m quadpipe ARGS` in a subprocess, as a user would."""
    env = dict(os.environ, COLUMNS="200", NO_COLOR="1")
    return subprocess.run(
        [sys.executable, "-m", "quadpipe", *args], cwd=cwd or REPO, capture_output=True, text=True, env=env, timeout=300
    )


SHARED_SCOPES = {"tests/test_feet.py": "tests/test_gaits.py"}
"""Test modules that measure the simulations another module caches (functools.cache is per
process), mapped to that module: under `--dist loadscope` (scripts/test.sh) they run on its
worker, so each simulation runs once in the whole suite."""


def pytest_xdist_make_scheduler(config, log):
    """Under `--dist loadscope`, group the modules of SHARED_SCOPES with the module whose
    simulations they reuse (otherwise xdist's own scheduling)."""
    if config.getoption("dist") != "loadscope":
        return None
    from xdist.scheduler import LoadScopeScheduling

    class SharedScopeScheduling(LoadScopeScheduling):
        def _split_scope(self, nodeid: str) -> str:
            scope = super()._split_scope(nodeid)
            return SHARED_SCOPES.get(scope.split("::", 1)[0], scope)

    return SharedScopeScheduling(config, log)


@pytest.fixture
def cli():
    """The `run_cli` helper as a fixture."""
    return run_cli


def invoke_cli(*args: str) -> subprocess.CompletedProcess:
    """Run the typer app on ARGS in this process (typer's CliRunner), for tests about what a
    command writes rather than about the process: no interpreter to start, no modules to import
    again. `quadpipe.cli.main`'s error handling is not in the way, so an error the command
    raises (a `QuadpipeError` included) propagates and fails the test; typer's own usage errors
    exit 2 with their message on stderr, as in a real process. The warning filters and the
    environment the command changes (it hides library warnings, `PYTHONWARNINGS` included) are
    restored afterwards, so that later tests in this process, and their subprocesses, still
    see warnings."""
    from typer.testing import CliRunner

    from quadpipe.cli import app

    with warnings.catch_warnings(), mock.patch.dict(os.environ):
        result = CliRunner().invoke(app, list(args), catch_exceptions=False)
    return subprocess.CompletedProcess(["quadpipe", *args], result.exit_code, result.stdout, result.stderr)


@functools.cache
def cached_simulation(
    animal: str, controller: str, seconds: float, scene: str | None = None, parameters: tuple[tuple[str, str], ...] = ()
):
    """`quadpipe.sim.simulation.simulate`, run once per session for the same arguments."""
    from quadpipe.sim.simulation import simulate

    return simulate(animal, controller, seconds=seconds, scene=scene, parameters=dict(parameters))
