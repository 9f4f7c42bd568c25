"""Each species' own gaits: the repertoire in every animal config, how it reaches the
controllers (`repertoire_parameters`, offered as a scene offers its goals), and the warning
when an animal is asked for a gait it does not use.

The gaits' motion (footfalls, flight, falls) is measured in tests/test_gaits.py.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from quadpipe.animals.library import GAIT_NAMES, load_animal, repertoire_parameters
from quadpipe.core import configs
from quadpipe.core.errors import QuadpipeError
from tests.conftest import run_cli

ANIMALS = tuple(configs.available("animals"))

NO_CONTROLLER = {"half_bound"}
"""Gaits an animal config may list that no shipped controller runs."""

REPERTOIRES = {
    "horse": ({"walk", "trot", "canter", "gallop"}, "transverse"),
    "dog": ({"walk", "trot", "gallop"}, "rotary"),
    "lion": ({"walk", "trot", "gallop"}, "rotary"),
    "cat": ({"walk", "trot", "gallop", "half_bound", "bound"}, "rotary"),
    "rat": ({"walk", "trot", "gallop", "half_bound", "bound"}, "rotary"),
    "cow": ({"walk", "trot", "gallop"}, "transverse"),
    "goat": ({"walk", "trot", "gallop"}, "transverse"),
    "pig": ({"walk", "trot", "gallop"}, "transverse"),
    "bear": ({"walk", "trot", "gallop"}, "rotary"),
    "elephant": ({"walk", "amble"}, None),
}
"""Issue #13's repertoires, and each species' gallop sequence (None: it does not gallop)."""

FLYING_GAITS = {"trot", "pace", "canter", "gallop", "bound", "half_bound"}
"""Gaits with an aerial phase, which an elephant never uses."""


def test_every_animal_is_listed_here():
    assert set(ANIMALS) == set(REPERTOIRES)


@pytest.mark.parametrize("animal", ANIMALS)
def test_each_animal_declares_its_own_repertoire(animal):
    gaits, sequence = REPERTOIRES[animal]
    loaded = load_animal(animal)
    assert set(loaded.gaits) == gaits
    assert (loaded.gaits["gallop"].sequence if "gallop" in loaded.gaits else None) == sequence
    assert list(loaded.gaits) == [name for name in GAIT_NAMES if name in gaits]  # slowest first


@pytest.mark.parametrize("animal", ANIMALS)
def test_every_gait_of_a_repertoire_has_a_controller_and_the_walk_starts_at_rest(animal):
    gaits = load_animal(animal).gaits
    assert set(gaits) - NO_CONTROLLER <= set(configs.available("controllers"))
    assert gaits["walk"].froude[0] == 0


@pytest.mark.parametrize("animal", ANIMALS)
def test_each_faster_gait_starts_before_the_slower_one_ends(animal):
    """Consecutive gaits overlap (auto_gait blends across the overlap), and none starts below the walk."""
    gaits = load_animal(animal).gaits
    ladder = [gaits[name].froude for name in ("walk", "trot", "amble", "gallop") if name in gaits]
    for (_, slower_top), (faster_bottom, _) in zip(ladder, ladder[1:]):
        assert faster_bottom <= slower_top


def test_the_elephant_never_uses_a_gait_with_an_aerial_phase():
    assert not set(load_animal("elephant").gaits) & FLYING_GAITS


def test_the_repertoire_reaches_the_controllers_as_parameters():
    dog, elephant = repertoire_parameters(load_animal("dog")), repertoire_parameters(load_animal("elephant"))
    assert dog["gallop_rotary"] == "1" and dog["uses_trot"] == "1" and dog["trot_froude_max"] == "3"
    assert elephant["uses_trot"] == "0" and elephant["uses_gallop"] == "0" and elephant["top_froude"] == "1.2"
    assert "trot_froude_min" not in elephant


def compiled_value(animal: str, controller: str, name: str, parameters: dict[str, str] | None = None) -> float:
    """A parameter of a controller compiled for one animal in the flat scene, at t = 0."""
    from quadpipe.sim.simulation import Simulation

    compiled, _ = Simulation.build(animal, None).compile_controller(controller, parameters)
    return float(compiled.parameters[name]({"t": np.array([0.0])})[0])


@pytest.mark.parametrize("animal", [animal for animal, (gaits, _) in REPERTOIRES.items() if "gallop" in gaits])
def test_the_gallop_takes_its_sequence_from_the_species(animal):
    rotary = REPERTOIRES[animal][1] == "rotary"
    lf, rf = (compiled_value(animal, "gallop", name) for name in ("phase_lf", "phase_rf"))
    assert (lf > rf) == rotary  # rotary: the right fore lands first, transverse: the left fore


def test_what_the_caller_sets_wins_over_the_species():
    assert compiled_value("dog", "gallop", "gallop_rotary", {"gallop_rotary": "0"}) == 0


def test_a_controller_that_declares_no_repertoire_parameter_takes_none():
    assert compiled_value("elephant", "trot", "phase_lf") == 0.5


def pair_scene(folder: Path, species: tuple[str, str]) -> Path:
    """Two animals of the given species side by side."""
    path = folder / "pair.yaml"
    animals = [
        {"name": "a", "species": species[0], "at": [0, 0]},
        {"name": "b", "species": species[1], "at": [0, "4 HP"]},
    ]
    path.write_text(yaml.safe_dump({"schema": 1, "name": "pair", "animals": animals}, sort_keys=False))
    return path


def test_species_that_carry_their_tails_differently_share_one_walk_with_a_warning(tmp_path):
    """The dog lifts its tail, the horse does not: one walk runs them both, every tail in its
    rest shape (the walk's own `tail_lift`), and the run warns once (`mixed-carriage`)."""
    from quadpipe.sim.simulation import Simulation

    sim = Simulation.build("dog", "walk", scene=str(pair_scene(tmp_path, ("dog", "horse"))))
    compiled = sim.runtime.compiled
    assert float(compiled.parameters["tail_lift"]({"t": np.array([0.0])})[0]) == 0.0
    assert [issue.code for issue in sim.warnings] == ["mixed-carriage"]
    assert sim.warnings[0].where is not None and sim.warnings[0].where.file.endswith("horse.yaml")
    alone = Simulation.build("dog", "walk", scene=str(pair_scene(tmp_path, ("dog", "lion"))))
    assert float(alone.runtime.compiled.parameters["tail_lift"]({"t": np.array([0.0])})[0]) > 0.0
    assert not alone.warnings


def test_species_that_gallop_differently_cannot_share_one_gallop(tmp_path):
    from quadpipe.sim.simulation import Simulation

    with pytest.raises(QuadpipeError) as raised:
        Simulation.build("dog", "gallop", scene=str(pair_scene(tmp_path, ("dog", "horse"))))
    issue = raised.value.issues[0]
    assert issue.code == "mixed-repertoires" and "gallop_rotary" in issue.message
    assert issue.where is not None and issue.where.file.endswith("horse.yaml")
    # set for both, it runs; and species that agree need nothing set
    Simulation.build(
        "dog", "gallop", scene=str(pair_scene(tmp_path, ("dog", "horse"))), parameters={"gallop_rotary": "1"}
    )
    Simulation.build("dog", "gallop", scene=str(pair_scene(tmp_path, ("dog", "lion"))))


def test_a_gait_the_species_does_not_use_runs_with_one_warning():
    from quadpipe.sim.simulation import simulate

    result = simulate("elephant", "trot", seconds=0.5)
    assert [issue.code for issue in result.warnings] == ["gait-not-in-repertoire"]
    message = "the elephant does not trot (its gaits: walk, amble); running it anyway"
    assert result.warnings[0].severity == "warning" and result.warnings[0].message == message
    assert result.metrics["warnings"] == [message]
    assert result.clip.metadata["warnings"] == message
    assert result.clip.frame_count > 1  # it ran


@pytest.mark.parametrize(
    ("animal", "controller"), [("elephant", "amble"), ("dog", "gallop"), ("elephant", "auto_gait")]
)
def test_a_gait_of_the_repertoire_or_a_controller_that_is_no_gait_does_not_warn(animal, controller):
    from quadpipe.sim.simulation import simulate

    result = simulate(animal, controller, seconds=0.2)
    assert result.warnings == () and "warnings" not in result.metrics and "warnings" not in result.clip.metadata


def test_the_command_line_prints_the_warning_once_on_stderr(tmp_path):
    done = run_cli("simulate", "-a", "elephant", "-c", "bound", "-s", "0.3", "-o", str(tmp_path / "e.npz"))
    assert done.returncode == 0, done.stderr
    lines = [line for line in done.stderr.splitlines() if "gait-not-in-repertoire" in line]
    assert len(lines) == 1 and "the elephant does not bound (its gaits: walk, amble)" in lines[0]
    assert lines[0].split(":")[0].endswith("elephant.yaml")
    assert "does not" not in done.stdout


@pytest.mark.parametrize(
    ("gaits", "message"),
    [
        ("{walk: {froude: [0.5, 0.2]}}", "not a range"),
        ("{walk: {froude: [0, .inf]}}", "not a range of finite"),
        ("{walk: {froude: [0, 0.5]}, trott: {froude: [0.4, 2]}}", "trott"),
    ],
)
def test_a_bad_repertoire_is_an_error_at_its_line(tmp_path, gaits, message):
    source = (configs.config_root() / "animals" / "dog.yaml").read_text()
    text = source[: source.index("gaits:")].replace("../", str(configs.config_root()) + "/") + f"gaits: {gaits}\n"
    path = tmp_path / "dog.yaml"
    path.write_text(text)
    with pytest.raises(QuadpipeError) as raised:
        load_animal(path)
    assert message in raised.value.format()
    assert all(issue.where is not None and issue.where.line == text.count("\n") for issue in raised.value.issues)


def auto_gait_blend(animal: str) -> tuple[np.ndarray, np.ndarray]:
    """auto_gait compiled for an animal, its target ramping from Fr 0.05 to 5 over 100 s:
    the target Froude numbers, and per instant phase_lf, phase_rh, phase_rf and duty."""
    from quadpipe.sim.simulation import Simulation

    ramp = {"start_froude": "0.05", "end_froude": "5", "ramp_start": "0 s", "ramp_end": "100 s"}
    compiled, _ = Simulation.build(animal, None).compile_controller("auto_gait", ramp)
    names = ("froude", "phase_lf", "phase_rh", "phase_rf", "duty")
    rows = np.array(
        [
            [float(compiled.parameters[name]({"t": np.array([t])})[0]) for name in names]
            for t in np.linspace(0.0, 100.0, 2001)
        ]
    )
    return rows[:, 0], rows[:, 1:]


@pytest.mark.parametrize("animal", ANIMALS)
def test_auto_gait_blends_through_the_species_gaits_without_a_jump(animal):
    gaits = load_animal(animal).gaits
    froudes, blends = auto_gait_blend(animal)
    assert np.abs(np.diff(blends, axis=0)).max() < 0.01  # the footfalls drift, never jump
    assert froudes.max() == pytest.approx(max(use.froude[1] for use in gaits.values()))
    top = blends[-1]  # phase_lf, phase_rh, phase_rf, duty at the top speed
    if "gallop" in gaits:
        rotary = gaits["gallop"].sequence == "rotary"
        assert top == pytest.approx([0.68 if rotary else 0.48, 0.2, 0.48 if rotary else 0.68, 0.25])
    else:
        assert top == pytest.approx([0.25, 0.5, 0.75, 0.6])  # the amble


def test_the_elephants_auto_gait_keeps_every_foot_down_half_the_cycle_at_any_speed():
    _, blends = auto_gait_blend("elephant")
    assert blends[:, 3].min() >= 0.5
    assert np.allclose(blends[:, :3], [0.25, 0.5, 0.75])  # the walk's footfalls throughout
