"""quadpipe: quadrupeds animated by physics alone, baked into clips that load everywhere.

The public API, for scripts and notebooks (the command line calls the same functions):

    import quadpipe

    result = quadpipe.simulate("dog", "walk", seconds=10, scene="hill")    # Result: clip + metrics
    quadpipe.export_clip(result.clip, "dog_walk.glb")                     # the suffix picks the format
    print(quadpipe.analyze_clip(result.clip).animals[0].gait.label)       # "lateral-sequence walk"

    sim = quadpipe.Simulation.build("horse", "trot")                      # step it yourself
    for _ in range(120):
        sim.step()

Names are imported on first use, so `import quadpipe` (and `quadpipe --help`) stays instant:
MuJoCo, numba and USD load only when a function that needs them is called.
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING, Any

from quadpipe.core.version import __version__

if TYPE_CHECKING:
    from quadpipe.analysis import analyze_clip
    from quadpipe.animals.library import Animal, load_animal
    from quadpipe.animals.model import build_animal
    from quadpipe.batch.bake import bake
    from quadpipe.clip.model import Clip
    from quadpipe.controllers.language import load_controller
    from quadpipe.core.errors import QuadpipeError
    from quadpipe.exporters import export_clip
    from quadpipe.exporters.npz import load_clip
    from quadpipe.importers import load_skeleton
    from quadpipe.render import render_clip
    from quadpipe.sim.simulation import Result, Simulation, simulate
    from quadpipe.world import load_scene

PUBLIC_API: dict[str, str] = {
    # inputs: animals, skeleton files, controllers, scenes
    "Animal": "quadpipe.animals.library",
    "load_animal": "quadpipe.animals.library",
    "build_animal": "quadpipe.animals.model",
    "load_skeleton": "quadpipe.importers",
    "load_controller": "quadpipe.controllers.language",
    "load_scene": "quadpipe.world",
    # simulation
    "Simulation": "quadpipe.sim.simulation",
    "simulate": "quadpipe.sim.simulation",
    "Result": "quadpipe.sim.simulation",
    "bake": "quadpipe.batch.bake",
    # clips and what is done with them
    "Clip": "quadpipe.clip.model",
    "load_clip": "quadpipe.exporters.npz",
    "export_clip": "quadpipe.exporters",
    "analyze_clip": "quadpipe.analysis",
    "render_clip": "quadpipe.render",
    # errors
    "QuadpipeError": "quadpipe.core.errors",
}
"""Each public name and the module that defines it (imported on first use)."""

__all__ = [
    "__version__",
    "Animal",
    "load_animal",
    "build_animal",
    "load_skeleton",
    "load_controller",
    "load_scene",
    "Simulation",
    "simulate",
    "Result",
    "bake",
    "Clip",
    "load_clip",
    "export_clip",
    "analyze_clip",
    "render_clip",
    "QuadpipeError",
]


def __getattr__(name: str) -> Any:
    """Import a public name's module on first use (PEP 562)."""
    module = PUBLIC_API.get(name)
    if module is None:
        raise AttributeError(f"module 'quadpipe' has no attribute {name!r}")
    value = getattr(import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(PUBLIC_API))
