"""The gait report: per animal, its footfalls, stride, duty factors, phases, gait name and effort.

Plain data (`GaitReport` holds one `AnimalGait` per animal), JSON-ready through `to_dict`; times
are in seconds, lengths in metres and in pelvis heights (HP).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import Any

from quadpipe.analysis.direction import DirectionReport
from quadpipe.analysis.posture import PostureReport

HILDEBRAND_ORDER: tuple[str, ...] = ("lh", "lf", "rf", "rh")
"""Leg order of footfall diagrams and reports, top to bottom, as Hildebrand draws them."""

ALEXANDER_COEFFICIENT = 2.3
ALEXANDER_EXPONENT = 0.3
"""Alexander (1976): relative stride length lambda / HP = 2.3 Fr^0.3 for mammals."""


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
            "gait": {
                "name": self.gait.name,
                "variant": self.gait.variant,
                "label": self.gait.label,
                "reason": self.gait.reason,
            },
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
            "controller_forces": "not recorded"
            if self.effort is None
            else {
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
    """The gait analysis of a clip: one `AnimalGait` per analysed animal, their posture when
    measured, and how each directed animal played its direction when the clip has one."""

    fps: float
    frame_count: int
    animals: tuple[AnimalGait, ...] = field(default_factory=tuple)
    posture: PostureReport | None = None
    directions: tuple[DirectionReport, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready report (each animal's `posture` too, when measured)."""
        animals = {animal.name: animal.to_dict() for animal in self.animals}
        for posture in self.posture.animals if self.posture is not None else ():
            animals[posture.name]["posture"] = posture.to_dict()
        report = {
            "fps": self.fps,
            "frames": self.frame_count,
            "duration_s": max(0, self.frame_count - 1) / self.fps,
            "animals": animals,
        }
        return report | ({"directions": [d.to_dict() for d in self.directions]} if self.directions else {})

    def to_json(self) -> str:
        """The report as a JSON document (what `quadpipe analyze -o` writes)."""
        return json.dumps(self.to_dict(), indent=2, allow_nan=False) + "\n"
