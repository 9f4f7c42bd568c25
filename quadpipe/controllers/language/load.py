"""Loading a controller: `load_controller(name_or_path)` -> a checked `ControllerSpec`."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from quadpipe.controllers.language.semantics import analyze_controller
from quadpipe.controllers.language.spec import ControllerSpec
from quadpipe.core.errors import Location, QuadpipeError


def load_controller(
    name_or_path: str | Path,
    parameters: Mapping[str, Any] | None = None,
    places: Mapping[str, Location] | None = None,
) -> ControllerSpec:
    """Load a controller by built-in name or path, with optional parameter values.

    `places` says where each parameter value was written (a batch plan's line), for messages.

    Raises:
        QuadpipeError: every error found (warnings are kept in `spec.warnings`).
    """
    where = None if places is None else (lambda name: places.get(name, Location("<parameters>")))
    spec, issues = analyze_controller(name_or_path, parameters, where)
    if spec is None:
        raise QuadpipeError([issue for issue in issues if issue.severity == "error"])
    return spec
