"""The controller language: YAML files an animator writes to make an animal move.

A controller (`configs/controllers/<name>.yaml`) declares parameters and a list of typed
elements — angular springs, control segments, force pairs, pulls, pedal cycles, sensors
and state machines — over the body's roles, with quantities in scale-free units (`0.5 bw`,
`1.2 HP`, `38/30 s`) and safe expressions. See docs/controllers.md.

Entry points:

- `load_controller(name_or_path)` -> `ControllerSpec` (validated, `extends` merged);
- `validate_files(paths, fmt)` -> (report, exit code), for `quadpipe validate`;
- `compile_controller(spec, scale)` -> `CompiledController`, numpy callables over animals;
- `compile_quantity(value, scale)` for a single value;
- `controller_json_schema()`, `reference_markdown()`, `render_docs(text)` for documentation.
"""

from quadpipe.controllers.language.compiler import CompiledController, CompiledElement, compile_controller
from quadpipe.controllers.language.load import load_controller
from quadpipe.controllers.language.reference import controller_json_schema, reference_markdown, render_docs
from quadpipe.controllers.language.semantics import analyze_controller
from quadpipe.controllers.language.spec import ControllerSpec
from quadpipe.controllers.language.validate import validate_files
from quadpipe.quantities.expressions import Compiled, ExprError, compile_quantity
from quadpipe.quantities.units import Scale, scale_for_animals

__all__ = [
    "Compiled",
    "CompiledController",
    "CompiledElement",
    "ControllerSpec",
    "ExprError",
    "Scale",
    "analyze_controller",
    "compile_controller",
    "compile_quantity",
    "controller_json_schema",
    "load_controller",
    "reference_markdown",
    "render_docs",
    "scale_for_animals",
    "validate_files",
]
