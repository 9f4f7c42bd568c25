"""The posture report: how an animal carries itself, against its own standing (rest) pose.

Plain data (`PostureReport` holds one `AnimalPosture` per animal), JSON-ready through
`to_dict`. Angles are in degrees, relative to the same angle in the animal's rest pose (its
standing pose); lengths in pelvis heights (HP); so the same thresholds hold for the rat and
the elephant. `quadpipe.analysis.carriage.posture_report` measures it; docs/analysis.md
defines every figure.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import Any

from quadpipe.anatomy.roles import LEGS

FORE_JOINTS: tuple[str, ...] = ("shoulder", "elbow", "carpus")
"""The fore leg's joints whose flexion is measured, body to foot."""

HIND_JOINTS: tuple[str, ...] = ("hip", "knee", "hock")
"""The hind leg's joints whose flexion is measured, body to foot."""


@dataclass(frozen=True)
class JointFlexion:
    """One joint's flexion, degrees beyond its rest (standing) angle; positive closes the joint.

    Attributes:
        joint: shoulder, elbow or carpus (fore); hip, knee or hock (hind).
        stance_max_deg: largest flexion over the stance frames (None: no stance frame).
        stance_mean_deg: mean flexion over the stance frames.
        stance_min_deg: smallest flexion over the stance frames (negative: extension).
        swing_max_deg: largest flexion over the swing frames (None: no swing frame).
        landing_max_deg: largest flexion at a touchdown, the first frame of a stance seen to
            start (None: no touchdown measured); the stance figures leave out each stance's
            first tenth, so a leg that lands still folded from its swing shows here.
    """

    joint: str
    stance_max_deg: float | None
    stance_mean_deg: float | None
    stance_min_deg: float | None
    swing_max_deg: float | None
    landing_max_deg: float | None = None

    def to_dict(self) -> dict[str, float | None]:
        """JSON-ready figures."""
        return {
            "stance_max_deg": self.stance_max_deg,
            "stance_mean_deg": self.stance_mean_deg,
            "stance_min_deg": self.stance_min_deg,
            "swing_max_deg": self.swing_max_deg,
            "landing_max_deg": self.landing_max_deg,
        }


@dataclass(frozen=True)
class LegPosture:
    """One leg's joints and foot.

    Attributes:
        leg: `lf`, `rf`, `lh` or `rh`.
        joints: flexion per joint name (`FORE_JOINTS` or `HIND_JOINTS`).
        stances: complete stances measured for slip and drag.
        slip_hp: mean over complete stances of the foot's slip (None without one).
        slip_max_hp: the largest slip of a stance.
        toe_drag_hp: mean over complete stances of the toe tip's forward travel before lift-off.
        toe_drag_max_hp: the largest such travel.
        penetration_dynamic_hp: deepest any foot shape goes below the ground, any frame (None:
            the foot has no shapes).
        penetration_rest_hp: median depth of the foot's lowest point over its stance frames.
        swing_clearance_hp: over complete swings, the lowest height of the foot's lowest point
            above the ground in the middle half of a swing, worst swing (None: no complete
            swing or no foot shapes; negative: the foot scuffs or sinks mid-swing).
        touchdown_speed: the largest downward speed of the foot's lowest point over the frames
            just before a touchdown, in natural velocities sqrt(g HP) (None: no touchdown
            measured or no foot shapes).
    """

    leg: str
    joints: dict[str, JointFlexion]
    stances: int
    slip_hp: float | None
    slip_max_hp: float | None
    toe_drag_hp: float | None
    toe_drag_max_hp: float | None
    penetration_dynamic_hp: float | None
    penetration_rest_hp: float | None
    swing_clearance_hp: float | None = None
    touchdown_speed: float | None = None

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready figures."""
        return {
            "joints": {name: joint.to_dict() for name, joint in self.joints.items()},
            "stances": self.stances,
            "slip_hp": self.slip_hp,
            "slip_max_hp": self.slip_max_hp,
            "toe_drag_hp": self.toe_drag_hp,
            "toe_drag_max_hp": self.toe_drag_max_hp,
            "penetration_dynamic_hp": self.penetration_dynamic_hp,
            "penetration_rest_hp": self.penetration_rest_hp,
            "swing_clearance_hp": self.swing_clearance_hp,
            "touchdown_speed": self.touchdown_speed,
        }


@dataclass(frozen=True)
class TrunkPosture:
    """How the trunk rides.

    Attributes:
        pelvis_height_ratio: mean pelvis height above the ground over its standing height.
        pelvis_height_ratio_min: the lowest such ratio.
        withers_height_ratio: mean withers (thorax joint) height over its standing height.
        roll_mean_deg: mean pelvis roll (positive: left side up).
        roll_amplitude_deg: half the peak-to-peak pelvis roll, per stride, averaged.
        yaw_amplitude_deg: half the peak-to-peak pelvis heading about its trend, per stride, averaged.
    """

    pelvis_height_ratio: float
    pelvis_height_ratio_min: float
    withers_height_ratio: float
    roll_mean_deg: float
    roll_amplitude_deg: float
    yaw_amplitude_deg: float


@dataclass(frozen=True)
class HeadTailPosture:
    """How the head and the tail are carried.

    Attributes:
        head_dz_hp: mean height of the head's centre above the ground minus its standing height.
        head_dz_max_abs_hp: the largest departure of that height from standing, either way.
        head_pitch_deg: mean elevation of the head's axis minus its standing elevation
            (positive: nose up).
        neck_angle_deg: mean elevation of the neck line (neck base to head joint) minus its
            standing elevation (positive: raised).
        tail_ground_fraction: fraction of the frames in which some tail shape touches or dips
            below the ground (None: the tail has no shapes).
        tail_elevation_deg: mean elevation of the tail base (`tail0`) above the horizontal
            (negative: pointing down).
        tail_elevation_rest_deg: the same in the standing pose.
        tail_chord_deg: mean elevation of the line from the tail's root to its tip above the
            horizontal (0: carried out behind; -90: hanging).
    """

    head_dz_hp: float
    head_dz_max_abs_hp: float
    head_pitch_deg: float
    neck_angle_deg: float
    tail_ground_fraction: float | None
    tail_elevation_deg: float
    tail_elevation_rest_deg: float
    tail_chord_deg: float


@dataclass(frozen=True)
class AnimalPosture:
    """One animal's posture over the measured frames.

    Attributes:
        name: instance name in the clip.
        species: animal config name.
        pelvis_height: HP, metres.
        fps: the clip's frame rate.
        first_frame: first measured frame (after settling).
        frames: measured frames, from `first_frame`.
        strides: whole strides of the left hind foot inside the measured frames.
        legs: per leg, in `quadpipe.anatomy.roles.LEGS` order.
        trunk: the trunk's carriage.
        head_tail: the head's and the tail's carriage.
        notes: what limited the measurement.
    """

    name: str
    species: str
    pelvis_height: float
    fps: float
    first_frame: int
    frames: int
    strides: int
    legs: dict[str, LegPosture]
    trunk: TrunkPosture
    head_tail: HeadTailPosture
    notes: tuple[str, ...] = ()

    def worst_flexion_deg(self, joint: str, figure: str = "stance_max_deg") -> float | None:
        """The largest value of a `JointFlexion` figure of a joint (by default its stance
        flexion; `landing_max_deg`: at a touchdown) over the legs that have it (None: never
        measured)."""
        values = [
            getattr(leg.joints[joint], figure)
            for leg in self.legs.values()
            if joint in leg.joints and getattr(leg.joints[joint], figure) is not None
        ]
        return max(values, default=None)

    def worst(self, figure: str) -> float | None:
        """The largest value of a `LegPosture` figure over the legs (None: no leg measured it)."""
        values = [getattr(leg, figure) for leg in self.legs.values() if getattr(leg, figure) is not None]
        return max(values, default=None)

    def lowest(self, figure: str) -> float | None:
        """The smallest value of a `LegPosture` figure over the legs (None: no leg measured it)."""
        values = [getattr(leg, figure) for leg in self.legs.values() if getattr(leg, figure) is not None]
        return min(values, default=None)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready figures (angles in degrees, lengths in HP)."""
        return {
            "name": self.name,
            "species": self.species,
            "pelvis_height_m": self.pelvis_height,
            "first_frame": self.first_frame,
            "first_s": self.first_frame / self.fps,
            "frames_measured": self.frames,
            "strides": self.strides,
            "legs": {leg: self.legs[leg].to_dict() for leg in LEGS},
            "trunk": vars(self.trunk).copy(),
            "head_tail": vars(self.head_tail).copy(),
            "worst": {
                "slip_max_hp": self.worst("slip_max_hp"),
                "toe_drag_max_hp": self.worst("toe_drag_max_hp"),
                "penetration_dynamic_hp": self.worst("penetration_dynamic_hp"),
                "penetration_rest_hp": self.worst("penetration_rest_hp"),
                "swing_clearance_hp": self.lowest("swing_clearance_hp"),
                "touchdown_speed": self.worst("touchdown_speed"),
            },
            "notes": list(self.notes),
        }


@dataclass(frozen=True)
class PostureReport:
    """The posture of a clip's animals: one `AnimalPosture` per measured animal."""

    fps: float
    animals: tuple[AnimalPosture, ...] = field(default_factory=tuple)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready report."""
        return {"fps": self.fps, "animals": {animal.name: animal.to_dict() for animal in self.animals}}

    def to_json(self) -> str:
        """The report as a JSON document."""
        return json.dumps(self.to_dict(), indent=2, allow_nan=False) + "\n"
