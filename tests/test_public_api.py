"""The curated public API in `quadpipe/__init__.py`: every name resolves, lazily, and works."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

import quadpipe
from tests.conftest import REPO

HEAVY_MODULES = ("mujoco", "numba", "pxr", "open3d", "trimesh")


@pytest.mark.parametrize("name", sorted(quadpipe.PUBLIC_API))
def test_every_public_name_resolves_to_its_module(name: str) -> None:
    value = getattr(quadpipe, name)
    assert value.__module__.startswith(quadpipe.PUBLIC_API[name])
    assert name in dir(quadpipe)


def test_all_lists_exactly_the_public_names() -> None:
    assert quadpipe.__all__ == ["__version__", *quadpipe.PUBLIC_API]


def test_an_unknown_name_is_an_attribute_error() -> None:
    with pytest.raises(AttributeError, match="no attribute 'simulat'"):
        _ = quadpipe.simulat  # type: ignore[attr-defined]


def test_importing_quadpipe_loads_no_heavy_library() -> None:
    code = f"import sys, quadpipe; print(sorted(m for m in {HEAVY_MODULES!r} if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_the_docstring_example_simulates_exports_and_analyses(tmp_path) -> None:
    result = quadpipe.simulate("dog", "walk", seconds=3)
    quadpipe.export_clip(result.clip, tmp_path / "dog.npz")
    again = quadpipe.load_clip(tmp_path / "dog.npz")
    np.testing.assert_array_equal(again.animals[0].positions, result.clip.animals[0].positions)
    assert result.metrics["animals"]["dog"]["distance_hp"] > 1.0
    assert quadpipe.analyze_clip(result.clip).animals[0].gait.label.endswith("walk")
    sim = quadpipe.Simulation.build("dog", "walk")
    for _ in range(12):
        sim.step()
    assert sim.time == pytest.approx(12 * 1 / 480)  # the dog steps at 1/480 s
