"""`tools/gallery.py`: which gaits the gallery shows, and the page it writes."""

from __future__ import annotations

import importlib.util
import json

import pytest

from quadpipe.core import configs
from tests.conftest import REPO


@pytest.fixture(scope="module")
def gallery():
    spec = importlib.util.spec_from_file_location("gallery", REPO / "tools" / "gallery.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize(
    ("animal", "fastest"), [("dog", "gallop"), ("horse", "gallop"), ("cat", "gallop"), ("elephant", "amble")]
)
def test_the_gallery_shows_the_walk_and_the_fastest_gait_of_the_species(gallery, animal, fastest):
    assert gallery.gaits_of(animal) == ["walk", fastest]


def test_every_animal_has_two_gaits_each_with_a_controller(gallery):
    controllers = set(configs.available("controllers"))
    for animal in configs.available("animals"):
        gaits = gallery.gaits_of(animal)
        assert len(gaits) == 2 and set(gaits) <= controllers, animal


def test_the_page_has_a_table_per_animal_linking_every_file(gallery):
    rows = [
        {
            "animal": animal,
            "gait": gait,
            "measured": "lateral-sequence walk",
            "froude": 0.15,
            "speed_m_s": 1.0,
            "period_s": None,
            "fell": gait == "gallop",
            "files": {
                "side": f"{animal}_{gait}_side.png",
                "rear": f"{animal}_{gait}_rear.png",
                "video": f"{animal}_{gait}.mp4",
            },
        }
        for animal in ("dog", "horse")
        for gait in ("walk", "gallop")
    ]
    page = gallery.page(rows)
    assert page.count("\n## ") == 2 and "python tools/gallery.py" in page
    for row in rows:
        for name in row["files"].values():
            assert f"(gallery/{name})" in page
    assert page.count("FELL") == 2 and "stride - s" in page


def test_the_figures_are_kept_as_the_page_shows_them(gallery):
    row = {"froude": 0.14222901765866489, "speed_m_s": 1.143156488317599, "period_s": None, "animal": "bear"}
    assert gallery.rounded_figures(row) == {"froude": 0.14, "speed_m_s": 1.14, "period_s": None, "animal": "bear"}
    for kept in json.loads((REPO / gallery.FIGURES).read_text()):
        assert kept == gallery.rounded_figures(kept), kept["animal"]
