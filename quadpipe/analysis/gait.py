"""Gait metrics and classification: strides of the reference foot, duty factors, touchdown phases,
speed and Froude number, and the gait named by Hildebrand's rules."""

from __future__ import annotations

import math

import numpy as np

from quadpipe.analysis.effort import controller_effort
from quadpipe.analysis.footfalls import (
    clean_contacts,
    finite_frames,
    footfalls_of,
    frame_rate_note,
    min_run_frames,
    named_tracks,
    toe_tips,
)
from quadpipe.analysis.report import AnimalGait, Footfall, Gait, GaitReport, LegGait
from quadpipe.anatomy import roles
from quadpipe.animals.sizing import GRAVITY
from quadpipe.clip.model import AnimalTrack, Clip

REFERENCE_LEG = "lh"
"""The foot whose touchdowns start every stride (phase 0), as in Hildebrand's gait diagrams."""

IN_PHASE_TOLERANCE = 0.1
"""Two feet whose touchdowns are at most this far apart (cycles) land together."""

HALF_CYCLE_TOLERANCE = 0.1
"""A pair whose touchdowns are half a cycle apart within this (cycles) alternates: a symmetric gait."""

WALK_MIN_DUTY = 0.5
"""Hildebrand: a symmetric gait whose mean duty factor exceeds this is a walk."""

STAND_MIN_FEET_DOWN = 2.0
"""Without strides, an animal with at least this many feet down on average is standing."""


def analyze_clip(clip: Clip, animal: str | None = None) -> GaitReport:
    """Analyse the gait of every animal of a clip, or of the one named `animal`.

    Raises:
        QuadpipeError: `unknown-animal` when no animal of the clip has that name;
            `bad-clip-sensor` when a controller sensor has the wrong shape.
    """
    tracks = named_tracks(clip, animal)
    return GaitReport(clip.fps, clip.frame_count, tuple(_analyze_track(clip, track) for track in tracks))


def _analyze_track(clip: Clip, track: AnimalTrack) -> AnimalGait:
    frames = finite_frames(track)
    notes = []
    if frames < track.positions.shape[0]:
        notes.append(f"poses are not finite from frame {frames} on: only frames 0-{frames - 1} are analysed")
    coarse = frame_rate_note(clip.fps, track.pelvis_height)
    if coarse is not None:
        notes.append(coarse)
    min_frames = min_run_frames(clip.fps, track.pelvis_height)
    contacts = {leg: clean_contacts(track.foot_contacts[:frames, i], min_frames) for i, leg in enumerate(roles.LEGS)}
    tips = toe_tips(track, frames)
    footfalls = {leg: footfalls_of(contacts[leg], tips[leg]) for leg in roles.LEGS}
    strides = np.array(
        [f.touchdown_frame for f in footfalls[REFERENCE_LEG] if f.touchdown_frame is not None], dtype=int
    )
    if len(strides) < 2:
        notes.append(f"the reference foot ({REFERENCE_LEG.upper()}) makes fewer than two touchdowns: no whole stride")
        strides = strides[:0]
    legs = {leg: _leg_gait(leg, footfalls[leg], contacts[leg], strides, clip.fps) for leg in roles.LEGS}
    pelvis = track.positions[:frames, roles.ROLES.index("pelvis"), :2]
    period = speed = length = froude = None
    if len(strides):
        period = float(np.median(np.diff(strides))) / clip.fps
        travel = np.linalg.norm(np.diff(pelvis[strides], axis=0), axis=1)
        speed = float(travel.sum() / ((strides[-1] - strides[0]) / clip.fps))
        length = float(travel.mean())
        froude = speed**2 / (GRAVITY * track.pelvis_height)
    gait = _name_gait(legs, contacts, strides)
    effort = controller_effort(clip, track, frames, pelvis)
    return AnimalGait(
        track.name,
        track.species,
        float(track.pelvis_height),
        float(track.mass_kg),
        float(clip.fps),
        frames,
        tuple(int(s) for s in strides),
        legs,
        period,
        length,
        speed,
        froude,
        gait,
        effort,
        tuple(notes),
    )


def _leg_gait(
    leg: str, footfalls: tuple[Footfall, ...], contact: np.ndarray, strides: np.ndarray, fps: float
) -> LegGait:
    complete = [
        (f.liftoff_frame - f.touchdown_frame, f.slip_m)
        for f in footfalls
        if f.touchdown_frame is not None and f.liftoff_frame is not None and f.slip_m is not None
    ]
    stance = float(np.mean([frames for frames, _ in complete])) / fps if complete else None
    slip = float(np.mean([slip_m for _, slip_m in complete])) if complete else None
    duty = phase = spread = None
    if len(strides):
        duty = float(contact[strides[0] : strides[-1]].mean())
        phases = _phases([f.touchdown_frame for f in footfalls if f.touchdown_frame is not None], strides)
        if len(phases):
            phase, spread = circular_mean(phases)
    return LegGait(leg, footfalls, duty, phase, spread, stance, slip)


def _phases(touchdowns: list[int], strides: np.ndarray) -> np.ndarray:
    """Phase of each touchdown inside the reference strides: (t - start) / (end - start)."""
    times = np.array([t for t in touchdowns if strides[0] <= t < strides[-1]], dtype=float)
    index = np.searchsorted(strides, times, side="right") - 1
    return (times - strides[index]) / (strides[index + 1] - strides[index])


def circular_mean(phases: np.ndarray) -> tuple[float, float]:
    """Circular mean (0..1) and circular standard deviation (cycles) of phases in cycles."""
    angles = 2.0 * np.pi * np.asarray(phases, dtype=float)
    mean_cos, mean_sin = float(np.cos(angles).mean()), float(np.sin(angles).mean())
    resultant = min(1.0, math.hypot(mean_cos, mean_sin))
    mean = (math.atan2(mean_sin, mean_cos) / (2.0 * math.pi)) % 1.0
    spread = math.sqrt(max(0.0, -2.0 * math.log(max(resultant, 1e-12)))) / (2.0 * math.pi)
    return (0.0 if mean >= 1.0 - 1e-12 else mean), spread


def phase_distance(a: float, b: float) -> float:
    """Distance between two phases around the cycle, 0..0.5."""
    difference = (a - b) % 1.0
    return min(difference, 1.0 - difference)


def _name_gait(legs: dict[str, LegGait], contacts: dict[str, np.ndarray], strides: np.ndarray) -> Gait:
    if len(strides) == 0:
        stepping = [leg for leg in roles.LEGS if sum(f.touchdown_frame is not None for f in legs[leg].footfalls) >= 2]
        if stepping:
            return Gait(
                "irregular", None, f"{', '.join(stepping).upper()} step but the reference foot makes no whole stride"
            )
        feet_down = sum(float(c.mean()) if len(c) else 0.0 for c in contacts.values())
        if feet_down >= STAND_MIN_FEET_DOWN:
            return Gait("stand", None, f"no stepping, {feet_down:.1f} feet down on average")
        return Gait("none", None, f"no stepping, {feet_down:.1f} feet down on average")
    phases = {leg: legs[leg].phase for leg in roles.LEGS}
    duty = float(np.mean([legs[leg].duty_factor for leg in roles.LEGS]))
    return classify_gait(phases, duty)


def classify_gait(phases: dict[str, float | None], duty: float) -> Gait:
    """Name a gait from the touchdown phases (relative to the left hind) and the mean duty factor.

    Rules, in order (tolerances `IN_PHASE_TOLERANCE`, `HALF_CYCLE_TOLERANCE`):

    1. a foot without a phase -> irregular;
    2. all four together -> pronk;
    3. symmetric (hind pair and fore pair each half a cycle apart): by diagonality D, the phase
       of the left fore: D ~ 0.5 -> trot, D ~ 0 -> pace, otherwise a walk when the duty factor
       exceeds 0.5 (a running walk when not), lateral-sequence for D < 0.5, diagonal for D > 0.5;
    4. asymmetric: both pairs together -> bound; hind pair together -> half-bound; a diagonal
       pair together -> canter; otherwise a gallop, transverse when the fore pair lands in the
       same left/right order as the hind pair, rotary when in the opposite order.

    Args:
        phases: per leg (`lf`, `rf`, `lh`, `rh`), 0..1 or None.
        duty: mean duty factor of the four feet.
    """
    missing = [leg for leg in roles.LEGS if phases[leg] is None]
    if missing:
        return Gait("irregular", None, f"{', '.join(missing).upper()} make no footfall inside the reference strides")
    # every phase is known here (a missing one returned above)
    lf, rf, lh, rh = (float(phase) for phase in (phases[leg] for leg in roles.LEGS) if phase is not None)
    hind, fore = phase_distance(rh, lh), phase_distance(rf, lf)
    figures = f"diagonality {lf:.2f}, hind pair {hind:.2f} apart, fore pair {fore:.2f} apart, duty {duty:.2f}"
    together = IN_PHASE_TOLERANCE
    if max(hind, fore, phase_distance(lf, lh)) <= together:
        return Gait("pronk", None, f"all four feet land together ({figures})")
    if abs(hind - 0.5) <= HALF_CYCLE_TOLERANCE and abs(fore - 0.5) <= HALF_CYCLE_TOLERANCE:
        return _symmetric_gait(lf, duty, figures)
    if hind <= together and fore <= together:
        return Gait("bound", None, f"hind feet together, fore feet together ({figures})")
    if hind <= together:
        return Gait("half-bound", None, f"hind feet together, fore feet apart ({figures})")
    if phase_distance(lf, rh) <= together or phase_distance(rf, lh) <= together:
        return Gait("canter", None, f"asymmetric, one diagonal pair together ({figures})")
    hind_left_first = (rh - lh) % 1.0 < 0.5
    fore_left_first = (rf - lf) % 1.0 < 0.5
    variant = "transverse" if hind_left_first == fore_left_first else "rotary"
    order = "the same" if variant == "transverse" else "the opposite"
    return Gait(
        "gallop", variant, f"asymmetric, fore pair lands in {order} left/right order as the hind pair ({figures})"
    )


def _symmetric_gait(diagonality: float, duty: float, figures: str) -> Gait:
    if phase_distance(diagonality, 0.5) <= IN_PHASE_TOLERANCE:
        return Gait("trot", None, f"symmetric, diagonal pairs together ({figures})")
    if phase_distance(diagonality, 0.0) <= IN_PHASE_TOLERANCE:
        return Gait("pace", None, f"symmetric, lateral pairs together ({figures})")
    variant = "lateral-sequence" if diagonality < 0.5 else "diagonal-sequence"
    if duty > WALK_MIN_DUTY:
        return Gait("walk", variant, f"symmetric, duty above {WALK_MIN_DUTY} ({figures})")
    return Gait("running-walk", variant, f"symmetric, duty at most {WALK_MIN_DUTY} ({figures})")
