"""Gait analysis of a baked clip: footfalls, stride, duty factors, phases, Froude number, gait name.

What `quadpipe analyze run.npz` reports, per animal of the clip:

- **Footfalls** from the clip's per-frame foot contacts, cleaned: a contact or a gap lasting
  less than `MIN_RUN_NATURAL_TIMES` of the animal's natural time `sqrt(HP / g)` (26 ms for
  the dog, 5 ms for the rat), or two frames, is a flicker and does not count;
  nor does a scuff (a contact much shorter than the foot's stances) or a bounce (a lift much
  shorter than its swings).
  A clip with too few frames per natural time for the animal (a rat at 30 fps) gets a note
  naming the frame rate to record at.
- **Stride** from the left hind foot (the reference, as in Hildebrand's diagrams): the period
  is the median time between its successive touchdowns; speed, stride length and Froude number
  come from the pelvis's horizontal travel over those whole strides.
- **Duty factor** of each foot (the fraction of the strides it is down) and the **phase** of
  its touchdowns in the reference foot's stride (0..1, circular mean), with their circular spread.
- **Slip**: how far each toe tip slides horizontally while its foot is down.
- **Controller effort**, when the clip carries it (see `controller_force_key`).
- The **gait** named by Hildebrand's rules (see `classify_gait` and docs/analysis.md), and
  Alexander's check of relative stride length against `2.3 Fr^0.3`.

Everything is in quadpipe's frame (metres, +X forward, +Y left, +Z up); lengths are also given
in pelvis heights (HP), the animal's own unit.
"""

from __future__ import annotations

import io
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from quadpipe.anatomy import roles
from quadpipe.anatomy.roles import TOE_BONES
from quadpipe.clip.model import AnimalTrack, Clip
from quadpipe.core.errors import QuadpipeError, did_you_mean
from quadpipe.animals.sizing import GRAVITY, natural_time

REFERENCE_LEG = "lh"
"""The foot whose touchdowns start every stride (phase 0), as in Hildebrand's gait diagrams."""

HILDEBRAND_ORDER: tuple[str, ...] = ("lh", "lf", "rf", "rh")
"""Leg order of footfall diagrams and reports, top to bottom, as Hildebrand draws them."""


MIN_RUN_NATURAL_TIMES = 0.1
"""A contact or a gap shorter than this many natural times sqrt(HP / g) is a flicker (26 ms
for the thesis dog, 5 ms for the rat, 55 ms for the elephant). Longer runs count: a horse's
hind foot at a bound is down for 0.18 natural time."""

MIN_RUN_FRAMES = 2
"""Runs shorter than this many frames are flickers whatever the frame rate."""

MIN_FRAMES_PER_NATURAL_TIME = 6.0
"""Below this many frames per natural time sqrt(HP / g), footfalls are not resolved (a dog at
30 fps has 7.8; a rat at 30 fps, 2): the report says which frame rate to record at."""

SCUFF_FRACTION = 0.4
"""A contact shorter than this fraction of the foot's typical stance is a scuff (a toe dragging
during the swing), not a footfall; the typical stance is the 75th percentile of its contacts."""

BOUNCE_FRACTION = 0.4
"""A lift shorter than this fraction of the foot's typical swing, between two contacts, is a
bounce (the foot hopping inside one stance), not a step; the typical swing is the 75th
percentile of its lifts."""

TYPICAL_STANCE_PERCENTILE = 75.0
"""Percentile of a foot's contact (or lift) lengths taken as its typical stance (or swing)."""

IN_PHASE_TOLERANCE = 0.1
"""Two feet whose touchdowns are at most this far apart (cycles) land together."""

HALF_CYCLE_TOLERANCE = 0.1
"""A pair whose touchdowns are half a cycle apart within this (cycles) alternates: a symmetric gait."""

WALK_MIN_DUTY = 0.5
"""Hildebrand: a symmetric gait whose mean duty factor exceeds this is a walk."""

ALEXANDER_COEFFICIENT = 2.3
ALEXANDER_EXPONENT = 0.3
"""Alexander (1976): relative stride length lambda / HP = 2.3 Fr^0.3 for mammals."""

STAND_MIN_FEET_DOWN = 2.0
"""Without strides, an animal with at least this many feet down on average is standing."""

CONTROLLER_FORCE_SENSOR = "controller_force:{animal}"
"""Clip sensor: (F, 3) net external force the controller applied to the animal, newtons."""

CONTROLLER_POWER_SENSOR = "controller_power:{animal}"
"""Clip sensor: (F,) mechanical power of the controller's forces on the animal, watts."""


def controller_force_key(animal: str) -> str:
    """The sensor name of an animal's net controller force in `Clip.sensors`.

    The value is (F, 3): the vector sum of every Cartesian force the controller applied to the
    animal's bodies, in newtons, averaged over the physics steps that end at each frame (frame 0:
    zero). Force couples (equal and opposite forces) cancel in it; what is left is external.
    """
    return CONTROLLER_FORCE_SENSOR.format(animal=animal)


def controller_power_key(animal: str) -> str:
    """The sensor name of an animal's controller power in `Clip.sensors`.

    The value is (F,): the power of the controller's forces (each force dotted with the velocity
    of the point it acts on, summed), in watts, averaged over the physics steps that end at each
    frame (frame 0: zero), so that the work up to a frame is the sum of the values divided by fps.
    """
    return CONTROLLER_POWER_SENSOR.format(animal=animal)


@dataclass(frozen=True)
class Footfall:
    """One stance of one foot: from touchdown to lift-off.

    Attributes:
        touchdown_frame: first frame down; None when the foot was already down at the first frame.
        liftoff_frame: first frame up again; None when it is still down at the last analysed frame.
        slip_m: horizontal path of the toe tip while down, metres (None for an incomplete stance).
    """

    touchdown_frame: int | None
    liftoff_frame: int | None
    slip_m: float | None


@dataclass(frozen=True)
class LegGait:
    """One foot's figures.

    Attributes:
        leg: `lf`, `rf`, `lh` or `rh`.
        footfalls: its stances, in time order.
        duty_factor: fraction of the whole strides it is down (None without strides).
        phase: circular mean of its touchdowns' phases in the reference foot's strides, 0..1
            (0 for the reference foot; None without a touchdown inside a stride).
        phase_spread: circular standard deviation of those phases, cycles (0: perfectly regular).
        mean_stance_s: mean duration of its complete stances (None without one).
        mean_slip_m: mean toe-tip slip per complete stance, metres (None without one).
    """

    leg: str
    footfalls: tuple[Footfall, ...]
    duty_factor: float | None
    phase: float | None
    phase_spread: float | None
    mean_stance_s: float | None
    mean_slip_m: float | None


@dataclass(frozen=True)
class Gait:
    """A named gait.

    Attributes:
        name: stand, none, irregular, walk, running-walk, trot, pace, canter, gallop,
            half-bound, bound or pronk.
        variant: lateral-sequence or diagonal-sequence (walks), transverse or rotary (gallops).
        reason: the rule that named it, with the figures it used.
    """

    name: str
    variant: str | None
    reason: str

    @property
    def label(self) -> str:
        """`lateral-sequence walk`, `trot`, `rotary gallop`."""
        return f"{self.variant} {self.name}" if self.variant else self.name


@dataclass(frozen=True)
class ControllerEffort:
    """What the controller's forces did, when the clip recorded them (None fields: not recorded).

    Attributes:
        mean_net_force_bw: mean magnitude of the net external force, in body weights.
        work_j: total work of the controller's forces over the analysed frames, joules.
        work_j_per_kg_m: that work per kilogram of animal per metre travelled (None when it did
            not travel).
    """

    mean_net_force_bw: float | None
    work_j: float | None
    work_j_per_kg_m: float | None


@dataclass(frozen=True)
class AnimalGait:
    """One animal's gait analysis.

    Attributes:
        name: instance name in the clip.
        species: animal config name.
        pelvis_height: HP, metres.
        mass_kg: body mass.
        fps: the clip's frame rate.
        frames: frames analysed (from the first; fewer than the clip's when poses became NaN).
        stride_frames: frames of the reference foot's touchdowns that bound whole strides.
        legs: per leg, in `quadpipe.anatomy.roles.LEGS` order.
        stride_period_s: median time between reference touchdowns (None: no whole stride).
        stride_length_m: mean horizontal pelvis travel per stride.
        speed_m_s: horizontal pelvis travel over the whole strides divided by their duration.
        froude: speed^2 / (g HP).
        gait: the gait's name and why.
        effort: the controller's forces, or None when the clip does not carry them.
        notes: what limited the analysis.
    """

    name: str
    species: str
    pelvis_height: float
    mass_kg: float
    fps: float
    frames: int
    stride_frames: tuple[int, ...]
    legs: dict[str, LegGait]
    stride_period_s: float | None
    stride_length_m: float | None
    speed_m_s: float | None
    froude: float | None
    gait: Gait
    effort: ControllerEffort | None
    notes: tuple[str, ...] = ()

    @property
    def stride_count(self) -> int:
        """Number of whole strides of the reference foot."""
        return max(0, len(self.stride_frames) - 1)

    @property
    def stride_frequency_hz(self) -> float | None:
        """Strides per second (1 / period)."""
        return None if self.stride_period_s is None else 1.0 / self.stride_period_s

    @property
    def stride_length_hp(self) -> float | None:
        """Stride length in pelvis heights."""
        return None if self.stride_length_m is None else self.stride_length_m / self.pelvis_height

    @property
    def alexander_stride_hp(self) -> float | None:
        """Alexander's predicted relative stride length, 2.3 Fr^0.3 (None when not moving)."""
        if not self.froude:
            return None
        return ALEXANDER_COEFFICIENT * self.froude**ALEXANDER_EXPONENT

    @property
    def alexander_ratio(self) -> float | None:
        """Measured over predicted relative stride length (1: as Alexander's mammals)."""
        predicted = self.alexander_stride_hp
        return None if predicted is None or self.stride_length_hp is None else self.stride_length_hp / predicted

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready figures (times in seconds, lengths in metres and HP)."""
        hp = self.pelvis_height
        return {
            "name": self.name,
            "species": self.species,
            "pelvis_height_m": hp,
            "mass_kg": self.mass_kg,
            "frames_analysed": self.frames,
            "gait": {"name": self.gait.name, "variant": self.gait.variant, "label": self.gait.label, "reason": self.gait.reason},
            "strides": self.stride_count,
            "stride_period_s": self.stride_period_s,
            "stride_frequency_hz": self.stride_frequency_hz,
            "stride_length_m": self.stride_length_m,
            "stride_length_hp": self.stride_length_hp,
            "speed_m_s": self.speed_m_s,
            "froude": self.froude,
            "alexander": {
                "predicted_stride_hp": self.alexander_stride_hp,
                "measured_stride_hp": self.stride_length_hp,
                "ratio": self.alexander_ratio,
            },
            "legs": {leg: _leg_dict(self.legs[leg], self.fps, hp) for leg in HILDEBRAND_ORDER},
            "controller_forces": "not recorded" if self.effort is None else {
                "mean_net_force_bw": self.effort.mean_net_force_bw,
                "work_j": self.effort.work_j,
                "work_j_per_kg_m": self.effort.work_j_per_kg_m,
            },
            "notes": list(self.notes),
        }


def _leg_dict(leg: LegGait, fps: float, hp: float) -> dict[str, Any]:
    return {
        "duty_factor": leg.duty_factor,
        "phase": leg.phase,
        "phase_spread": leg.phase_spread,
        "mean_stance_s": leg.mean_stance_s,
        "mean_slip_m": leg.mean_slip_m,
        "mean_slip_hp": None if leg.mean_slip_m is None else leg.mean_slip_m / hp,
        "footfalls": [
            {
                "touchdown_s": None if f.touchdown_frame is None else f.touchdown_frame / fps,
                "liftoff_s": None if f.liftoff_frame is None else f.liftoff_frame / fps,
                "slip_m": f.slip_m,
            }
            for f in leg.footfalls
        ],
    }


@dataclass(frozen=True)
class GaitReport:
    """The gait analysis of a clip: one `AnimalGait` per analysed animal."""

    fps: float
    frame_count: int
    animals: tuple[AnimalGait, ...] = field(default_factory=tuple)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready report."""
        return {
            "fps": self.fps,
            "frames": self.frame_count,
            "duration_s": max(0, self.frame_count - 1) / self.fps,
            "animals": {animal.name: animal.to_dict() for animal in self.animals},
        }


def analyze_clip(clip: Clip, animal: str | None = None) -> GaitReport:
    """Analyse the gait of every animal of a clip, or of the one named `animal`.

    Raises:
        QuadpipeError: `unknown-animal` when no animal of the clip has that name;
            `bad-clip-sensor` when a controller sensor has the wrong shape.
    """
    tracks = clip.animals
    if animal is not None:
        tracks = [track for track in clip.animals if track.name == animal]
        if not tracks:
            raise QuadpipeError.single(
                "unknown-animal", f"the clip has no animal named {animal!r}",
                hint=did_you_mean(animal, [t.name for t in clip.animals]),
            )
    return GaitReport(clip.fps, clip.frame_count, tuple(_analyze_track(clip, track) for track in tracks))


def min_run_frames(fps: float, pelvis_height: float) -> int:
    """Shortest contact or gap that counts at this frame rate for an animal of this HP, in frames."""
    return max(MIN_RUN_FRAMES, round(MIN_RUN_NATURAL_TIMES * natural_time(pelvis_height) * fps))


def frame_rate_note(fps: float, pelvis_height: float) -> str | None:
    """A note when the clip has too few frames per natural time to resolve footfalls."""
    own = natural_time(pelvis_height)
    if fps * own >= MIN_FRAMES_PER_NATURAL_TIME:
        return None
    needed = math.ceil(MIN_FRAMES_PER_NATURAL_TIME / own / 10.0) * 10
    return (
        f"{fps * own:.1f} frames per natural time sqrt(HP/g) = {own * 1000:.0f} ms: too few to resolve footfalls;"
        f" record at {needed:g} fps or more (quadpipe simulate --fps)"
    )


def clean_contacts(contact: np.ndarray, min_frames: int) -> np.ndarray:
    """One foot's per-frame contacts as footfalls: flickers, then bounces, then scuffs removed.

    Bounces go before scuffs: a foot that touches, hops off and lands for good starts its
    stance at the first touch, whose short contact would otherwise be dropped as a scuff.
    """
    return drop_scuffs(fill_bounces(debounce(contact, min_frames)))


def debounce(contact: np.ndarray, min_frames: int) -> np.ndarray:
    """One foot's contacts without flickers: gaps, then contacts, shorter than `min_frames` removed.

    Args:
        contact: (F,) booleans.
        min_frames: shortest run that counts.
    """
    cleaned = np.asarray(contact, dtype=bool).copy()
    for value in (False, True):
        for start, stop in _runs(cleaned, value):
            if stop - start < min_frames:
                cleaned[start:stop] = not value
    return cleaned


def drop_scuffs(contact: np.ndarray, fraction: float = SCUFF_FRACTION) -> np.ndarray:
    """One foot's contacts without scuffs: contacts shorter than `fraction` of its typical stance.

    The typical stance is the `TYPICAL_STANCE_PERCENTILE`th percentile of its contacts' lengths,
    so that a few scuffs do not lower it.
    """
    return _drop_short_runs(contact, True, fraction)


def fill_bounces(contact: np.ndarray, fraction: float = BOUNCE_FRACTION) -> np.ndarray:
    """One foot's contacts without bounces: lifts shorter than `fraction` of its typical swing
    are filled, so that a foot hopping inside its stance makes one footfall, not two.

    Only lifts between two contacts count; the typical swing is the
    `TYPICAL_STANCE_PERCENTILE`th percentile of those lifts' lengths.
    """
    return _drop_short_runs(contact, False, fraction)


def _drop_short_runs(contact: np.ndarray, value: bool, fraction: float) -> np.ndarray:
    """`contact` with the inner runs of `value` shorter than `fraction` of the typical one flipped.

    A run of contacts counts wherever it lies; a run of lifts only between two contacts (the
    clip's first and last frames may cut a swing short).
    """
    cleaned = np.asarray(contact, dtype=bool).copy()
    runs = [(start, stop) for start, stop in _runs(cleaned, value) if value or (start > 0 and stop < len(cleaned))]
    if not runs:
        return cleaned
    typical = float(np.percentile([stop - start for start, stop in runs], TYPICAL_STANCE_PERCENTILE))
    for start, stop in runs:
        if stop - start < fraction * typical:
            cleaned[start:stop] = not value
    return cleaned


def _runs(mask: np.ndarray, value: bool) -> list[tuple[int, int]]:
    """(start, stop) frames of every maximal run of `value` in a boolean array."""
    padded = np.concatenate([[False], np.asarray(mask) == value, [False]]).astype(np.int8)
    edges = np.flatnonzero(np.diff(padded))
    return [(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2])]


def toe_tips(track: AnimalTrack, frames: int | None = None) -> dict[str, np.ndarray]:
    """World position of each toe tip per frame: the far end of the leg's last phalanx.

    A bone's body frame is aligned with the world at rest, so its end offset in that frame is
    `rest_end - rest_start`; each frame rotates it by the bone's orientation.
    """
    tips = {}
    for leg, bone in TOE_BONES.items():
        index = track.roles.index(bone)
        offset = track.rest_end[index] - track.rest_start[index]
        tips[leg] = track.positions[:frames, index] + rotate(track.rotations[:frames, index], offset)
    return tips


def rotate(quaternions: np.ndarray, vector: np.ndarray) -> np.ndarray:
    """Rotate one vector by each (w, x, y, z) unit quaternion of an (N, 4) array: (N, 3)."""
    w = quaternions[:, :1]
    axis = quaternions[:, 1:]
    twice_cross = 2.0 * np.cross(axis, vector)
    return vector + w * twice_cross + np.cross(axis, twice_cross)


def _finite_frames(track: AnimalTrack) -> int:
    """Frames from the first before any pose becomes NaN or infinite."""
    bad = ~np.isfinite(track.positions).all(axis=(1, 2)) | ~np.isfinite(track.rotations).all(axis=(1, 2))
    return int(np.argmax(bad)) if bad.any() else int(track.positions.shape[0])


def _analyze_track(clip: Clip, track: AnimalTrack) -> AnimalGait:
    frames = _finite_frames(track)
    notes = []
    if frames < track.positions.shape[0]:
        notes.append(f"poses are not finite from frame {frames} on: only frames 0-{frames - 1} are analysed")
    coarse = frame_rate_note(clip.fps, track.pelvis_height)
    if coarse is not None:
        notes.append(coarse)
    min_frames = min_run_frames(clip.fps, track.pelvis_height)
    contacts = {leg: clean_contacts(track.foot_contacts[:frames, i], min_frames) for i, leg in enumerate(roles.LEGS)}
    tips = toe_tips(track, frames)
    footfalls = {leg: _footfalls(contacts[leg], tips[leg]) for leg in roles.LEGS}
    strides = np.array([f.touchdown_frame for f in footfalls[REFERENCE_LEG] if f.touchdown_frame is not None], dtype=int)
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
    effort = _effort(clip, track, frames, pelvis)
    return AnimalGait(
        track.name, track.species, float(track.pelvis_height), float(track.mass_kg), float(clip.fps), frames,
        tuple(int(s) for s in strides), legs, period, length, speed, froude, gait, effort, tuple(notes),
    )


def _footfalls(contact: np.ndarray, tip: np.ndarray) -> tuple[Footfall, ...]:
    frames = len(contact)
    result = []
    for start, stop in _runs(contact, True):
        touchdown = start if start > 0 else None
        liftoff = stop if stop < frames else None
        slip = None
        if touchdown is not None and liftoff is not None:
            slip = float(np.linalg.norm(np.diff(tip[start:stop, :2], axis=0), axis=1).sum())
        result.append(Footfall(touchdown, liftoff, slip))
    return tuple(result)


def _leg_gait(leg: str, footfalls: tuple[Footfall, ...], contact: np.ndarray, strides: np.ndarray, fps: float) -> LegGait:
    complete = [f for f in footfalls if f.slip_m is not None]
    stance = float(np.mean([f.liftoff_frame - f.touchdown_frame for f in complete])) / fps if complete else None
    slip = float(np.mean([f.slip_m for f in complete])) if complete else None
    duty = phase = spread = None
    if len(strides):
        duty = float(contact[strides[0]:strides[-1]].mean())
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
            return Gait("irregular", None, f"{', '.join(stepping).upper()} step but the reference foot makes no whole stride")
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
    lf, rf, lh, rh = (float(phases[leg]) for leg in roles.LEGS)  # type: ignore[arg-type]
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
    return Gait("gallop", variant, f"asymmetric, fore pair lands in {order} left/right order as the hind pair ({figures})")


def _symmetric_gait(diagonality: float, duty: float, figures: str) -> Gait:
    if phase_distance(diagonality, 0.5) <= IN_PHASE_TOLERANCE:
        return Gait("trot", None, f"symmetric, diagonal pairs together ({figures})")
    if phase_distance(diagonality, 0.0) <= IN_PHASE_TOLERANCE:
        return Gait("pace", None, f"symmetric, lateral pairs together ({figures})")
    variant = "lateral-sequence" if diagonality < 0.5 else "diagonal-sequence"
    if duty > WALK_MIN_DUTY:
        return Gait("walk", variant, f"symmetric, duty above {WALK_MIN_DUTY} ({figures})")
    return Gait("running-walk", variant, f"symmetric, duty at most {WALK_MIN_DUTY} ({figures})")


def _effort(clip: Clip, track: AnimalTrack, frames: int, pelvis: np.ndarray) -> ControllerEffort | None:
    force = _sensor(clip, controller_force_key(track.name), (3,))
    power = _sensor(clip, controller_power_key(track.name), ())
    if force is None and power is None:
        return None
    mean_force = None if force is None else float(np.linalg.norm(force[:frames], axis=1).mean() / (track.mass_kg * GRAVITY))
    work = None if power is None else float(power[:frames].sum() / clip.fps)
    distance = float(np.linalg.norm(pelvis[-1] - pelvis[0])) if frames else 0.0
    per_kg_m = None if work is None or distance <= 0.0 else work / (track.mass_kg * distance)
    return ControllerEffort(mean_force, work, per_kg_m)


def _sensor(clip: Clip, key: str, item_shape: tuple[int, ...]) -> np.ndarray | None:
    if key not in clip.sensors:
        return None
    values = np.asarray(clip.sensors[key], dtype=float)
    if values.shape != (clip.frame_count, *item_shape):
        raise QuadpipeError.single(
            "bad-clip-sensor",
            f"clip sensor {key!r} has shape {values.shape}, expected {(clip.frame_count, *item_shape)}",
            hint="controller sensors hold one value per frame: (frames, 3) newtons for forces, (frames,) watts for power",
        )
    return values


def format_report(report: GaitReport) -> str:
    """The report as text for the terminal: per animal, the gait, stride and a table of the feet."""
    if not report.animals:
        return "no animals in the clip"
    return "\n\n".join(_format_animal(animal) for animal in report.animals)


def _number(value: float | None, digits: int = 2) -> str:
    return "-" if value is None else f"{value:.{digits}f}"


def _format_animal(a: AnimalGait) -> str:
    lines = [f"{a.name} ({a.species}, HP {a.pelvis_height:.2f} m): {a.gait.label} - {a.gait.reason}"]
    if a.stride_period_s is not None:
        lines.append(
            f"  {a.stride_count} strides: period {a.stride_period_s:.2f} s ({a.stride_frequency_hz:.2f} Hz), "
            f"length {a.stride_length_m:.2f} m = {a.stride_length_hp:.2f} HP, speed {a.speed_m_s:.2f} m/s, "
            f"Froude {a.froude:.3f}"
        )
        if a.alexander_ratio is not None:
            lines.append(f"  Alexander: 2.3 Fr^0.3 = {a.alexander_stride_hp:.2f} HP predicted, ratio {a.alexander_ratio:.2f}")
    lines.append("  foot  duty  phase  spread  stance(s)  slip(mm)  slip(HP)")
    for leg in HILDEBRAND_ORDER:
        g = a.legs[leg]
        slip_mm = None if g.mean_slip_m is None else 1000 * g.mean_slip_m
        slip_hp = None if g.mean_slip_m is None else g.mean_slip_m / a.pelvis_height
        lines.append(
            f"  {leg.upper():4}  {_number(g.duty_factor):>4}  {_number(g.phase):>5}  {_number(g.phase_spread):>6}  "
            f"{_number(g.mean_stance_s):>9}  {_number(slip_mm, 1):>8}  {_number(slip_hp, 3):>8}"
        )
    lines.append("  controller forces: " + _format_effort(a.effort))
    lines.extend(f"  note: {note}" for note in a.notes)
    return "\n".join(lines)


def _format_effort(effort: ControllerEffort | None) -> str:
    if effort is None:
        return "not recorded"
    parts = []
    if effort.mean_net_force_bw is not None:
        parts.append(f"mean net force {effort.mean_net_force_bw:.3f} body weights")
    if effort.work_j is not None:
        parts.append(f"work {effort.work_j:.1f} J ({_number(effort.work_j_per_kg_m, 3)} J/kg/m)")
    return ", ".join(parts)


# --- Footfall diagram -------------------------------------------------------------------------

DIAGRAM_STRIDES = 4
"""Strides shown in a footfall diagram (the last ones, the steadiest)."""

DIAGRAM_WIDTH_PX = 960
LABEL_WIDTH_PX = 56
RIGHT_MARGIN_PX = 24
TITLE_HEIGHT_PX = 52
ROW_HEIGHT_PX = 26
ROW_GAP_PX = 10
AXIS_HEIGHT_PX = 40
TICK_LENGTH_PX = 6
FONT_PX = 14
"""Layout of a footfall diagram, pixels: one panel per animal, one row per foot."""

MAX_TICKS = 12
NICE_STEPS_S = (0.05, 0.1, 0.2, 0.25, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 60.0)
"""Time axis: the smallest of these steps that needs at most `MAX_TICKS` ticks, seconds."""

BACKGROUND = (255, 255, 255)
BAR_COLOUR = (38, 84, 150)
GRID_COLOUR = (225, 225, 225)
TEXT_COLOUR = (20, 20, 20)

DIAGRAM_SUFFIXES = (".png",)


@dataclass(frozen=True)
class DiagramPanel:
    """Where one animal's footfall diagram lies in the picture, and the times it shows.

    Attributes:
        top: first pixel row of the panel.
        start_s: time at the left edge of the bars' area.
        end_s: time at its right edge.
    """

    top: int
    start_s: float
    end_s: float

    @property
    def left(self) -> int:
        """First pixel column of the bars' area."""
        return LABEL_WIDTH_PX

    @property
    def right(self) -> int:
        """Last pixel column of the bars' area."""
        return DIAGRAM_WIDTH_PX - RIGHT_MARGIN_PX - 1

    def x_of(self, seconds: float) -> float:
        """Pixel column of a time."""
        span = max(self.end_s - self.start_s, 1e-9)
        return self.left + (seconds - self.start_s) / span * (self.right - self.left)

    def row_band(self, row: int) -> tuple[int, int]:
        """First and last pixel rows of the bars of the `row`-th foot (`HILDEBRAND_ORDER`)."""
        top = self.top + TITLE_HEIGHT_PX + row * (ROW_HEIGHT_PX + ROW_GAP_PX)
        return top, top + ROW_HEIGHT_PX - 1

    @property
    def axis_y(self) -> int:
        """Pixel row of the time axis."""
        return self.top + TITLE_HEIGHT_PX + len(HILDEBRAND_ORDER) * (ROW_HEIGHT_PX + ROW_GAP_PX)


PANEL_HEIGHT_PX = TITLE_HEIGHT_PX + len(HILDEBRAND_ORDER) * (ROW_HEIGHT_PX + ROW_GAP_PX) + AXIS_HEIGHT_PX


def diagram_size(report: GaitReport) -> tuple[int, int]:
    """Width and height in pixels of the report's footfall diagram (at least one panel tall)."""
    return DIAGRAM_WIDTH_PX, PANEL_HEIGHT_PX * max(1, len(report.animals))


def diagram_panels(report: GaitReport) -> list[DiagramPanel]:
    """Each animal's panel: its last `DIAGRAM_STRIDES` whole strides, or all it has (or the clip)."""
    panels = []
    for index, animal in enumerate(report.animals):
        strides = animal.stride_frames
        if strides:
            first, last = strides[max(0, len(strides) - 1 - DIAGRAM_STRIDES)], strides[-1]
        else:
            first, last = 0, max(1, animal.frames - 1)
        panels.append(DiagramPanel(index * PANEL_HEIGHT_PX, first / animal.fps, last / animal.fps))
    return panels


def check_diagram_path(path: str | Path) -> None:
    """Raise `unsupported-diagram-format` unless the path ends in a diagram suffix (.png)."""
    suffix = Path(path).suffix.lower()
    if suffix not in DIAGRAM_SUFFIXES:
        raise QuadpipeError.single(
            "unsupported-diagram-format",
            f"cannot draw a footfall diagram as {suffix or 'a file without suffix'!r}: {str(path)!r}",
            file=str(path), hint="footfall diagrams are PNG pictures: name the file *.png",
        )


def footfall_diagram_png(report: GaitReport) -> bytes:
    """The footfall (Hildebrand) diagram as PNG bytes: a panel per animal, a row of stance bars per foot."""
    from PIL import Image, ImageDraw, ImageFont

    image = Image.new("RGB", diagram_size(report), BACKGROUND)
    draw = ImageDraw.Draw(image)
    font = ImageFont.load_default(size=FONT_PX)
    if not report.animals:
        draw.text((LABEL_WIDTH_PX, TITLE_HEIGHT_PX), "no animals in the clip", font=font, fill=TEXT_COLOUR)
    for animal, panel in zip(report.animals, diagram_panels(report)):
        _draw_panel(draw, font, animal, panel)
    buffer = io.BytesIO()
    image.save(buffer, format="PNG")
    return buffer.getvalue()


def draw_footfall_diagram(report: GaitReport, path: str | Path) -> None:
    """Write the footfall diagram as a PNG file, atomically.

    Raises:
        QuadpipeError: `unsupported-diagram-format`, or `unwritable-output`.
    """
    from quadpipe.core.atomic import write_bytes

    check_diagram_path(path)
    write_bytes(path, footfall_diagram_png(report))


def _draw_panel(draw: Any, font: Any, animal: AnimalGait, panel: DiagramPanel) -> None:
    _draw_title(draw, font, animal, panel)
    ticks = _ticks(panel.start_s, panel.end_s)
    bands_top, bands_bottom = panel.row_band(0)[0], panel.row_band(len(HILDEBRAND_ORDER) - 1)[1]
    for tick in ticks:
        x = round(panel.x_of(tick))
        draw.line((x, bands_top, x, bands_bottom), fill=GRID_COLOUR)
    for row, leg in enumerate(HILDEBRAND_ORDER):
        top, bottom = panel.row_band(row)
        draw.text((8, (top + bottom) / 2), leg.upper(), font=font, fill=TEXT_COLOUR, anchor="lm")
        for start, end in _stance_spans(animal, leg, panel):
            draw.rectangle((round(panel.x_of(start)), top, round(panel.x_of(end)), bottom), fill=BAR_COLOUR)
    _draw_axis(draw, font, panel, ticks)


def _draw_title(draw: Any, font: Any, animal: AnimalGait, panel: DiagramPanel) -> None:
    title = f"{animal.name} ({animal.species}): {animal.gait.label}"
    if animal.speed_m_s is not None:
        title += f", {animal.speed_m_s:.2f} m/s, Fr {animal.froude:.3f}, stride {animal.stride_period_s:.2f} s"
    duties = "duty " + "  ".join(f"{leg.upper()} {_number(animal.legs[leg].duty_factor)}" for leg in HILDEBRAND_ORDER)
    draw.text((8, panel.top + 6), title, font=font, fill=TEXT_COLOUR)
    draw.text((8, panel.top + 6 + FONT_PX + 6), duties, font=font, fill=TEXT_COLOUR)


def _draw_axis(draw: Any, font: Any, panel: DiagramPanel, ticks: list[float]) -> None:
    y = panel.axis_y
    draw.line((panel.left, y, panel.right, y), fill=TEXT_COLOUR)
    for tick in ticks:
        x = round(panel.x_of(tick))
        draw.line((x, y, x, y + TICK_LENGTH_PX), fill=TEXT_COLOUR)
        draw.text((x, y + TICK_LENGTH_PX + 2), f"{tick:g}", font=font, fill=TEXT_COLOUR, anchor="mt")
    draw.text((panel.right, y + TICK_LENGTH_PX + 2 + FONT_PX + 2), "time (s)", font=font, fill=TEXT_COLOUR, anchor="rt")


def _stance_spans(animal: AnimalGait, leg: str, panel: DiagramPanel) -> list[tuple[float, float]]:
    """Stance intervals of a foot, seconds, clipped to the panel's time span."""
    spans = []
    for footfall in animal.legs[leg].footfalls:
        start = 0.0 if footfall.touchdown_frame is None else footfall.touchdown_frame / animal.fps
        end = (animal.frames - 1) / animal.fps if footfall.liftoff_frame is None else footfall.liftoff_frame / animal.fps
        start, end = max(start, panel.start_s), min(end, panel.end_s)
        if end > start:
            spans.append((start, end))
    return spans


def _ticks(start: float, end: float) -> list[float]:
    """Round times between start and end, at the smallest nice step giving at most `MAX_TICKS`."""
    span = max(end - start, 1e-9)
    step = next((s for s in NICE_STEPS_S if span / s <= MAX_TICKS), NICE_STEPS_S[-1])
    first = math.ceil(start / step - 1e-9)
    last = math.floor(end / step + 1e-9)
    return [round(k * step, 6) for k in range(first, last + 1)]
