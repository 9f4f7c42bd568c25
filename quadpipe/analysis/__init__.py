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
- The **posture** (`posture_report`), against the animal's own standing pose: each leg joint's
  flexion in stance, the trunk's height, roll and yaw, the head's and the tail's carriage, and
  how far the feet slip, drag and sink.

Everything is in quadpipe's frame (metres, +X forward, +Y left, +Z up); lengths are also given
in pelvis heights (HP), the animal's own unit.

The modules: `report` (the figures, as data and JSON), `footfalls` (contacts cleaned into
footfalls, toe tips), `gait` (`analyze_clip`: stride, duty factors, phases, the gait's name),
`effort` (the controller's forces), `text` (`format_report`), `diagram` (the footfall
diagram as PNG), `posture` (the posture figures as data), `carriage` (`posture_report`: measures
them) and `ground` (the terrain's height, the lowest point of a bone's shapes).
"""

from __future__ import annotations

from quadpipe.analysis.carriage import SETTLE_NATURAL_TIMES, posture_report
from quadpipe.analysis.diagram import (
    BAR_COLOUR,
    DIAGRAM_STRIDES,
    DIAGRAM_SUFFIXES,
    DIAGRAM_WIDTH_PX,
    PANEL_HEIGHT_PX,
    ROW_GAP_PX,
    DiagramPanel,
    check_diagram_path,
    diagram_panels,
    diagram_size,
    draw_footfall_diagram,
    footfall_diagram_png,
)
from quadpipe.analysis.effort import controller_force_key, controller_power_key
from quadpipe.analysis.footfalls import (
    clean_contacts,
    debounce,
    drop_scuffs,
    fill_bounces,
    frame_rate_note,
    min_run_frames,
    rotate,
    toe_tips,
)
from quadpipe.analysis.gait import REFERENCE_LEG, analyze_clip, circular_mean, classify_gait, phase_distance
from quadpipe.analysis.posture import (
    AnimalPosture,
    HeadTailPosture,
    JointFlexion,
    LegPosture,
    PostureReport,
    TrunkPosture,
)
from quadpipe.analysis.report import (
    ALEXANDER_COEFFICIENT,
    ALEXANDER_EXPONENT,
    HILDEBRAND_ORDER,
    AnimalGait,
    ControllerEffort,
    Footfall,
    Gait,
    GaitReport,
    LegGait,
)
from quadpipe.analysis.text import format_posture, format_report

__all__ = [
    "ALEXANDER_COEFFICIENT",
    "ALEXANDER_EXPONENT",
    "BAR_COLOUR",
    "DIAGRAM_STRIDES",
    "DIAGRAM_SUFFIXES",
    "DIAGRAM_WIDTH_PX",
    "HILDEBRAND_ORDER",
    "PANEL_HEIGHT_PX",
    "REFERENCE_LEG",
    "SETTLE_NATURAL_TIMES",
    "ROW_GAP_PX",
    "AnimalGait",
    "AnimalPosture",
    "ControllerEffort",
    "DiagramPanel",
    "Footfall",
    "Gait",
    "GaitReport",
    "HeadTailPosture",
    "JointFlexion",
    "LegGait",
    "LegPosture",
    "PostureReport",
    "TrunkPosture",
    "analyze_clip",
    "check_diagram_path",
    "circular_mean",
    "classify_gait",
    "clean_contacts",
    "controller_force_key",
    "controller_power_key",
    "debounce",
    "diagram_panels",
    "diagram_size",
    "draw_footfall_diagram",
    "drop_scuffs",
    "fill_bounces",
    "footfall_diagram_png",
    "format_posture",
    "format_report",
    "frame_rate_note",
    "min_run_frames",
    "phase_distance",
    "posture_report",
    "rotate",
    "toe_tips",
]
