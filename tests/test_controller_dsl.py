"""The controller language: units, expressions, loading, validation output, generated docs."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from quadpipe.anatomy import roles
from quadpipe.controllers.language import (
    ExprError,
    Scale,
    compile_controller,
    compile_quantity,
    controller_json_schema,
    load_controller,
    reference,
    render_docs,
    scale_for_animals,
    validate_files,
)
from quadpipe.controllers.language.schema import (
    ANGLE,
    ANGULAR_STIFFNESS,
    CONDITION,
    DIRECTION,
    ELEMENT_TYPES,
    FORCE,
    LENGTH,
    LENGTH2_FACTOR,
    POINT,
    TIME,
    ControllerFile,
)
from quadpipe.controllers.language.validate import ISSUE_CODES
from quadpipe.core.errors import QuadpipeError
from quadpipe.quantities import expressions, units
from quadpipe.quantities.units import STANDARD_GRAVITY

REPO = Path(__file__).resolve().parent.parent
SHIPPED = REPO / "configs" / "controllers"
FIXTURES = REPO / "tests" / "fixtures" / "controllers"
BAD = sorted((FIXTURES / "bad").glob("*.yaml"))
THESIS_CONTROLLERS = ("rigid", "point_target", "postures", "leash", "leg_by_leg", "spine_walk")
CODES_WITHOUT_FIXTURE = {"file-unreadable"}
"""An unreadable file cannot be committed as a fixture."""

DOG_HP, DOG_KG = 0.6556, 30.0
RAT_HP, RAT_KG = 0.0254, 0.3


def synthetic_rest_points(n: int = 2) -> dict[str, np.ndarray]:
    """Rest positions for every body point: bone i runs from (i cm, 0, 50 cm) down by (i+1) cm."""
    points = {}
    for index, role in enumerate(roles.ROLES):
        start = np.tile([0.01 * index, 0.0, 0.5], (n, 1)) * np.arange(1, n + 1)[:, None]
        end = start - np.array([0.0, 0.0, 0.01 * (index + 1)])
        points[f"{role}.start"], points[f"{role}.end"], points[f"{role}.mid"] = start, end, (start + end) / 2
    return points


@pytest.fixture
def two_animals() -> Scale:
    """A dog-sized and a rat-sized animal with synthetic rest poses."""
    return Scale.of([DOG_HP, RAT_HP], [DOG_KG, RAT_KG], synthetic_rest_points())


@pytest.fixture
def in_repo(monkeypatch: pytest.MonkeyPatch) -> Path:
    """Run from the repository root, so reported paths are relative like in the goldens."""
    monkeypatch.chdir(REPO)
    return REPO


# --------------------------------------------------------------------------- units and expressions


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("38/30 s", 38 / 30),
        ("-38/30 s", -38 / 30),
        ("2cm", 0.02),
        ("2 cm + 1 mm", 0.021),
        ("20 deg", np.radians(20)),
        ("1 / 2 s", 0.5),
        ("2 s * 3", 6.0),
        ("max(1 cm, 2 mm)", 0.01),
        ("smoothstep(1 s, 2 s, 1.5 s)", 0.5),
        ("1 if 2 s > 1 s else 0", 1.0),
        ("[1, 2, 3].z + 1", 4.0),
        ("2^3", 8.0),
    ],
)
def test_numbers_with_units_compile_to_si(text: str, expected: float) -> None:
    compiled = compile_quantity(text, Scale.of(DOG_HP, DOG_KG))
    assert compiled.needs == frozenset()
    assert compiled.constant == pytest.approx([expected])


def test_plain_zeros_in_a_vector_take_the_unit_of_the_others(two_animals: Scale) -> None:
    compiled = compile_quantity("[20 HP, 0, 0]", two_animals, POINT)
    assert compiled.constant == pytest.approx(np.array([[20 * DOG_HP, 0, 0], [20 * RAT_HP, 0, 0]]))
    with pytest.raises(ExprError, match="vector components mix units"):
        compile_quantity([1, 0, "2 cm"], two_animals, POINT)


def test_a_unit_binds_to_the_number_before_it_not_to_a_whole_quotient() -> None:
    namespace = expressions.Namespace(parameters={"x": expressions.check("3 m", expressions.Namespace())})
    compiled = compile_quantity("x / 2 s", Scale.of(DOG_HP, DOG_KG), namespace=namespace)
    assert compiled.type == expressions.Type(expressions.SCALAR, units.VELOCITY)
    assert compiled.constant == pytest.approx([1.5])


def test_animal_units_take_each_animals_value(two_animals: Scale) -> None:
    torque = compile_quantity("0.5 bw*HP/rad", two_animals, ANGULAR_STIFFNESS)
    expected = 0.5 * np.array([DOG_KG, RAT_KG]) * STANDARD_GRAVITY * np.array([DOG_HP, RAT_HP])
    assert torque.constant == pytest.approx(expected)
    speed = compile_quantity("froude_speed(0.25)", two_animals)
    assert speed.constant == pytest.approx(np.sqrt(0.25 * STANDARD_GRAVITY * np.array([DOG_HP, RAT_HP])))


@pytest.mark.parametrize(
    ("text", "expect", "code", "message"),
    [
        ("20 deg", TIME, "wrong-dimension", "expected a time, got an angle"),
        ("2 cm + 1 s", TIME, "dimension-mismatch", "cannot add a length and a time"),
        ("[0, 0, -1]", FORCE, "wrong-type", "expected a force, got a direction vector (no unit)"),
        ("0.4", LENGTH2_FACTOR, "wrong-dimension", "expected a force per squared length, got a number"),
        ("t > 1 s", FORCE, "wrong-type", "expected a force, got a condition (true/false)"),
        ("1 s < 2 cm", CONDITION, "dimension-mismatch", "cannot compare a time and a length"),
        ("[1, 0, 2 cm]", DIRECTION, "dimension-mismatch", "vector components mix units"),
    ],
)
def test_dimensions_are_checked(text: str, expect: expressions.Expect, code: str, message: str) -> None:
    with pytest.raises(ExprError) as caught:
        compile_quantity(text, Scale.of(DOG_HP, DOG_KG), expect)
    assert caught.value.code == code
    assert message in caught.value.message


@pytest.mark.parametrize(
    ("text", "code"),
    [
        ("__import__('os').system('true')", "forbidden-syntax"),
        ("(lambda: 1)()", "forbidden-syntax"),
        ("[x for x in [1, 2, 3]]", "forbidden-syntax"),
        ("t.real", "wrong-type"),
        ("pi.__class__", "wrong-type"),
        ("open", "unknown-name"),
        ("eval(1)", "unknown-function"),
        ("max(a=1, b=2)", "forbidden-syntax"),
        ("2 s == 2 s", "forbidden-syntax"),
        ("1 +", "expression-syntax"),
        ("k HP", "expression-syntax"),
    ],
)
def test_unsafe_or_malformed_expressions_are_refused(text: str, code: str) -> None:
    with pytest.raises(ExprError) as caught:
        compile_quantity(text, Scale.of(DOG_HP, DOG_KG))
    assert caught.value.code == code


def test_points_sensors_phases_and_contacts_read_the_env_for_every_animal(two_animals: Scale) -> None:
    namespace = expressions.Namespace(sensors={"ground": expressions.Type(expressions.VECTOR)}, cycles={"pedal"})
    text = "norm(lf.foot - lf.top) * (1 if contact(lf) and phase(pedal) < 0.5 else 0) + dot(ground, [0, 0, 1 m])"
    compiled = compile_quantity(text, two_animals, LENGTH, namespace)
    assert compiled.needs == {
        "point:lf_fpha1.end",
        "point:lf_scapula.start",
        "contact:lf",
        "phase:pedal",
        "sensor:ground",
    }
    env = {
        "point:lf_fpha1.end": np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0]]),
        "point:lf_scapula.start": np.array([[0.0, 0.0, 0.5], [0.0, 0.0, 0.02]]),
        "contact:lf": np.array([True, False]),
        "phase:pedal": np.array([0.25, 0.25]),
        "sensor:ground": np.array([[0.0, 0.0, 1.0], [0.0, 0.6, 0.8]]),
    }
    assert compiled(env) == pytest.approx([0.5 + 1.0, 0.0 + 0.8])


def test_heading_turns_a_heading_vector_into_the_world(two_animals: Scale) -> None:
    compiled = compile_quantity("heading([1, 0, 0])", two_animals, DIRECTION)
    quarter_turn = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    env = {expressions.HEADING_FRAME_KEY: np.stack([np.eye(3), quarter_turn])}
    assert compiled.needs == {expressions.HEADING_FRAME_KEY}
    assert compiled(env) == pytest.approx(np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]))


def test_degenerate_values_give_zero_not_nan(two_animals: Scale) -> None:
    assert compile_quantity("normalize([0, 0, 0])", two_animals).constant == pytest.approx(np.zeros((2, 3)))
    at_zero = {"t": np.zeros(2)}
    assert compile_quantity("1 N / (t * 1 / 1 s)", two_animals)(at_zero) == pytest.approx([0.0, 0.0])


def test_a_divisor_that_is_always_zero_is_refused_before_running(two_animals: Scale) -> None:
    for text in ("1 N / (0 s * 1 / 1 s)", "0.5 bw / 0", "0.5 bw / (1 - 1)"):
        with pytest.raises(ExprError) as caught:
            compile_quantity(text, two_animals)
        assert caught.value.code == "division-by-zero", text


def test_angle_between_vectors(two_animals: Scale) -> None:
    compiled = compile_quantity("angle([1, 0, 0], [1, 1, 0])", two_animals, ANGLE)
    assert compiled.constant == pytest.approx([np.pi / 4] * 2)


# --------------------------------------------------------------------------- shipped controllers


def test_every_shipped_controller_validates_without_any_issue(in_repo: Path) -> None:
    shipped = sorted(p.stem for p in SHIPPED.glob("*.yaml"))
    output, code = validate_files([str(SHIPPED)])
    assert (output, code) == (f"{len(shipped)} files checked: no problems\n", 0)
    assert shipped == sorted(
        THESIS_CONTROLLERS
        + ("amble", "auto_gait", "bound", "canter", "direct", "gallop", "locomotion", "pace", "trot", "walk")
    )


@pytest.mark.parametrize("name", THESIS_CONTROLLERS)
def test_shipped_controllers_point_editors_at_the_schema(name: str) -> None:
    first = (SHIPPED / f"{name}.yaml").read_text(encoding="utf-8").splitlines()[0]
    assert first == "# yaml-language-server: $schema=../../schemas/controller.schema.json"


def test_rigid_has_the_thesis_segments_in_quadpipe_axes() -> None:
    spec = load_controller("rigid")
    directions = {name: element.direction.vector for name, element in spec.elements.items()}
    assert directions == {
        "tail": [-1, 0, -1],
        "spine": [1, 0, 0],
        "neck": [1, 0, 1],
        **{f"{leg}_leg": None for leg in roles.LEGS},
    }
    tops = {leg: f"{leg}_scapula.start" if leg.endswith("f") else f"{leg}_hip.start" for leg in roles.LEGS}
    assert {leg: spec.elements[f"{leg}_leg"].direction.balance for leg in roles.LEGS} == tops
    assert (spec.elements["lf_leg"].from_, spec.elements["lf_leg"].to) == ("lf_scapula.start", "lf_fpha1.end")
    assert (spec.elements["rh_leg"].from_, spec.elements["rh_leg"].to) == ("rh_hip.start", "rh_hpha2.end")


def test_length2_strength_is_factor_times_rest_length_squared(two_animals: Scale) -> None:
    compiled = compile_controller(load_controller("rigid"), two_animals)
    rest = two_animals.rest_points
    distance = np.linalg.norm(rest["lh_hpha2.end"] - rest["lh_hip.start"], axis=-1)
    expected = 1.2 * two_animals.bw / two_animals.hp**2 * distance**2
    assert compiled.elements["lh_leg"].value("strength").constant == pytest.approx(expected)


def test_a_legs_rest_length_is_a_constant_length_per_animal_from_its_top_to_its_foot(two_animals: Scale) -> None:
    rest = two_animals.rest_points
    compiled = compile_quantity("rh.rest_length / 2 + lf.rest_length", two_animals, LENGTH)
    hind = np.linalg.norm(rest["rh_hpha2.end"] - rest["rh_hip.start"], axis=-1)
    front = np.linalg.norm(rest["lf_fpha1.end"] - rest["lf_scapula.start"], axis=-1)
    assert compiled.needs == frozenset()
    assert compiled.constant == pytest.approx(hind / 2 + front)
    assert hind[0] != pytest.approx(front[0])


@pytest.mark.parametrize(
    ("text", "code", "message"),
    [
        ("lf.rest_lenght", "bad-point", "did you mean 'rest_length'"),
        ("lf_elbow.rest_length", "bad-point", "a bone has the points .start, .end and .mid"),
        ("lf.rest_length", "wrong-dimension", "expected a time, got a length"),
    ],
)
def test_a_legs_rest_length_is_checked(text: str, code: str, message: str) -> None:
    with pytest.raises(ExprError) as caught:
        compile_quantity(text, Scale.of(DOG_HP, DOG_KG), TIME)
    assert caught.value.code == code
    assert message in f"{caught.value.message} {caught.value.hint}"


def test_strengths_scale_with_real_animals() -> None:
    from quadpipe.animals.library import load_animal

    scale = scale_for_animals([load_animal("dog"), load_animal("rat")])
    leg = compile_controller(load_controller("rigid"), scale).elements["lh_leg"]
    length = np.linalg.norm(scale.rest_points["lh_hpha2.end"] - scale.rest_points["lh_hip.start"], axis=-1)
    assert leg.value("strength").constant / scale.bw == pytest.approx(1.2 * (length / scale.hp) ** 2)
    assert scale.hp == pytest.approx([DOG_HP, RAT_HP], rel=1e-3)


def test_point_target_overrides_directions_and_keeps_strengths() -> None:
    spec = load_controller("point_target")
    assert spec.sources[1].endswith("rigid.yaml")
    assert spec.elements["neck"].direction.toward == "target"
    assert spec.elements["neck"].direction.vector is None
    assert spec.elements["lf_leg"].direction.balance == "lf_scapula.start"
    assert spec.elements["lh_leg"].direction.toward == "target"
    assert spec.elements["neck"].strength.force == "neck_force"
    assert spec.elements["lh_leg"].strength.length2 == "reach_gain"
    assert spec.elements["lh_leg"].direction.balance is None


def test_postures_states_set_the_thesis_leg_ratios(two_animals: Scale) -> None:
    compiled = compile_controller(load_controller("postures"), two_animals)
    machine = compiled.machines["posture"]
    assert machine.initial == "standing"
    assert set(machine.owned) == {f"{leg}_leg" for leg in roles.LEGS}
    ratios = {
        state: (
            machine.states[state].elements["lh_leg"].value("elastic", "ratio").constant[0],
            machine.states[state].elements["lf_leg"].value("elastic", "ratio").constant[0],
        )
        for state in machine.states
    }
    assert ratios == {"standing": (1.3, 1.3), "sitting": (0.5, 1.3), "lying": (0.5, 0.5)}
    hold = [transition.after.constant[0] for transition in machine.transitions]
    assert hold == [3.0, 3.0, 3.0]


def test_leash_legs_switch_between_support_and_seek() -> None:
    spec = load_controller("leash")
    assert {name: spec.elements[name].at for name in ("lf_balance", "rf_balance", "lh_balance", "rh_balance")} == {
        "lf_balance": "lf_scapula.start",
        "rf_balance": "rf_scapula.start",
        "lh_balance": "lh_hip.start",
        "rh_balance": "rh_hip.start",
    }
    machine = spec.machines["gait"]
    assert list(machine.states) == ["support"] + [f"{leg}_{state}" for leg in roles.LEGS for state in ("seek", "land")]
    assert {"rh_seek", "rh_stance_aim", "rh_length"} <= set(machine.owned)
    assert spec.elements["rh_seek"].enabled is False
    seeking = machine.states["rh_seek"].elements
    assert seeking["rh_seek"].enabled is True and seeking["rh_stance_aim"].enabled is False
    assert seeking["rh_length"].elastic.ratio == "lift_ratio"
    assert "rh_length" not in machine.states["rh_land"].elements
    assert machine.transitions[3].when == "rh_tilt > seek_angle and rh_rank >= most_tilted"
    assert "pelvis" not in spec.elements["trunk_springs"].joints
    assert spec.elements["toe_springs"].joints == [
        f"{leg}_{toe}"
        for leg in roles.LEGS
        for toe in (("fpha0", "fpha1") if leg.endswith("f") else ("hpha0", "hpha1", "hpha2"))
    ]


def test_leg_by_leg_removes_the_leash_and_pushes_while_supporting() -> None:
    spec = load_controller("leg_by_leg")
    assert "leash" not in spec.elements
    assert spec.elements["lf_stance_push"].reaction == {"lf_wrist.start": 1}
    assert spec.elements["rh_stance_push"].reaction == {"rh_ankle.start": 1}
    machine = spec.machines["gait"]
    assert "lf_stance_push" in machine.owned
    assert machine.states["lf_seek"].elements["lf_stance_push"].enabled is False
    assert "lf_stance_push" not in machine.states["support"].elements


def test_spine_walk_pedals_rudder_and_slope(two_animals: Scale) -> None:
    compiled = compile_controller(load_controller("spine_walk"), two_animals)
    shoulder = compiled.elements["shoulder_pedal"]
    assert shoulder.value("sites", "rf_shoulder.start").constant == pytest.approx([0.75, 0.75])
    period = compiled.elements["gait"].value("period").constant
    assert period[0] == pytest.approx(38 / 30, rel=1e-3)
    assert period[1] == pytest.approx(38 / 30 * np.sqrt(RAT_HP / DOG_HP), rel=1e-3)
    rudder = compiled.elements["rudder"]
    assert [rudder.value("reaction", p).constant[0] for p in ("thorax.mid", "pelvis.mid")] == [0.5, 0.5]
    slope = compiled.elements["slope"].value("strength")
    uphill_10_deg = np.array([-np.sin(np.radians(10)), 0.0, np.cos(np.radians(10))])
    env = {
        "sensor:ground_normal": np.stack([uphill_10_deg, uphill_10_deg * [-1, 1, 1]]),
        expressions.HEADING_FRAME_KEY: np.stack([np.eye(3)] * 2),
    }
    strengths = slope(env) / two_animals.bw
    assert strengths == pytest.approx([np.sin(np.radians(10)), -np.sin(np.radians(10))])


def test_parameters_can_be_replaced_when_loading() -> None:
    spec = load_controller("spine_walk", {"goal": "[3 HP, 1 HP, 0 HP]"})
    assert spec.parameters["goal"].value == "[3 HP, 1 HP, 0 HP]"
    with pytest.raises(QuadpipeError) as caught:
        load_controller("spine_walk", {"goal": "3 s", "gaol": "1 HP"})
    assert [(issue.code, issue.message) for issue in caught.value.issues] == [
        ("unknown-parameter", "the controller has no parameter 'gaol'"),
        ("wrong-type", "parameter 'goal' is a vector of lengths in the controller, the new value is a time"),
    ]


# --------------------------------------------------------------------------- user controllers


def test_relative_extends_groups_and_state_set(in_repo: Path) -> None:
    path = FIXTURES / "good" / "calm_leash.yaml"
    assert validate_files([str(path)]) == ("1 file checked: no problems\n", 0)
    spec = load_controller(path)
    assert [name for name in spec.elements if name.endswith("_lift")] == ["lf_lift", "rh_lift"]
    lifted = spec.machines["trot"].states["lifted"].elements
    assert lifted["pull"].strength == "2 * pull_force"
    assert lifted["lf_lift"].enabled is True


def test_force_pair_weights_are_normalised(tmp_path: Path, two_animals: Scale) -> None:
    path = tmp_path / "pair.yaml"
    path.write_text(
        "schema: 1\nname: pair\nelements:\n"
        "  - {type: force_pair, name: tug, at: head, direction: [1, 0, 0], strength: 1 bw, reaction: {thorax: 1, pelvis: 3}}\n",
        encoding="utf-8",
    )
    tug = compile_controller(load_controller(path), two_animals).elements["tug"]
    assert tug.value("reaction", "thorax.start").constant == pytest.approx([0.25, 0.25])
    assert tug.value("reaction", "pelvis.start").constant == pytest.approx([0.75, 0.75])


# --------------------------------------------------------------------------- tunables and parameter templates


KNOBS = """schema: 1
name: knobs
tunables:
  hold:
    value: 2 bw/HP
    description: How firmly the legs hold their length.
    min: 0
    max: 4 bw/HP
  front_ratio: {value: 1.1, description: Length of the front legs., min: 0.5, max: 1.5}
  hind_ratio: {value: 1.2, description: Length of the hind legs., min: 0.5, max: 1.5}
parameters:
  "{leg}_ratio":
    for_each: all_legs
    value: "{pair}_ratio"
    description: Length of {leg}.
elements:
  - type: segment
    name: "{leg}_leg"
    for_each: all_legs
    from: "{leg}.top"
    to: "{leg}.foot"
    elastic: {stiffness: hold, ratio: "{leg}_ratio"}
"""
"""A controller with tunables, and a parameter per leg from a template."""


def write_knobs(folder: Path, text: str = KNOBS) -> Path:
    path = folder / "knobs.yaml"
    path.write_text(text, encoding="utf-8")
    return path


def test_for_each_makes_one_parameter_per_leg_with_leg_and_pair_replaced(tmp_path: Path, two_animals: Scale) -> None:
    spec = load_controller(write_knobs(tmp_path))
    assert {
        name: (p.value, p.description)
        for name, p in spec.parameters.items()
        if name.endswith("_ratio") and "_" in name[:3]
    } == {
        "lf_ratio": ("front_ratio", "Length of lf."),
        "rf_ratio": ("front_ratio", "Length of rf."),
        "lh_ratio": ("hind_ratio", "Length of lh."),
        "rh_ratio": ("hind_ratio", "Length of rh."),
    }
    compiled = compile_controller(spec, two_animals)
    assert compiled.elements["rf_leg"].value("elastic", "ratio").constant == pytest.approx([1.1, 1.1])
    assert compiled.elements["lh_leg"].value("elastic", "ratio").constant == pytest.approx([1.2, 1.2])


def test_a_parameter_template_needs_leg_in_its_name(tmp_path: Path) -> None:
    path = write_knobs(tmp_path, KNOBS.replace('"{leg}_ratio":', "ratio:").replace('"{leg}_ratio"}', "ratio}"))
    with pytest.raises(QuadpipeError) as caught:
        load_controller(path)
    (issue,) = caught.value.issues
    assert (issue.code, issue.where.line, issue.where.column) == ("template-name", 12, 3)


def test_tunables_are_parameters_with_a_range(tmp_path: Path) -> None:
    spec = load_controller(write_knobs(tmp_path))
    assert list(spec.tunables) == ["hold", "front_ratio", "hind_ratio"]
    assert spec.tunables["hold"].limits == (0, "4 bw/HP")
    assert not spec.parameters["lf_ratio"].tunable


def test_a_tunable_outside_its_range_is_an_error_at_its_value(tmp_path: Path) -> None:
    path = write_knobs(tmp_path, KNOBS.replace("value: 2 bw/HP", "value: 5 bw/HP"))
    with pytest.raises(QuadpipeError) as caught:
        load_controller(path)
    (issue,) = caught.value.issues
    assert (issue.code, issue.where.file, issue.where.line, issue.where.column) == ("out-of-range", str(path), 5, 12)
    assert issue.message == "tunable 'hold' is 5 bw/HP, outside its range 0 to 4 bw/HP"


def test_a_tunable_can_be_overridden_within_its_range(tmp_path: Path, two_animals: Scale) -> None:
    path = write_knobs(tmp_path)
    spec = load_controller(path, {"hold": "3 bw/HP", "hind_ratio": 0.9})
    assert spec.parameters["hold"].value == "3 bw/HP" and spec.parameters["hold"].limits == (0, "4 bw/HP")
    compiled = compile_controller(spec, two_animals)
    assert compiled.elements["lh_leg"].value("elastic", "ratio").constant == pytest.approx([0.9, 0.9])
    assert compiled.elements["lf_leg"].value("elastic", "stiffness").constant == pytest.approx(
        3 * two_animals.bw / two_animals.hp
    )
    with pytest.raises(QuadpipeError) as caught:
        load_controller(path, {"hind_ratio": 2})
    assert [(issue.code, issue.where.file) for issue in caught.value.issues] == [("out-of-range", "<parameters>")]


def test_an_extending_controller_sets_a_tunable_and_keeps_its_range(tmp_path: Path) -> None:
    write_knobs(tmp_path)
    child = tmp_path / "child.yaml"
    child.write_text(
        "schema: 1\nname: child\nextends: knobs.yaml\ntunables:\n  hold: 3 bw/HP\n  hind_ratio: 1.7\n", encoding="utf-8"
    )
    with pytest.raises(QuadpipeError) as caught:
        load_controller(child)
    (issue,) = caught.value.issues
    assert (issue.code, issue.where.file, issue.where.line) == ("out-of-range", str(child), 6)
    child.write_text("schema: 1\nname: child\nextends: knobs.yaml\ntunables:\n  hold: 3 bw/HP\n", encoding="utf-8")
    hold = load_controller(child).tunables["hold"]
    assert (hold.value, hold.limits, hold.description) == (
        "3 bw/HP",
        (0, "4 bw/HP"),
        "How firmly the legs hold their length.",
    )


def test_a_tunable_needs_a_range_and_a_description(tmp_path: Path) -> None:
    path = write_knobs(
        tmp_path, KNOBS.replace("    description: How firmly the legs hold their length.\n    min: 0\n", "")
    )
    with pytest.raises(QuadpipeError) as caught:
        load_controller(path)
    assert [(issue.code, issue.message, issue.where.line) for issue in caught.value.issues] == [
        ("missing-key", "tunable 'hold' needs `description`, `min`", 5),
    ]


def test_the_shipped_gaits_have_tunables_and_keep_their_formulas_in_parameters() -> None:
    walk = load_controller("walk")
    assert {"froude", "duty", "phase_lf", "stance_stiffness"} <= set(walk.tunables)
    assert walk.tunables["froude"].value == 0.15 and walk.tunables["froude"].limits == (0.01, 5)
    assert not walk.parameters["period"].tunable and not walk.parameters["lf_push"].tunable
    auto = load_controller("auto_gait")
    assert "froude" not in auto.tunables and {"start_froude", "end_froude"} <= set(auto.tunables)


def test_quadpipe_controllers_name_lists_its_tunables(cli) -> None:
    result = cli("controllers", "walk")
    assert result.returncode == 0, result.stderr
    rows = {line.split("│")[1].strip(): line for line in result.stdout.splitlines() if line.count("│") >= 5}
    assert {"froude", "duty", "phase_lf", "fold_angle", "stance_stiffness"} <= set(rows)
    assert "0.15" in rows["froude"] and "0.01 to 5" in rows["froude"] and "Target speed" in rows["froude"]
    assert "period" not in rows and "lf_push" not in rows


# --------------------------------------------------------------------------- validation output


@pytest.mark.parametrize("path", BAD, ids=[p.stem for p in BAD])
def test_bad_fixture_reports_exactly_its_golden_output(path: Path, in_repo: Path) -> None:
    output, code = validate_files([str(path.relative_to(REPO))])
    expected = path.with_suffix(".expected").read_text(encoding="utf-8")
    assert output == expected
    assert code == (1 if " error " in expected else 0)


def test_every_issue_code_has_a_golden_fixture() -> None:
    shown = set()
    for path in BAD:
        for line in path.with_suffix(".expected").read_text(encoding="utf-8").splitlines():
            if ": error " in line or ": warning " in line:
                shown.add(line.split(": ", 2)[1].split()[1])
    assert shown <= set(ISSUE_CODES)
    assert set(ISSUE_CODES) - CODES_WITHOUT_FIXTURE <= shown


def test_json_and_github_formats(in_repo: Path) -> None:
    path = "tests/fixtures/controllers/bad/wrong_dimension.yaml"
    text, code = validate_files([path], "json")
    assert code == 1
    assert json.loads(text) == [
        {
            "file": path,
            "line": 9,
            "column": 13,
            "severity": "error",
            "code": "wrong-dimension",
            "message": "expected a time, got an angle",
            "hint": "parameter 'period' is '20 deg'; for example `38/30 s`",
        }
    ]
    github, _ = validate_files([path], "github")
    assert github == (
        f"::error file={path},line=9,col=13::wrong-dimension: expected a time, got an angle"
        "%0A  hint: parameter 'period' is '20 deg'; for example `38/30 s`\n"
    )


def test_warnings_alone_exit_zero(in_repo: Path) -> None:
    output, code = validate_files(["tests/fixtures/controllers/bad/unused_parameter.yaml"], "github")
    assert code == 0
    assert output.startswith("::warning file=")


def test_unknown_format_and_unknown_name_are_reported() -> None:
    with pytest.raises(QuadpipeError):
        validate_files([str(SHIPPED)], "xml")
    output, code = validate_files(["rigd"])
    assert code == 1
    assert "error unknown-controller: there is no controller named 'rigd'" in output


# --------------------------------------------------------------------------- generated files


def test_committed_json_schema_is_up_to_date() -> None:
    committed = (REPO / reference.SCHEMA_PATH).read_text(encoding="utf-8")
    assert committed == reference.json_schema_text(), "run: python -m quadpipe.controllers.language.generate"


def test_committed_reference_docs_are_up_to_date() -> None:
    committed = (REPO / reference.DOCS_PATH).read_text(encoding="utf-8")
    assert committed == render_docs(committed), "run: python -m quadpipe.controllers.language.generate"


def test_reference_documents_every_element_key_unit_and_function() -> None:
    text = reference.reference_markdown()
    for model in ELEMENT_TYPES:
        for name, info in model.model_fields.items():
            assert f"| `{info.alias or name}` |" in text
    for symbol in units.UNITS:
        assert f"| `{symbol}` |" in text
    for function in expressions.FUNCTIONS.values():
        assert f"`{function.signature}`" in text


def test_every_key_of_the_format_has_a_description() -> None:
    models = [ControllerFile, *ELEMENT_TYPES, *reference.PARTS]
    missing = [
        f"{model.__name__}.{name}"
        for model in models
        for name, info in model.model_fields.items()
        if not info.description
    ]
    assert missing == []


def test_json_schema_accepts_shipped_controllers_and_rejects_unknown_keys() -> None:
    jsonschema = pytest.importorskip("jsonschema")
    import yaml

    validator = jsonschema.Draft202012Validator(controller_json_schema())
    for path in [*SHIPPED.glob("*.yaml"), *(FIXTURES / "good").glob("*.yaml")]:
        assert not list(validator.iter_errors(yaml.safe_load(path.read_text(encoding="utf-8")))), path.name
    assert list(
        validator.iter_errors(yaml.safe_load((FIXTURES / "bad" / "unknown_key.yaml").read_text(encoding="utf-8")))
    )


def test_render_docs_needs_its_markers() -> None:
    with pytest.raises(ValueError):
        render_docs("# no markers here\n")


def test_gait_helpers_sweep_lift_and_wrap() -> None:
    scale = Scale.of([DOG_HP], [30.0])
    phases = np.array([0.0, 0.325, 0.65, 0.825, 0.999])

    def value(text: str, p: float) -> float:
        return float(expressions.compile_quantity(text.replace("P", str(float(p))), scale)({})[0])

    sweep = [value("leg_sweep(P, 0.65)", p) for p in phases]
    assert sweep[:3] == pytest.approx([1.0, 0.0, -1.0], abs=1e-9)  # back through stance
    assert sweep[3] == pytest.approx(0.0, abs=1e-9) and sweep[4] == pytest.approx(1.0, abs=1e-3)  # forward in swing
    lift = [value("leg_lift(P, 0.65)", p) for p in phases]
    assert lift[:3] == [0.0, 0.0, 0.0] and lift[3] == pytest.approx(1.0)
    assert value("wrap(P - 0.25)", 0.1) == pytest.approx(0.85)
