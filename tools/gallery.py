"""Render the gallery: every animal's walk and fastest gait, seen from the side and from behind.

Run from the repository root (about a minute per animal and gait on one core):

    .venv/bin/python tools/gallery.py                      # every animal -> docs/gallery/, docs/gallery.md
    .venv/bin/python tools/gallery.py --animals dog horse -j 2   # those two again, the others' rows kept

For each animal (`configs/animals`) and each of two gaits, its `walk` and its fastest gait
(`gaits_of`: of its repertoire's gaits with a controller, the one used up to the highest
Froude number), the gait's controller runs with a goal far ahead for `SETTLE_NATURAL_TIMES` natural times
sqrt(HP / g) to settle, then `SHOWN_NATURAL_TIMES` more. Two whole strides of the settled part
(from a left hind touchdown, as `quadpipe analyze` finds them) make the contact sheets, side
and rear (4 x 3 tiles: six a stride); the whole settled part, seen from the side, makes the
MP4, in real time. The views are turned to the animal's mean heading over what they show
(a gait that veers off its goal is still seen from its side). Every file is rendered with
the animals' skinned bodies and the default overlays (feet down, pelvis trail). The page docs/gallery.md is written last, with each
clip's measured gait, speed and stride (kept in docs/gallery/gallery.json, so that a run
for a few animals replaces their rows and keeps the others').
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
    from quadpipe.render import Camera

OUTPUT = Path("docs/gallery")
PAGE = Path("docs/gallery.md")
FIGURES = OUTPUT / "gallery.json"
"""Every clip's row of the page: a run for a few animals replaces theirs and keeps the others'."""

SETTLE_NATURAL_TIMES = 8.0
"""Simulated before anything is shown: the animal settles into its gait."""

SHOWN_NATURAL_TIMES = 12.0
"""Simulated after settling: the video, and the strides the sheets pick from."""

SHEET_STRIDES = 2
"""Whole strides a contact sheet shows."""

FRAMES_PER_STRIDE = 24
"""Recorded frames per stride at least, so that a sheet's tiles fall evenly in the stride."""

VIDEO_FPS = 30.0
"""The videos' frame rate (real time)."""

TILE = (320, 240)
"""Width and height of a contact sheet tile, pixels (a sheet is 4 x 3 tiles)."""

VIDEO_SIZE = (320, 240)
"""Width and height of a video frame, pixels."""

FAR_GOAL = "[1000 HP, 0, 0]"
"""A goal far ahead, so that the animal goes straight along +x (the views assume it)."""

FIGURE_DECIMALS = 2
"""Decimals kept of the measured Froude number, speed (m/s) and stride period (s), as the page
shows them: they vary by more than that from stride to stride, and a recorded frame is 1/30 s
or shorter."""

SHEET_VIEWS = ("side", "rear")
VIDEO_VIEW = "side"


def gaits_of(animal: str) -> list[str]:
    """The animal's walk and its fastest gait: of the gaits of its repertoire that have a
    controller, the one used up to the highest Froude number (the first listed of those that
    tie: the gallop before the bound of the cat and the rat)."""
    from quadpipe.animals.library import load_animal
    from quadpipe.core import configs

    controllers = set(configs.available("controllers"))
    repertoire = {gait: use for gait, use in load_animal(animal).gaits.items() if gait in controllers}
    fastest = max(repertoire, key=lambda gait: repertoire[gait].froude[1])
    return list(dict.fromkeys(["walk", fastest]))


def recording_fps(animal: str) -> float:
    """A frame rate that divides the animal's physics rate, at least `VIDEO_FPS`, and with
    about `FRAMES_PER_STRIDE` frames in a stride of its walk (its fastest gait has shorter
    strides, but no fewer than half as many frames)."""
    from quadpipe.animals import sizing
    from quadpipe.animals.library import load_animal

    pelvis_height = load_animal(animal).pelvis_height
    step = sizing.timestep(pelvis_height)
    stride_s = 3.0 * sizing.natural_time(pelvis_height)  # a walk's stride, about 3 natural times
    wanted = max(VIDEO_FPS, FRAMES_PER_STRIDE / stride_s)
    return 1.0 / (max(1, int(1.0 / (wanted * step))) * step)


def frames_between(clip: Clip, first: int, stop: int) -> Clip:
    """The clip's frames `first` to `stop` (excluded), its animals only."""
    tracks = [
        dataclasses.replace(
            track,
            positions=track.positions[first:stop],
            rotations=track.rotations[first:stop],
            foot_contacts=track.foot_contacts[first:stop],
        )
        for track in clip.animals
    ]
    return dataclasses.replace(clip, animals=tracks, props=[], sensors={})


def heading_deg(clip: Clip) -> float:
    """The first animal's mean heading over the clip, degrees counter-clockwise from +x (the
    horizontal direction from its pelvis to its thorax)."""
    import numpy as np

    from quadpipe.anatomy.roles import ROLES

    positions = clip.animals[0].positions
    forward = positions[:, ROLES.index("thorax"), :2] - positions[:, ROLES.index("pelvis"), :2]
    forward /= np.linalg.norm(forward, axis=1, keepdims=True)
    return float(np.degrees(np.arctan2(*forward.mean(axis=0)[::-1])))


def turned_view(view: str, clip: Clip) -> Camera:
    """The named view (`quadpipe.render.VIEWS`, for an animal heading +x) turned to the
    animal's own mean heading: a gait that veers off the goal is still seen from its side."""
    from quadpipe.render import view_camera

    camera = view_camera(view)
    return dataclasses.replace(camera, azimuth_deg=camera.azimuth_deg + heading_deg(clip))


def render_one(animal: str, gait: str) -> dict[str, Any]:
    """Simulate one animal at one gait, render its sheets and video, and return the page's figures."""
    from quadpipe.analysis import analyze_clip
    from quadpipe.animals.library import load_animal
    from quadpipe.animals.sizing import natural_time
    from quadpipe.render import render_clip
    from quadpipe.sim.simulation import simulate

    own_time = natural_time(load_animal(animal).pelvis_height)
    fps = recording_fps(animal)
    result = simulate(
        animal,
        gait,
        seconds=(SETTLE_NATURAL_TIMES + SHOWN_NATURAL_TIMES) * own_time,
        parameters={"goal": FAR_GOAL},
        fps=fps,
    )
    settled = frames_between(result.clip, round(SETTLE_NATURAL_TIMES * own_time * fps), result.clip.frame_count)
    report = analyze_clip(settled).animals[0]
    strides = report.stride_frames
    first, stop = (strides[0], strides[SHEET_STRIDES]) if len(strides) > SHEET_STRIDES else (0, settled.frame_count)
    shown = frames_between(settled, first, stop)
    OUTPUT.mkdir(parents=True, exist_ok=True)
    stem = f"{animal}_{gait}"
    files = {}
    for view in SHEET_VIEWS:
        files[view] = OUTPUT / f"{stem}_{view}.png"
        render_clip(shown, files[view], width=TILE[0], height=TILE[1], camera=turned_view(view, shown))
    files["video"] = OUTPUT / f"{stem}.mp4"
    width, height = VIDEO_SIZE
    render_clip(
        settled,
        files["video"],
        width=width,
        height=height,
        fps=VIDEO_FPS,
        camera=turned_view(VIDEO_VIEW, settled),
    )
    return rounded_figures(
        {
            "animal": animal,
            "gait": gait,
            "measured": report.gait.label,
            "froude": report.froude,
            "speed_m_s": report.speed_m_s,
            "period_s": report.stride_period_s,
            "fell": bool(result.metrics["animals"][result.clip.animals[0].name]["fell"]),
            "files": {name: path.name for name, path in files.items()},
        }
    )


def rounded_figures(row: dict[str, Any]) -> dict[str, Any]:
    """A row of the page with its measured figures rounded to `FIGURE_DECIMALS`; a figure that
    could not be measured stays None."""
    return row | {
        name: None if row[name] is None else round(row[name], FIGURE_DECIMALS)
        for name in ("froude", "speed_m_s", "period_s")
    }


def _figure(value: float | None) -> str:
    return "-" if value is None else f"{value:.{FIGURE_DECIMALS}f}"


def page(rows: list[dict[str, Any]]) -> str:
    """docs/gallery.md: how the gallery was made, then a table per animal."""
    lines = [
        "# Gallery",
        "",
        "Every animal's walk and the fastest gait of its species' repertoire (`gaits:` in",
        "`configs/animals/<animal>.yaml`: the gallop for most, the amble for the elephant), as the",
        "shipped controllers make them today. Each contact sheet shows two whole strides of the settled",
        "gait (six tiles a stride, from a left hind touchdown), from the animal's left side and from",
        "behind (turned to the animal's mean heading, should it veer off the goal ahead); each video",
        "is the settled gait from the side, in real time. Measured: the gait that",
        "`quadpipe analyze` recognises, the Froude number v²/(g HP), and the stride period.",
        "",
        "Made with one command, from the repository root (docs: [render.md](render.md); the views are",
        "`quadpipe render --view side|rear`):",
        "",
        "```",
        "python tools/gallery.py            # -j N to run N at a time; --animals dog horse for a few",
        "```",
        "",
    ]
    for animal in dict.fromkeys(row["animal"] for row in rows):
        lines += [f"## {animal}", "", "| gait | side | rear | video | measured |", "|---|---|---|---|---|"]
        for row in (row for row in rows if row["animal"] == animal):
            files = row["files"]
            measured = (
                f"{row['measured']}, Fr {_figure(row['froude'])}, {_figure(row['speed_m_s'])} m/s, "
                f"stride {_figure(row['period_s'])} s{', FELL' if row['fell'] else ''}"
            )
            lines.append(
                f"| {row['gait']} | ![{animal} {row['gait']}, side](gallery/{files['side']}) "
                f"| ![{animal} {row['gait']}, rear](gallery/{files['rear']}) "
                f"| [mp4](gallery/{files['video']}) | {measured} |"
            )
        lines.append("")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """Render the gallery and write its page."""
    from quadpipe.core import configs

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--animals", nargs="+", default=list(configs.available("animals")))
    parser.add_argument("-j", "--jobs", type=int, default=1, help="Clips simulated and rendered at once.")
    args = parser.parse_args(argv)
    jobs = [(animal, gait) for animal in args.animals for gait in gaits_of(animal)]
    with ProcessPoolExecutor(max_workers=args.jobs) as pool:
        rows = list(pool.map(render_one, *zip(*jobs, strict=True)))
    for row in rows:
        print(f"{row['animal']:9} {row['gait']:7} {row['measured']}")
    kept = json.loads(FIGURES.read_text()) if FIGURES.exists() else []
    rows = sorted(
        [rounded_figures(row) for row in kept if row["animal"] not in args.animals] + rows,
        key=lambda row: (row["animal"], row["gait"] != "walk"),
    )
    FIGURES.write_text(json.dumps(rows, indent=1) + "\n")
    PAGE.write_text(page(rows))
    print(f"wrote {OUTPUT}/ and {PAGE}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
