"""Gait analysis: hand-made clips with known footfalls are measured exactly and named right.

A synthetic clip moves every bone forward at a constant speed; each foot is down when
`(t / period - phase) mod 1 < duty`, and its toe stays where it landed while down (or drifts,
to test slip). Times are quantised to frames, so phases and duties are exact within one frame.
"""

from __future__ import annotations

import functools
import io
import json

import numpy as np
import pytest
from PIL import Image

from quadpipe.analysis import (
    BAR_COLOUR,
    DIAGRAM_STRIDES,
    DIAGRAM_WIDTH_PX,
    HILDEBRAND_ORDER,
    PANEL_HEIGHT_PX,
    ROW_GAP_PX,
    AnimalGait,
    GaitReport,
    analyze_clip,
    classify_gait,
    clean_contacts,
    controller_force_key,
    controller_power_key,
    debounce,
    diagram_panels,
    diagram_size,
    draw_footfall_diagram,
    footfall_diagram_png,
    format_report,
    min_run_frames,
    phase_distance,
    toe_tips,
)
from quadpipe.analysis.footfalls import runs
from quadpipe.anatomy.roles import LEGS, PARENT, ROLES, TOE_BONES
from quadpipe.animals.sizing import GRAVITY, natural_time
from quadpipe.clip.model import AnimalTrack, Clip
from quadpipe.core.errors import QuadpipeError

FPS = 30.0
PERIOD_S = 0.95
"""28.5 frames: touchdowns fall between frames, so quantisation is exercised."""

SECONDS = 8.0
SPEED_M_S = 1.2
HP_M = 0.6
MASS_KG = 30.0
TOE_OFFSET = np.array([0.03, 0.0, -0.04])
"""Toe tip relative to the last phalanx's joint in the rest pose (and in these clips' identity rotation)."""

HIP_OFFSET = {"lf": (0.3, 0.1), "rf": (0.3, -0.1), "lh": (-0.3, 0.1), "rh": (-0.3, -0.1)}
ONE_FRAME_PHASE = 1.0 / (PERIOD_S * FPS)
FRAME_S = 1.0 / FPS

LS_WALK = {"lh": 0.0, "lf": 0.25, "rh": 0.5, "rf": 0.75}


def foot_down(phase: float, duty: float, frames: int, period_s: float = PERIOD_S) -> np.ndarray:
    """When a foot with this phase and duty factor is down, per frame."""
    cycles = np.arange(frames) / FPS / period_s - phase
    return np.mod(cycles, 1.0) < duty


def synthetic_track(
    phases: dict[str, float],
    duty: float | dict[str, float],
    *,
    name: str = "dog",
    seconds: float = SECONDS,
    drift_m_s: dict[str, float] | None = None,
    contacts: np.ndarray | None = None,
) -> AnimalTrack:
    """A dog-sized track moving at `SPEED_M_S` along +x with the given footfalls.

    Args:
        phases: touchdown phase of each leg in cycles.
        duty: duty factor, for all legs or per leg.
        drift_m_s: sideways (+y) sliding speed of a planted toe, per leg (default: planted).
        contacts: (F, 4) contacts to use instead of the generated ones (the toes still follow
            the generated footfalls).
    """
    frames = round(seconds * FPS) + 1
    duties = duty if isinstance(duty, dict) else {leg: duty for leg in LEGS}
    down = np.stack([foot_down(phases[leg], duties[leg], frames) for leg in LEGS], axis=1)
    times = np.arange(frames) / FPS
    body = np.stack([SPEED_M_S * times, np.zeros(frames), np.full(frames, HP_M)], axis=1)
    positions = np.repeat(body[:, None, :], len(ROLES), axis=1)
    for index, leg in enumerate(LEGS):
        positions[:, ROLES.index(TOE_BONES[leg])] = _toe_path(
            body, down[:, index], HIP_OFFSET[leg], (drift_m_s or {}).get(leg, 0.0)
        )
    rest_start = np.zeros((len(ROLES), 3))
    rest_end = np.zeros((len(ROLES), 3))
    for bone in TOE_BONES.values():
        rest_end[ROLES.index(bone)] = TOE_OFFSET
    rotations = np.zeros((frames, len(ROLES), 4))
    rotations[..., 0] = 1.0
    return AnimalTrack(
        name=name,
        species="dog",
        roles=ROLES,
        parents=np.array([ROLES.index(PARENT[r]) if PARENT[r] else -1 for r in ROLES]),
        rest_start=rest_start,
        rest_end=rest_end,
        shapes=[[] for _ in ROLES],
        positions=positions,
        rotations=rotations,
        pelvis_height=HP_M,
        mass_kg=MASS_KG,
        foot_contacts=down if contacts is None else contacts,
    )


def _toe_path(body: np.ndarray, down: np.ndarray, offset: tuple[float, float], drift: float) -> np.ndarray:
    """Toe joint positions: under the hip in swing, frozen where it landed (plus drift) in stance."""
    toe = body + np.array([offset[0], offset[1], -HP_M])
    for frame in range(1, len(down)):
        if down[frame] and down[frame - 1]:
            toe[frame] = toe[frame - 1] + np.array([0.0, drift / FPS, 0.0])
    return toe


def synthetic_clip(*tracks: AnimalTrack, sensors: dict | None = None) -> Clip:
    return Clip(FPS, list(tracks), sensors=dict(sensors or {}))


def analyse(phases: dict[str, float], duty: float | dict[str, float], **options) -> AnimalGait:
    return analyze_clip(synthetic_clip(synthetic_track(phases, duty, **options))).animals[0]


def phase_error(a: float, b: float) -> float:
    return phase_distance(a, b)


# --- Measuring known footfalls ----------------------------------------------------------------

PHASES_UNDER_TEST = {"lh": 0.0, "lf": 0.31, "rh": 0.52, "rf": 0.83}
DUTIES_UNDER_TEST = {"lh": 0.72, "lf": 0.61, "rh": 0.66, "rf": 0.58}


def test_phases_duty_factors_and_stride_frequency_are_measured_exactly():
    gait = analyse(PHASES_UNDER_TEST, DUTIES_UNDER_TEST)
    assert abs(gait.stride_period_s - PERIOD_S) <= FRAME_S
    assert abs(gait.stride_frequency_hz - 1 / PERIOD_S) <= 1 / PERIOD_S - 1 / (PERIOD_S + FRAME_S)
    for leg in LEGS:
        assert phase_error(gait.legs[leg].phase, PHASES_UNDER_TEST[leg]) <= ONE_FRAME_PHASE, leg
        assert abs(gait.legs[leg].duty_factor - DUTIES_UNDER_TEST[leg]) <= ONE_FRAME_PHASE, leg
        assert gait.legs[leg].phase_spread < ONE_FRAME_PHASE, leg
        assert abs(gait.legs[leg].mean_stance_s - DUTIES_UNDER_TEST[leg] * PERIOD_S) <= FRAME_S, leg


def test_speed_stride_length_and_froude_follow_the_pelvis():
    gait = analyse(PHASES_UNDER_TEST, DUTIES_UNDER_TEST)
    assert gait.speed_m_s == pytest.approx(SPEED_M_S, rel=1e-9)
    assert gait.froude == pytest.approx(SPEED_M_S**2 / (GRAVITY * HP_M), rel=1e-9)
    assert abs(gait.stride_length_m - SPEED_M_S * PERIOD_S) <= SPEED_M_S * FRAME_S
    assert gait.stride_length_hp == pytest.approx(gait.stride_length_m / HP_M)
    assert gait.alexander_stride_hp == pytest.approx(2.3 * gait.froude**0.3)
    assert gait.alexander_ratio == pytest.approx(gait.stride_length_hp / gait.alexander_stride_hp)


def test_strides_run_between_the_left_hind_touchdowns():
    gait = analyse(PHASES_UNDER_TEST, DUTIES_UNDER_TEST)
    expected = np.flatnonzero(np.diff(foot_down(0.0, DUTIES_UNDER_TEST["lh"], gait.frames).astype(int)) == 1) + 1
    assert gait.stride_frames == tuple(expected)
    assert gait.stride_count == len(expected) - 1


# --- Naming gaits -----------------------------------------------------------------------------

GAITS = {
    "lateral-sequence walk": ({"lh": 0.0, "lf": 0.25, "rh": 0.5, "rf": 0.75}, 0.7),
    "diagonal-sequence walk": ({"lh": 0.0, "lf": 0.75, "rh": 0.5, "rf": 0.25}, 0.7),
    "lateral-sequence running-walk": ({"lh": 0.0, "lf": 0.25, "rh": 0.5, "rf": 0.75}, 0.4),
    "trot": ({"lh": 0.0, "rf": 0.0, "lf": 0.5, "rh": 0.5}, 0.4),
    "pace": ({"lh": 0.0, "lf": 0.0, "rh": 0.5, "rf": 0.5}, 0.45),
    "bound": ({"lh": 0.0, "rh": 0.03, "lf": 0.5, "rf": 0.53}, 0.3),
    "half-bound": ({"lh": 0.0, "rh": 0.03, "lf": 0.45, "rf": 0.65}, 0.3),
    "pronk": ({"lh": 0.0, "rh": 0.0, "lf": 0.0, "rf": 0.0}, 0.3),
    "canter": ({"lh": 0.0, "rh": 0.3, "lf": 0.3, "rf": 0.6}, 0.4),
    "transverse gallop": ({"lh": 0.0, "rh": 0.15, "lf": 0.55, "rf": 0.7}, 0.35),
    "rotary gallop": ({"lh": 0.0, "rh": 0.15, "rf": 0.55, "lf": 0.7}, 0.35),
}


@pytest.mark.parametrize("label", sorted(GAITS))
def test_each_gait_is_recognised_from_its_footfalls(label):
    phases, duty = GAITS[label]
    assert analyse(phases, duty).gait.label == label


def test_an_animal_that_never_steps_stands():
    frames = round(SECONDS * FPS) + 1
    gait = analyse(LS_WALK, 0.7, contacts=np.ones((frames, 4), dtype=bool))
    assert gait.gait.name == "stand"
    assert gait.stride_period_s is None and gait.speed_m_s is None and gait.legs["lf"].duty_factor is None


def test_no_feet_down_is_no_gait():
    frames = round(SECONDS * FPS) + 1
    assert analyse(LS_WALK, 0.7, contacts=np.zeros((frames, 4), dtype=bool)).gait.name == "none"


def test_a_foot_that_stays_down_makes_the_gait_irregular():
    frames = round(SECONDS * FPS) + 1
    contacts = np.stack([foot_down(LS_WALK[leg], 0.7, frames) for leg in LEGS], axis=1)
    contacts[:, LEGS.index("rf")] = True
    gait = analyse(LS_WALK, 0.7, contacts=contacts)
    assert gait.gait.name == "irregular"
    assert gait.legs["rf"].phase is None and gait.legs["rf"].duty_factor == 1.0


def test_classification_tolerates_small_phase_errors_and_rejects_large_ones():
    assert classify_gait({"lh": 0.0, "rf": 0.05, "lf": 0.46, "rh": 0.53}, 0.4).name == "trot"
    assert classify_gait({"lh": 0.0, "rf": 0.3, "lf": 0.6, "rh": 0.5}, 0.4).name != "trot"


# --- Debouncing -------------------------------------------------------------------------------


def test_debounce_removes_one_frame_gaps_and_contacts():
    raw = np.array([0, 0, 1, 0, 0, 1, 1, 1, 0, 1, 1, 1, 0, 0], dtype=bool)
    expected = np.array([0, 0, 0, 0, 0, 1, 1, 1, 1, 1, 1, 1, 0, 0], dtype=bool)
    np.testing.assert_array_equal(debounce(raw, 2), expected)


def test_flickers_do_not_change_the_analysis():
    frames = round(SECONDS * FPS) + 1
    clean = np.stack([foot_down(LS_WALK[leg], 0.7, frames) for leg in LEGS], axis=1)
    noisy = clean.copy()
    rng = np.random.default_rng(7)
    for leg in range(4):
        for frame in rng.choice(np.arange(5, frames - 5), size=40, replace=False):
            around = slice(frame - 2, frame + 3)  # isolated: two frames from any edge and other flickers
            if len(set(clean[around, leg])) == 1 and (noisy[around, leg] == clean[around, leg]).all():
                noisy[frame, leg] = not clean[frame, leg]
    assert (noisy != clean).sum() > 20
    before, after = analyse(LS_WALK, 0.7, contacts=clean), analyse(LS_WALK, 0.7, contacts=noisy)
    assert after.stride_frames == before.stride_frames
    for leg in LEGS:
        assert after.legs[leg].footfalls == before.legs[leg].footfalls
        assert after.legs[leg].phase == before.legs[leg].phase
        assert after.legs[leg].duty_factor == before.legs[leg].duty_factor
    assert after.gait == before.gait


def test_a_short_scuff_during_the_swing_is_not_a_footfall():
    frames = round(SECONDS * FPS) + 1
    contacts = np.stack([foot_down(LS_WALK[leg], 0.7, frames) for leg in LEGS], axis=1)
    reference = analyse(LS_WALK, 0.7, contacts=contacts.copy())
    lh = LEGS.index("lh")
    swing_starts = np.flatnonzero(np.diff(contacts[:, lh].astype(int)) == -1) + 1
    for start in swing_starts[:-1]:
        contacts[start + 2 : start + 5, lh] = True  # three frames: longer than a flicker
    scuffed = analyse(LS_WALK, 0.7, contacts=contacts)
    assert scuffed.stride_frames == reference.stride_frames
    assert scuffed.stride_period_s == reference.stride_period_s
    assert scuffed.gait.label == "lateral-sequence walk"


def test_a_foot_bouncing_inside_its_stance_makes_one_footfall():
    frames = round(SECONDS * FPS) + 1
    contacts = np.stack([foot_down(LS_WALK[leg], 0.7, frames) for leg in LEGS], axis=1)
    reference = analyse(LS_WALK, 0.7, contacts=contacts.copy())
    lh = LEGS.index("lh")
    touchdowns = np.flatnonzero(np.diff(contacts[:, lh].astype(int)) == 1) + 1
    for touchdown in touchdowns:
        contacts[touchdown + 3 : touchdown + 6, lh] = False  # a three-frame hop: longer than a flicker
    bounced = analyse(LS_WALK, 0.7, contacts=contacts)
    assert bounced.stride_frames == reference.stride_frames
    assert [f.touchdown_frame for f in bounced.legs["lh"].footfalls] == [
        f.touchdown_frame for f in reference.legs["lh"].footfalls
    ]
    for leg in LEGS:
        assert bounced.legs[leg].phase == pytest.approx(reference.legs[leg].phase, abs=1e-12), leg
    assert bounced.gait.label == "lateral-sequence walk"


def test_a_bounds_short_stance_is_a_footfall_not_a_flicker():
    fps = 120.0
    stance = round(0.18 * natural_time(HP_M) * fps)  # a horse's hind foot at a bound: 0.18 natural time
    raw = np.array(([False] * 40 + [True] * stance) * 5 + [False] * 40)
    cleaned = clean_contacts(raw, min_run_frames(fps, HP_M))
    assert len(runs(cleaned, True)) == 5


def test_a_first_touch_before_a_hop_starts_the_stance():
    raw = np.array([0] * 10 + [1, 1] + [0, 0] + [1] * 10 + [0] * 10 + [1] * 14 + [0] * 10, dtype=bool)
    cleaned = clean_contacts(raw, 2)
    assert runs(cleaned, True)[:2] == [(10, 24), (34, 48)]


# --- Slip ---------------------------------------------------------------------------------------


def test_planted_feet_do_not_slip():
    gait = analyse(LS_WALK, 0.7)
    for leg in LEGS:
        assert gait.legs[leg].mean_slip_m == pytest.approx(0.0, abs=1e-12), leg


def test_slip_is_the_planted_toes_drift():
    drift = 0.05
    gait = analyse(LS_WALK, 0.7, drift_m_s={"rh": drift})
    footfalls = [f for f in gait.legs["rh"].footfalls if f.slip_m is not None]
    assert footfalls
    for footfall in footfalls:
        stance_frames = footfall.liftoff_frame - footfall.touchdown_frame
        assert footfall.slip_m == pytest.approx(drift * (stance_frames - 1) / FPS)
    assert gait.legs["rh"].mean_slip_m == pytest.approx(np.mean([f.slip_m for f in footfalls]))
    assert gait.legs["lh"].mean_slip_m == pytest.approx(0.0, abs=1e-12)


def test_toe_tips_rotate_with_the_last_phalanx():
    track = synthetic_track(LS_WALK, 0.7)
    bone = ROLES.index(TOE_BONES["lf"])
    half_turn_about_z = np.array([0.0, 0.0, 0.0, 1.0])
    track.rotations[:, bone] = half_turn_about_z
    tips = toe_tips(track)["lf"]
    np.testing.assert_allclose(
        tips - track.positions[:, bone], np.tile([-0.03, 0.0, -0.04], (len(tips), 1)), atol=1e-12
    )


# --- Several animals, controller sensors, broken clips, JSON --------------------------------------


def test_each_animal_of_a_clip_is_analysed_on_its_own():
    clip = synthetic_clip(synthetic_track(*GAITS["trot"], name="dog"), synthetic_track(*GAITS["pace"], name="dog2"))
    report = analyze_clip(clip)
    assert [(a.name, a.gait.name) for a in report.animals] == [("dog", "trot"), ("dog2", "pace")]
    assert [a.name for a in analyze_clip(clip, "dog2").animals] == ["dog2"]
    with pytest.raises(QuadpipeError) as error:
        analyze_clip(clip, "dgo2")
    assert error.value.issues[0].code == "unknown-animal"
    assert "dog2" in error.value.issues[0].hint


def test_controller_force_and_work_are_reported_when_recorded():
    track = synthetic_track(LS_WALK, 0.7)
    frames = track.positions.shape[0]
    force = np.tile([0.1 * MASS_KG * GRAVITY, 0.0, 0.0], (frames, 1))
    force[:, 1] = np.where(np.arange(frames) % 2, 1.0, -1.0) * 0.2 * MASS_KG * GRAVITY  # |F| alternates
    power = np.full(frames, 12.0)
    clip = synthetic_clip(track, sensors={controller_force_key("dog"): force, controller_power_key("dog"): power})
    effort = analyze_clip(clip).animals[0].effort
    assert effort.mean_net_force_bw == pytest.approx(np.hypot(0.1, 0.2))
    assert effort.work_j == pytest.approx(12.0 * frames / FPS)
    distance = SPEED_M_S * (frames - 1) / FPS
    assert effort.work_j_per_kg_m == pytest.approx(effort.work_j / (MASS_KG * distance))


def test_controller_effort_is_not_recorded_without_sensors():
    report = analyze_clip(synthetic_clip(synthetic_track(LS_WALK, 0.7)))
    assert report.animals[0].effort is None
    assert report.to_dict()["animals"]["dog"]["controller_forces"] == "not recorded"
    assert "controller forces: not recorded" in format_report(report)


def test_a_controller_sensor_of_the_wrong_shape_is_an_error():
    track = synthetic_track(LS_WALK, 0.7)
    clip = synthetic_clip(track, sensors={controller_power_key("dog"): np.zeros((track.positions.shape[0], 2))})
    with pytest.raises(QuadpipeError) as error:
        analyze_clip(clip)
    assert error.value.issues[0].code == "bad-clip-sensor"


def test_a_blown_up_clip_is_analysed_up_to_its_first_nan():
    track = synthetic_track(LS_WALK, 0.7)
    blow_up = 150
    track.positions[blow_up:] = np.nan
    gait = analyze_clip(synthetic_clip(track)).animals[0]
    assert gait.frames == blow_up
    assert gait.stride_frames[-1] < blow_up
    assert gait.gait.label == "lateral-sequence walk"
    assert any(f"frame {blow_up}" in note for note in gait.notes)


def test_the_report_is_strict_json_with_every_figure():
    report = analyze_clip(synthetic_clip(synthetic_track(PHASES_UNDER_TEST, DUTIES_UNDER_TEST)))
    data = json.loads(json.dumps(report.to_dict(), allow_nan=False))
    dog = data["animals"]["dog"]
    assert dog["gait"]["label"] == "lateral-sequence walk"
    assert list(dog["legs"]) == ["lh", "lf", "rf", "rh"]
    assert dog["froude"] == pytest.approx(report.animals[0].froude)
    assert dog["alexander"]["ratio"] == pytest.approx(report.animals[0].alexander_ratio)
    first = dog["legs"]["lf"]["footfalls"][1]
    assert first["touchdown_s"] < first["liftoff_s"]


# --- Footfall diagram ------------------------------------------------------------------------------


def diagram_pixels(report: GaitReport) -> np.ndarray:
    return np.asarray(Image.open(io.BytesIO(footfall_diagram_png(report))).convert("RGB"))


def test_the_diagram_has_one_panel_per_animal():
    one = analyze_clip(synthetic_clip(synthetic_track(*GAITS["trot"])))
    two = analyze_clip(synthetic_clip(synthetic_track(*GAITS["trot"]), synthetic_track(*GAITS["pace"], name="dog2")))
    assert diagram_pixels(one).shape == (PANEL_HEIGHT_PX, DIAGRAM_WIDTH_PX, 3)
    assert diagram_pixels(two).shape == (2 * PANEL_HEIGHT_PX, DIAGRAM_WIDTH_PX, 3)
    assert diagram_size(two) == (DIAGRAM_WIDTH_PX, 2 * PANEL_HEIGHT_PX)


def test_each_row_of_the_diagram_shows_its_foots_stances():
    phases, duty = GAITS["rotary gallop"]
    track = synthetic_track(phases, duty)
    report = analyze_clip(synthetic_clip(track))
    pixels = diagram_pixels(report)
    panel = diagram_panels(report)[0]
    is_bar = np.all(pixels == BAR_COLOUR, axis=-1)
    frames = np.arange(round(panel.start_s * FPS) + 1, round(panel.end_s * FPS) - 1)
    for row, leg in enumerate(HILDEBRAND_ORDER):
        top, bottom = panel.row_band(row)
        middle = (top + bottom) // 2
        down = track.foot_contacts[:, LEGS.index(leg)]
        for frame in frames:
            if down[frame - 1] == down[frame] == down[frame + 1]:
                assert is_bar[middle, round(panel.x_of(frame / FPS))] == down[frame], (leg, frame)
        assert is_bar[top : bottom + 1].any(axis=0).sum() > 0.2 * (panel.right - panel.left), leg
        between = panel.row_band(row)[1] + ROW_GAP_PX // 2
        assert not is_bar[between].any(), leg


def test_the_diagram_shows_the_last_whole_strides():
    report = analyze_clip(synthetic_clip(synthetic_track(*GAITS["trot"])))
    panel, animal = diagram_panels(report)[0], report.animals[0]
    assert panel.end_s == animal.stride_frames[-1] / FPS
    assert panel.start_s == animal.stride_frames[-1 - DIAGRAM_STRIDES] / FPS


def test_the_diagram_is_written_atomically_as_png_only(tmp_path):
    report = analyze_clip(synthetic_clip(synthetic_track(*GAITS["trot"])))
    target = tmp_path / "footfalls.png"
    draw_footfall_diagram(report, target)
    assert target.read_bytes() == footfall_diagram_png(report)
    assert [p.name for p in tmp_path.iterdir()] == ["footfalls.png"]
    with pytest.raises(QuadpipeError) as error:
        draw_footfall_diagram(report, tmp_path / "footfalls.jpg")
    assert error.value.issues[0].code == "unsupported-diagram-format"
    assert not (tmp_path / "footfalls.jpg").exists()


# --- A real simulated walk ---------------------------------------------------------------------------

WALK_SECONDS = 6.0
SPINE_WALK_PERIOD_S = 38 / 30
"""The spine_walk controller's gait cycle for the dog (configs/controllers/spine_walk.yaml)."""


@functools.cache
def simulated_walk() -> GaitReport:
    from quadpipe.sim.simulation import simulate

    return analyze_clip(simulate("dog", "spine_walk", seconds=WALK_SECONDS).clip)


def test_a_simulated_dog_walk_is_recognised_as_a_walk():
    dog = simulated_walk().animals[0]
    assert dog.gait.label == "lateral-sequence walk"
    assert np.mean([dog.legs[leg].duty_factor for leg in LEGS]) > 0.5
    assert abs(dog.stride_period_s - SPINE_WALK_PERIOD_S) <= 2 * FRAME_S
    assert dog.stride_count >= 3
    assert dog.speed_m_s > 0.0 and dog.froude == pytest.approx(dog.speed_m_s**2 / (GRAVITY * dog.pelvis_height))


# --- Frame rates and analysis from simulate / bake ----------------------------------------------------


def test_a_higher_frame_rate_records_the_same_motion_more_often():
    from quadpipe.sim.simulation import simulate

    thirty = simulate("dog", "walk", seconds=1.0).clip
    hundred_twenty = simulate("dog", "walk", seconds=1.0, fps=120).clip
    assert hundred_twenty.fps == 120 and hundred_twenty.frame_count == 121
    np.testing.assert_array_equal(hundred_twenty.animals[0].positions[::4], thirty.animals[0].positions)


def test_a_frame_rate_that_does_not_divide_the_physics_rate_is_refused_before_anything_is_written(cli, tmp_path):
    result = cli(
        "simulate",
        "--animal",
        "dog",
        "--controller",
        "walk",
        "--seconds",
        "1",
        "--fps",
        "50",
        "-o",
        str(tmp_path / "walk.npz"),
    )
    assert result.returncode == 1 and "Traceback" not in result.stderr
    assert (
        "error bad-fps: 50 frames per second does not divide this simulation's 480 physics steps per second"
        in result.stderr
    )
    assert (
        "record at one of 10, 12, 15, 16, 20, 24, 30, 32, 40, 48, 60, 80, 96, 120, 160, 240, 480 fps" in result.stderr
    )
    assert list(tmp_path.iterdir()) == []


def test_bake_writes_the_gait_report_and_diagram_of_its_clip(cli, tmp_path):
    from quadpipe.exporters.npz import load_clip

    clip, report, diagram = tmp_path / "rat.npz", tmp_path / "rat.gait.json", tmp_path / "rat.png"
    result = cli(
        "bake",
        "--animal",
        "rat",
        "--controller",
        "walk",
        "--seconds",
        "4",
        "--fps",
        "120",
        "-o",
        str(clip),
        "--gait-report",
        str(report),
        "--diagram",
        str(diagram),
    )
    assert result.returncode == 0, result.stderr
    written = json.loads(report.read_text())
    expected = analyze_clip(load_clip(clip))
    assert written == json.loads(json.dumps(expected.to_dict()))
    rat = expected.animals[0]
    assert rat.gait.label == "lateral-sequence walk", rat.gait.reason  # 120 fps resolves a rat's 0.17 s stride
    assert Image.open(diagram).size == diagram_size(expected)


def test_a_wrong_diagram_suffix_is_refused_before_simulating(cli, tmp_path):
    result = cli(
        "simulate",
        "--animal",
        "dog",
        "--seconds",
        "30",
        "-o",
        str(tmp_path / "run.npz"),
        "--diagram",
        str(tmp_path / "d.jpg"),
    )
    assert result.returncode == 1 and "error unsupported-diagram-format" in result.stderr
    assert list(tmp_path.iterdir()) == []
