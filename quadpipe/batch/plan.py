"""Batch plans: which animals, controllers and scenes to bake, for how long, in which formats.

A plan is a file (`configs/batches/<name>.yaml`, read by `load_plan` with errors at
file:line:col) or lists given on the command line (`plan_from`, which also merges the two).
See docs/batch.md.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Annotated, Any

from pydantic import AfterValidator, BaseModel, BeforeValidator, ConfigDict, Field, PrivateAttr

from quadpipe.controllers.runtime.variation import MAX_VARIATION
from quadpipe.core import configs
from quadpipe.core.errors import Issue, Location, QuadpipeError, did_you_mean
from quadpipe.core.limits import MAX_SIMULATED_SECONDS
from quadpipe.core.yamlio import YamlDocument, load_yaml, validate_document

ALL = "all"
"""In a list of animals, controllers or scenes: every built-in one."""

DEFAULT_SCENE = "flat"
DEFAULT_SECONDS = 10.0
DEFAULT_FORMAT = "glb"
DEFAULT_OUTPUT = "out/batch"

COMMAND_LINE = "<command line>"
"""Where options given on the command line are reported to come from."""


def _as_list(value: Any) -> Any:
    """Accept one name where a list of names is expected (`animals: dog`)."""
    return [value] if isinstance(value, str) else value


def _names(value: list[str]) -> list[str]:
    """Strip and de-duplicate names; `all` must stand alone."""
    names = list(dict.fromkeys(name.strip() for name in value))
    if "" in names:
        raise ValueError("a name is empty")
    if ALL in names and len(names) > 1:
        raise ValueError(f"{ALL!r} already means every built-in one: write it alone, or list the names")
    return names


def _format(value: str) -> str:
    """A format as a bare lower-case suffix (`.GLB` -> `glb`) that quadpipe can write."""
    from quadpipe.exporters import supported_formats

    known = {fmt.suffix.lstrip("."): fmt for fmt in supported_formats()}
    name = value.strip().lower().lstrip(".")
    if name not in known:
        raise ValueError(f"quadpipe cannot write {name!r} files; {did_you_mean(name, known)}")
    if not known[name].available:
        raise ValueError(f"writing {name} needs a package that is not installed: {known[name].install_hint}")
    return name


def _unique(value: list[str]) -> list[str]:
    """The list without repeats, in order."""
    return list(dict.fromkeys(value))


Names = Annotated[list[str], BeforeValidator(_as_list), Field(min_length=1), AfterValidator(_names)]
Formats = Annotated[
    list[Annotated[str, AfterValidator(_format)]],
    BeforeValidator(_as_list),
    Field(min_length=1),
    AfterValidator(_unique),
]


class JobOverride(BaseModel):
    """Settings for the jobs an override selects (every job when it names no selector).

    Selectors compare with the names as they appear in file names: a built-in name (`dog`) or
    a config file's stem (`my_walk` for `controllers/my_walk.yaml`).
    """

    model_config = ConfigDict(extra="forbid")

    animal: str | None = Field(None, description="Only jobs of this animal (omitted: any).")
    controller: str | None = Field(None, description="Only jobs of this controller (omitted: any).")
    scene: str | None = Field(None, description="Only jobs in this scene (omitted: any).")
    seconds: float | None = Field(None, gt=0, description="Simulated time of the selected jobs.")
    parameters: dict[str, Any] = Field(
        {}, description="Controller parameter values, as in a controller file (`pedal_force: 0.2 bw`)."
    )

    def selects(self, animal: str, controller: str, scene: str) -> bool:
        """Whether this override applies to the job with these labels."""
        wanted = (self.animal, self.controller, self.scene)
        return all(want is None or want == have for want, have in zip(wanted, (animal, controller, scene)))


class BatchPlan(BaseModel):
    """What to bake: the cross product of animals, controllers and scenes, in some formats."""

    model_config = ConfigDict(extra="forbid")

    animals: Names = Field(description="Animal names or config files, or `all`.")
    controllers: Names = Field(description="Controller names or files, or `all`.")
    scenes: Names = Field([DEFAULT_SCENE], description="Scene names or files, or `all`.")
    seconds: float = Field(DEFAULT_SECONDS, gt=0, description="Simulated time of every job.")
    formats: Formats = Field([DEFAULT_FORMAT], description="Formats to write, by suffix: glb, usdc, bvh, npz...")
    output: str = Field(DEFAULT_OUTPUT, min_length=1, description="Folder of the files (created if missing).")
    variation: float = Field(
        0.0,
        ge=0.0,
        le=MAX_VARIATION,
        description="Natural stride-to-stride variation of every job's gait (0.03: stride times vary 3 %); 0: none.",
    )
    seed: int = Field(0, ge=0, description="Seed of `variation`: the same seed, the same files.")
    overrides: list[JobOverride] = Field([], description="Per-job settings, applied in order (later ones win).")
    _places: list[dict[str, Location]] = PrivateAttr(default_factory=list)
    """For each override, where each of its parameter values is written in the plan file."""

    def parameter_places(self, index: int) -> dict[str, Location]:
        """Where the parameter values of `overrides[index]` are written (empty: not from a file)."""
        return self._places[index] if index < len(self._places) else {}


def load_plan(path: str | Path) -> BatchPlan:
    """Read and check a batch plan file.

    Raises:
        QuadpipeError: syntax or schema errors, and override selectors that name no animal,
            controller or scene of the plan, each at its file:line:col.
    """
    doc = load_yaml(path, "batch plan", BatchPlan)
    plan = _validated(doc)
    issues = _selector_issues(plan, doc)
    if issues:
        raise QuadpipeError(issues)
    plan._places = [
        {name: doc.locate(("overrides", index, "parameters", name)) for name in override.parameters}
        for index, override in enumerate(plan.overrides)
    ]
    return plan


def _validated(doc: YamlDocument) -> BatchPlan:
    """The plan of a document (a file, or the command line's options), its times within the run limit.

    Raises:
        QuadpipeError: schema errors, and a `seconds` over `MAX_SIMULATED_SECONDS`, at file:line:col.
    """
    plan = validate_document(BatchPlan, doc)
    times: list[tuple[tuple[str | int, ...], float]] = [(("seconds",), plan.seconds)]
    times += [(("overrides", i, "seconds"), o.seconds) for i, o in enumerate(plan.overrides) if o.seconds is not None]
    for path, seconds in times:
        MAX_SIMULATED_SECONDS.check(seconds, where=doc.locate(path))
    return plan


def _selector_issues(plan: BatchPlan, doc: YamlDocument) -> list[Issue]:
    """An issue for each override selector that matches none of the plan's names."""
    labels = {
        "animal": [label(n) for n in expand_names(plan.animals, "animals")],
        "controller": [label(n) for n in expand_names(plan.controllers, "controllers")],
        "scene": [label(n) for n in expand_names(plan.scenes, "scenes")],
    }
    issues = []
    for index, override in enumerate(plan.overrides):
        for key, valid in labels.items():
            wanted = getattr(override, key)
            if wanted is not None and wanted not in valid:
                issues.append(
                    Issue(
                        "override-selects-nothing",
                        f"overrides[{index}] selects {key} {wanted!r}, which is not in the plan's {key}s",
                        doc.locate(("overrides", index, key)),
                        did_you_mean(wanted, valid),
                    )
                )
    return issues


def plan_from(
    path: str | Path | None,
    *,
    animals: Sequence[str] | None = None,
    controllers: Sequence[str] | None = None,
    scenes: Sequence[str] | None = None,
    seconds: float | None = None,
    formats: Sequence[str] | None = None,
    output: str | Path | None = None,
    variation: float | None = None,
    seed: int | None = None,
) -> BatchPlan:
    """A plan from a file (optional) and command-line options, which replace the file's values.

    List options accept repeated and comma-separated names (`["dog,horse", "cat"]`).

    Raises:
        QuadpipeError: errors in the file (located), or in the options (`<command line>`).
    """
    file_plan = load_plan(path) if path is not None else None
    base = file_plan.model_dump(exclude_unset=True) if file_plan is not None else {}
    options = {
        "animals": _split(animals),
        "controllers": _split(controllers),
        "scenes": _split(scenes),
        "seconds": seconds,
        "formats": _split(formats),
        "output": None if output is None else str(output),
        "variation": variation,
        "seed": seed,
    }
    merged = base | {key: value for key, value in options.items() if value is not None}
    if "animals" not in merged or "controllers" not in merged:
        raise QuadpipeError.single(
            "incomplete-plan",
            "a batch needs animals and controllers",
            hint="give a plan file, or --animal and --controller (e.g. quadpipe batch -a dog,horse -c spine_walk)",
        )
    plan = _validated(YamlDocument(data=merged, file=COMMAND_LINE))
    if file_plan is not None:  # overrides come only from the file: keep where they are written
        plan._places = file_plan._places
    return plan


def _split(values: Sequence[str] | None) -> list[str] | None:
    """Repeated and comma-separated command-line names as one list (None when not given)."""
    if not values:
        return None
    return [name.strip() for value in values for name in value.split(",") if name.strip()]


def looks_like_path(name: str) -> bool:
    """Whether a config is given by file (`walks/fast.yaml`) rather than by built-in name."""
    return Path(name).suffix in (".yaml", ".yml") or "/" in name or os.sep in name


def label(name: str) -> str:
    """What a config contributes to a job's file names: its name, or its file's stem."""
    return Path(name).stem if looks_like_path(name) else name


def expand_names(names: Sequence[str], kind: str) -> list[str]:
    """`all` as every built-in config of `kind` (`animals`, `controllers`, `scenes`)."""
    return configs.available(kind) if list(names) == [ALL] else list(names)
