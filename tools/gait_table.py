"""Posture of every animal at every gait, as one markdown table: what tuning the gaits aims at.

Run from the repository root:

    .venv/bin/python tools/gait_table.py                          # walk and trot, every animal
    .venv/bin/python tools/gait_table.py --gaits walk trot pace bound --animals dog horse -j 2
    .venv/bin/python tools/gait_table.py --json table.json        # also every figure as JSON

Each run is simulated as tests/test_gaits.py does: the gait's controller with a goal far ahead
(so that the animal goes straight), for 28 natural times sqrt(HP / g), recorded with as many
frames per natural time as the dog's 120 fps clip (31); the first 8 natural times (the animal
settling into its gait) are not measured. `quadpipe.analysis.carriage.posture_report` measures
the rest; docs/analysis.md defines each figure.

Columns (worst leg where per leg; flexion is beyond the standing angle, positive = closing):
elbow, carpus, knee, hock: largest stance flexion, degrees; land: largest elbow and carpus
flexion at a touchdown frame (a fore leg landing still folded from its swing), degrees; pelvis: mean pelvis height over
standing; roll: pelvis roll amplitude, degrees; head: mean head height change, HP; tail: % of
frames some tail shape touches the ground; slip, drag: largest foot slip and toe drag of a
stance, % HP; pen dyn/rest: deepest and median stance penetration of a foot, % HP; clear: lowest
swing clearance of a foot, % HP; touchdown: fastest descent of a foot as it lands, natural velocities.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from quadpipe.clip.model import Clip

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's quadpipe, not an installed one

SETTLE_NATURAL_TIMES = 8.0
"""Not measured at the start: the animal settles into its gait."""

MEASURE_NATURAL_TIMES = 20.0
"""Measured: 5 to 8 strides of a walk or a trot."""

FRAMES_PER_NATURAL_TIME = 31.0
"""As many as the dog's clip at its physics rate (120 fps) has."""

FAR_GOAL = "[1000 HP, 0, 0]"
"""A goal far ahead, so that the rudder keeps the animal going straight."""

HEADER = (
    "| animal | gait | measured gait | elbow° | carpus° | knee° | hock° | land elbow/carpus° | pelvis | roll° | head HP "
    "| tail % | slip %HP | drag %HP | pen dyn/rest %HP | clear %HP | touchdown |"
)


def recording_fps(animal: str) -> float:
    """A frame rate that divides the animal's physics rate and gives about 31 frames per natural time."""
    from quadpipe.animals import sizing
    from quadpipe.animals.library import load_animal

    return sizing.natural_frame_rate(load_animal(animal).pelvis_height, FRAMES_PER_NATURAL_TIME)


def measure(animal: str, gait: str) -> dict[str, Any]:
    """Simulate one animal at one gait and return its posture and gait figures as a table row's data."""
    from quadpipe.analysis import analyze_clip
    from quadpipe.analysis.carriage import posture_report
    from quadpipe.animals.library import load_animal
    from quadpipe.animals.sizing import natural_time
    from quadpipe.sim.simulation import simulate

    own_time = natural_time(load_animal(animal).pelvis_height)
    result = simulate(
        animal,
        gait,
        seconds=(SETTLE_NATURAL_TIMES + MEASURE_NATURAL_TIMES) * own_time,
        parameters={"goal": FAR_GOAL},
        fps=recording_fps(animal),
    )
    posture = posture_report(result.clip, settle_natural_times=SETTLE_NATURAL_TIMES).animals[0]
    label = analyze_clip(frames_from(result.clip, posture.first_frame)).animals[0].gait.label
    return {"animal": animal, "gait": gait, "measured_gait": label, "posture": posture.to_dict()}


def frames_from(clip: Clip, first: int) -> Clip:
    """The clip from frame `first` on (its animals only): the gait as measured after settling."""
    tracks = [
        dataclasses.replace(
            track,
            positions=track.positions[first:],
            rotations=track.rotations[first:],
            foot_contacts=track.foot_contacts[first:],
        )
        for track in clip.animals
    ]
    return dataclasses.replace(clip, animals=tracks, props=[], sensors={})


def row(data: dict[str, Any]) -> str:
    """One markdown table row."""
    posture = data["posture"]
    legs = posture["legs"].values()

    def joint(name: str, figure: str = "stance_max_deg") -> str:
        values = [leg["joints"][name][figure] for leg in legs if name in leg["joints"]]
        values = [v for v in values if v is not None]
        return f"{round(max(values)):d}" if values else "-"

    def percent(value: float | None) -> str:
        return "-" if value is None else f"{100 * value:.1f}"

    trunk, head, worst = posture["trunk"], posture["head_tail"], posture["worst"]
    cells = [
        data["animal"],
        data["gait"],
        data["measured_gait"],
        *(joint(name) for name in ("elbow", "carpus", "knee", "hock")),
        f"{joint('elbow', 'landing_max_deg')}/{joint('carpus', 'landing_max_deg')}",
        f"{trunk['pelvis_height_ratio']:.2f}",
        f"{trunk['roll_amplitude_deg']:.1f}",
        f"{head['head_dz_hp']:+.2f}",
        percent(head["tail_ground_fraction"]).removesuffix(".0"),
        percent(worst["slip_max_hp"]),
        percent(worst["toe_drag_max_hp"]),
        f"{percent(worst['penetration_dynamic_hp'])}/{percent(worst['penetration_rest_hp'])}",
        percent(worst["swing_clearance_hp"]),
        "-" if worst["touchdown_speed"] is None else f"{worst['touchdown_speed']:.2f}",
    ]
    return "| " + " | ".join(cells) + " |"


def table(rows: list[dict[str, Any]]) -> str:
    """The markdown table."""
    separator = "|" + "---|" * (HEADER.count("|") - 1)
    return "\n".join([HEADER, separator, *(row(data) for data in rows)])


def main(argv: list[str] | None = None) -> int:
    """Simulate, measure, print the table (and write the JSON)."""
    from quadpipe.core import configs

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--gaits", nargs="+", default=["walk", "trot"], help="gait controllers (default: walk trot)")
    parser.add_argument("--animals", nargs="+", default=None, help="animals (default: every built-in animal)")
    parser.add_argument("--json", type=Path, default=None, help="also write every figure to this JSON file")
    parser.add_argument("-j", "--jobs", type=int, default=1, help="simulations run in parallel (default 1)")
    arguments = parser.parse_args(argv)
    animals = arguments.animals or list(configs.available("animals"))
    runs = [(animal, gait) for animal in animals for gait in arguments.gaits]
    with ProcessPoolExecutor(max_workers=max(1, arguments.jobs)) as pool:
        rows = list(pool.map(measure, *zip(*runs)))
    print(table(rows))
    if arguments.json is not None:
        arguments.json.write_text(json.dumps(rows, indent=2, allow_nan=False) + "\n")
        print(f"wrote {arguments.json}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
