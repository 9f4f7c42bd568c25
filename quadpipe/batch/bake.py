"""Baking: one simulation written into clip files (the suffix picks the format) and a metrics JSON.

`quadpipe simulate`, `quadpipe bake` and every batch job (`quadpipe.batch.jobs`) bake through
`bake`: the files are staged beside their targets and renamed into place together when all are
written, or none is (`quadpipe.core.atomic.transaction`).
"""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from quadpipe.animals.sizing import FRAME_RATE

if TYPE_CHECKING:
    from quadpipe.animals.library import AnimalSource
    from quadpipe.bodies import Look
    from quadpipe.controllers.runtime.variation import Variation
    from quadpipe.core.errors import Location
    from quadpipe.exporters import SkeletonChoice
    from quadpipe.sim.simulation import Result

METRICS_SUFFIX = ".metrics.json"
"""A bake's metrics file: `<stem>.metrics.json` (a batch job's stem is its name)."""


def bake(
    animal: str | AnimalSource,
    controller: str,
    *,
    seconds: float,
    outputs: Sequence[Path],
    metrics_path: Path,
    scene: str | None = None,
    parameters: Mapping[str, str] | None = None,
    fps: float = FRAME_RATE,
    on_frame: Callable[[float], None] | None = None,
    places: Mapping[str, Location] | None = None,
    look: Look = "body",
    skeleton: SkeletonChoice = "rig",
    direction: Path | None = None,
    variation: Variation | None = None,
) -> Result:
    """Simulate once (see `quadpipe.sim.simulation.simulate`), write the clip into every output,
    then the metrics JSON: all of them, or none (inside a running `transaction`, at its commit).
    `places` says where each of `parameters` was written (a batch plan's line), for messages;
    `look` how glTF and USD files draw the animals (`quadpipe.bodies`); `skeleton` whether an
    animal imported from a rig is written on the rig's joints (`quadpipe.exporters.export_clip`);
    `direction` a direction file replacing the scene's (docs/direction.md);
    `variation` how the gait varies from stride to stride (None: not at all).

    Raises:
        QuadpipeError: the inputs cannot be loaded, the simulation blew up, a file cannot be
            written.
    """
    from quadpipe.core.atomic import transaction, write_text
    from quadpipe.exporters import export_clip
    from quadpipe.sim.simulation import simulate

    result = simulate(
        animal,
        controller,
        seconds=seconds,
        scene=scene,
        parameters=dict(parameters or {}),
        on_frame=on_frame,
        fps=fps,
        places=places,
        direction=direction,
        variation=variation,
    )
    with transaction():
        for output in outputs:
            export_clip(result.clip, output, look=look, skeleton=skeleton)
        write_text(metrics_path, json.dumps(result.metrics, indent=2) + "\n")
    return result
