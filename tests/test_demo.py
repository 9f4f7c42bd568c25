"""The README's first command runs end to end and leaves every promised file."""

from __future__ import annotations

import json
import os
import subprocess

import pytest
from PIL import Image

from tests.conftest import REPO

DEMO_FILES = (
    "dog.xml",
    "dog_hill.npz",
    "dog_hill.glb",
    "dog_hill.usdc",
    "dog_hill.bvh",
    "dog_hill.metrics.json",
    "dog_hill.png",
    "dog_hill.mp4",
)


@pytest.mark.slow
def test_the_demo_writes_the_model_the_baked_walk_and_the_pictures(tmp_path):
    env = dict(os.environ, QUADPIPE_DEMO_OUT=str(tmp_path))
    result = subprocess.run(["bash", "scripts/demo.sh"], cwd=REPO, env=env, capture_output=True, text=True, timeout=900)
    assert result.returncode == 0, result.stderr[-3000:]
    for name in DEMO_FILES:
        assert (tmp_path / name).stat().st_size > 100, name
    metrics = json.loads((tmp_path / "dog_hill.metrics.json").read_text())["animals"]["dog"]
    assert metrics["forward_hp"] > 2 and not metrics["fell"]
    width, height = Image.open(tmp_path / "dog_hill.png").size
    assert width > 1000 and height > 500  # a contact sheet, not a single frame
