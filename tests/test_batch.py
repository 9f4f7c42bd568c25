"""`quadpipe.batch`: plans, parallel runs, failing jobs, re-runs, interruptions, and Dask.

Simulations last half a second so that the whole file runs in well under a minute.
"""

from __future__ import annotations

import json
import os
import queue
import threading
from pathlib import Path

import pytest
from rich.console import Console

from quadpipe.batch import (
    BatchPlan,
    Job,
    Outcome,
    WorkerLink,
    expand_jobs,
    load_plan,
    plan_from,
    run_batch,
    run_job,
    summary_table,
)
from quadpipe.core import configs
from quadpipe.core.errors import QuadpipeError
from tests.conftest import FIXTURES, REPO

SECONDS = 0.5
EXPLODE = str(FIXTURES / "runtime" / "explode.yaml")


def write_plan(folder: Path, text: str) -> Path:
    """A plan file with `text` in `folder`."""
    path = folder / "plan.yaml"
    path.write_text(text)
    return path


def listing(folder: Path) -> list[str]:
    """Every entry of a folder, hidden ones included, sorted."""
    return sorted(os.listdir(folder))


# ---------------------------------------------------------------------------------- plans


def test_plan_is_the_cross_product_in_order_with_overrides_applied(tmp_path):
    plan = load_plan(
        write_plan(
            tmp_path,
            """
animals: [dog, horse]
controllers: [rigid, spine_walk]
scenes: [flat, hill, stairs]
seconds: 4
formats: [GLB, .usdc, glb]
output: baked
overrides:
  - scene: hill
    seconds: 6
  - animal: horse
    controller: spine_walk
    parameters: {stride_angle: 25 deg}
  - animal: horse
    scene: hill
    seconds: 8
""",
        )
    )
    jobs = expand_jobs(plan)
    assert len(jobs) == 2 * 2 * 3
    assert [job.name for job in jobs[:4]] == [
        "dog_rigid_flat",
        "dog_rigid_hill",
        "dog_rigid_stairs",
        "dog_spine_walk_flat",
    ]
    by_name = {job.name: job for job in jobs}
    assert by_name["dog_rigid_flat"].seconds == 4 and by_name["dog_rigid_hill"].seconds == 6
    assert by_name["horse_rigid_hill"].seconds == 8 and by_name["horse_spine_walk_hill"].seconds == 8
    assert by_name["horse_spine_walk_flat"].parameters == (("stride_angle", "25 deg"),)
    assert by_name["dog_spine_walk_flat"].parameters == () and by_name["horse_rigid_flat"].parameters == ()
    job = by_name["dog_rigid_flat"]
    assert job.formats == ("glb", "usdc")
    assert job.files == [
        Path.cwd() / "baked" / name
        for name in ("dog_rigid_flat.glb", "dog_rigid_flat.usdc", "dog_rigid_flat.metrics.json")
    ]


def test_all_means_every_builtin_and_files_are_named_by_their_stem():
    plan = BatchPlan(animals="all", controllers=["rigid", EXPLODE], scenes=["all"])
    jobs = expand_jobs(plan)
    animals, scenes = configs.available("animals"), configs.available("scenes")
    assert len(jobs) == len(animals) * 2 * len(scenes)
    assert {job.animal for job in jobs} == set(animals)
    explode = next(job for job in jobs if job.name == f"{animals[0]}_explode_{scenes[0]}")
    assert explode.controller == EXPLODE and Path(explode.controller).is_absolute()


def test_the_example_plans_are_valid():
    plans = sorted((REPO / "configs" / "batches").glob("*.yaml"))
    assert plans
    for path in plans:
        assert expand_jobs(load_plan(path))
    walks = expand_jobs(load_plan(REPO / "configs" / "batches" / "walks.yaml"))
    assert len(walks) == 4 * 2 * 2
    assert {job.name: job.seconds for job in walks}["horse_leg_by_leg_hill"] == 20


@pytest.mark.parametrize(
    "text, code, line, column",
    [
        ("animal: [dog]\ncontrollers: [rigid]\n", "unknown-key", 1, 1),
        ("animals: [dog]\n", "missing-key", 1, 1),
        ("animals: [dog]\ncontrollers: [rigid]\nformats: [glb, gbl]\n", "invalid-value", 3, 16),
        ("animals: [dog]\ncontrollers: [rigid]\nseconds: -2\n", "invalid-value", 3, 10),
        ("animals: [dog, all]\ncontrollers: [rigid]\n", "invalid-value", 1, 10),
        ("animals: []\ncontrollers: [rigid]\n", "invalid-value", 1, 10),
        (
            "animals: [dog]\ncontrollers: [rigid]\noverrides:\n  - animal: hrse\n    seconds: 2\n",
            "override-selects-nothing",
            4,
            13,
        ),
        ("animals: [dog]\ncontrollers: [rigid]\noverrides:\n  - scene: flat\n    secs: 2\n", "unknown-key", 5, 5),
        ("animals: [dog]\ncontrollers: [rigid]\nanimals: [cat]\n", "duplicate-key", 3, 1),
    ],
)
def test_plan_errors_point_at_their_place(tmp_path, text, code, line, column):
    path = write_plan(tmp_path, text)
    with pytest.raises(QuadpipeError) as caught:
        load_plan(path)
    issue = caught.value.issues[0]
    assert (issue.code, issue.where.file, issue.where.line, issue.where.column) == (code, str(path), line, column)


def test_unknown_keys_and_formats_get_did_you_mean_hints(tmp_path):
    with pytest.raises(QuadpipeError) as caught:
        load_plan(write_plan(tmp_path, "animal: [dog]\ncontrollers: [rigid]\nformats: [gbl]\n"))
    text = caught.value.format()
    assert "did you mean 'animals'?" in text and "did you mean 'glb'?" in text


def test_command_line_options_replace_the_plan_files_values(tmp_path):
    path = write_plan(tmp_path, "animals: [dog, horse]\ncontrollers: [rigid]\nseconds: 4\nformats: [glb]\n")
    plan = plan_from(path, animals=["cat,goat", "rat"], seconds=2.5, formats=["npz"], output=tmp_path / "o")
    assert plan.animals == ["cat", "goat", "rat"] and plan.controllers == ["rigid"]
    assert (plan.seconds, plan.formats, plan.output) == (2.5, ["npz"], str(tmp_path / "o"))


def test_command_line_errors_say_where_they_come_from():
    with pytest.raises(QuadpipeError) as caught:
        plan_from(None, animals=["dog"])
    assert caught.value.issues[0].code == "incomplete-plan"
    with pytest.raises(QuadpipeError) as caught:
        plan_from(None, animals=["dog"], controllers=["rigid"], formats=["obj"])
    assert caught.value.issues[0].code == "invalid-value"
    assert caught.value.issues[0].where.file == "<command line>"


RIG = FIXTURES / "rigs_out" / "dog_short.bvh"
RIG_ROLES = FIXTURES / "rigs_out" / "dog_short_roles.yaml"


def test_roles_and_mass_reach_the_skeleton_file_animals(tmp_path, monkeypatch):
    """Given at the top, in an override for one rig, and on the command line: each rig job
    carries its role map (an absolute path) and mass; a built-in animal's job neither."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "other.bvh").write_text(RIG.read_text())
    path = write_plan(
        tmp_path,
        f"animals: [dog, {RIG}, other.bvh]\ncontrollers: [rigid]\nroles: {RIG_ROLES}\nmass: 30\n"
        "overrides:\n  - animal: other\n    mass: 12.5\n",
    )
    jobs = expand_jobs(load_plan(path))
    assert [(job.name, job.roles, job.mass_kg) for job in jobs] == [
        ("dog_rigid_flat", None, None),
        ("dog_short_rigid_flat", str(RIG_ROLES), 30.0),
        ("other_rigid_flat", str(RIG_ROLES), 12.5),
    ]
    plan = plan_from(None, animals=[f"dog,{RIG}"], controllers=["rigid"], roles=RIG_ROLES, mass=20.0)
    assert [(job.roles, job.mass_kg) for job in expand_jobs(plan)] == [(None, None), (str(RIG_ROLES), 20.0)]


@pytest.mark.parametrize(
    ("text", "line", "column"),
    [
        ("animals: [dog]\ncontrollers: [rigid]\nroles: rig_roles.yaml\n", 3, 8),
        (f"animals: [dog, {RIG}]\ncontrollers: [rigid]\noverrides:\n  - animal: dog\n    mass: 30\n", 5, 11),
    ],
)
def test_roles_or_mass_for_no_skeleton_file_are_refused_at_their_place(tmp_path, text, line, column):
    path = write_plan(tmp_path, text)
    with pytest.raises(QuadpipeError) as caught:
        load_plan(path)
    [issue] = caught.value.issues
    assert (issue.code, issue.where.line, issue.where.column) == ("unused-option", line, column)
    with pytest.raises(QuadpipeError) as caught:
        plan_from(None, animals=["dog"], controllers=["rigid"], mass=30.0)
    assert caught.value.issues[0].code == "unused-option" and caught.value.issues[0].where.file == "<command line>"


def test_a_batch_job_bakes_a_rig_with_its_role_map_and_mass(tmp_path):
    from quadpipe.exporters.npz import load_clip

    job = Job(str(RIG), "rigid", "flat", SECONDS, ("npz", "bvh"), str(tmp_path), roles=str(RIG_ROLES), mass_kg=30.0)
    result = run_job(job)
    assert result.outcome is Outcome.ok, result.error
    assert load_clip(tmp_path / "dog_short_rigid_flat.npz").animals[0].mass_kg == pytest.approx(30.0)
    assert "JOINT Jaw" in (tmp_path / "dog_short_rigid_flat.bvh").read_text()  # on the rig's own joints


def test_two_configs_with_the_same_stem_are_refused(tmp_path):
    for folder in ("a", "b"):
        (tmp_path / folder).mkdir()
        (tmp_path / folder / "walk.yaml").write_text("")
    plan = BatchPlan(
        animals=["dog"], controllers=[str(tmp_path / "a" / "walk.yaml"), str(tmp_path / "b" / "walk.yaml")]
    )
    with pytest.raises(QuadpipeError) as caught:
        expand_jobs(plan)
    assert caught.value.issues[0].code == "duplicate-job" and "dog_walk_flat" in caught.value.format()


# ---------------------------------------------------------------------------------- local runs


@pytest.fixture(scope="module")
def batch(tmp_path_factory):
    """One parallel batch: a good job, a controller that blows up, an unknown controller."""
    folder = tmp_path_factory.mktemp("batch") / "out"
    plan = BatchPlan(
        animals=["dog"],
        controllers=["rigid", EXPLODE, "no_such_controller"],
        seconds=SECONDS,
        formats=["glb", "npz"],
        output=str(folder),
    )
    return plan, folder, run_batch(plan, workers=2, progress=False)


def test_a_parallel_batch_writes_every_file_of_its_good_jobs(batch):
    plan, folder, report = batch
    assert listing(folder) == ["dog_rigid_flat.glb", "dog_rigid_flat.metrics.json", "dog_rigid_flat.npz"]
    metrics = json.loads((folder / "dog_rigid_flat.metrics.json").read_text())
    assert metrics["frames"] == round(SECONDS * 30) + 1 and set(metrics["animals"]) == {"dog"}
    ok = report.results[0]
    assert (ok.job.name, ok.outcome, ok.error) == ("dog_rigid_flat", Outcome.ok, None)
    assert ok.distances_hp == (pytest.approx(metrics["animals"]["dog"]["distance_hp"]),)
    assert dict(ok.sizes) == {path.name: path.stat().st_size for path in folder.iterdir()}


def test_failing_jobs_are_reported_without_traceback_and_leave_no_file(batch):
    plan, folder, report = batch
    outcomes = [(result.job.name, result.outcome) for result in report.results]
    assert outcomes == [
        ("dog_rigid_flat", Outcome.ok),
        ("dog_explode_flat", Outcome.failed),
        ("dog_no_such_controller_flat", Outcome.failed),
    ]
    exploded, unknown = report.results[1].error, report.results[2].error
    assert "simulation-blew-up" in exploded and "explode" in exploded
    assert "unknown-controller" in unknown and "no_such_controller" in unknown
    assert "Traceback" not in exploded + unknown
    assert not any(name.startswith(("dog_explode", "dog_no_such", ".")) for name in listing(folder))
    assert report.exit_code != 0


def test_the_summary_table_shows_every_job(batch):
    plan, folder, report = batch
    console = Console(record=True, width=250)
    console.print(summary_table(report))
    text = console.export_text()
    assert "3 jobs (1 ok, 2 failed, 0 skipped)" in text
    for name in ("dog_rigid_flat", "dog_explode_flat", "dog_no_such_controller_flat", "simulation-blew-up", ".glb"):
        assert name in text
    assert f"{report.results[0].distances_hp[0]:.2f}" in text


def test_a_rerun_skips_finished_jobs_and_force_redoes_them(batch):
    plan, folder, report = batch
    good = folder / "dog_rigid_flat.glb"
    before = (good.stat().st_ino, good.read_bytes())
    rerun = run_batch(plan, workers=2, progress=False)
    assert [result.outcome for result in rerun.results] == [Outcome.skipped, Outcome.failed, Outcome.failed]
    assert good.stat().st_ino == before[0]
    assert rerun.results[0].distances_hp == report.results[0].distances_hp
    assert rerun.results[0].sizes == report.results[0].sizes
    forced = run_batch(plan.model_copy(update={"controllers": ["rigid"]}), workers=1, force=True, progress=False)
    assert [result.outcome for result in forced.results] == [Outcome.ok] and forced.exit_code == 0
    assert good.stat().st_ino != before[0] and good.read_bytes() == before[1]


def test_a_job_that_is_missing_a_file_is_redone(batch):
    plan, folder, report = batch
    (folder / "dog_rigid_flat.npz").unlink()
    rerun = run_batch(plan.model_copy(update={"controllers": ["rigid"]}), workers=1, progress=False)
    assert rerun.results[0].outcome is Outcome.ok and (folder / "dog_rigid_flat.npz").is_file()


class _Recorder:
    """A progress queue that sets the stop flag once a job reports `stop_at` simulated seconds."""

    def __init__(self, stop: threading.Event, stop_at: float):
        self.items, self.stop, self.stop_at = [], stop, stop_at

    def put(self, item):
        self.items.append(item)
        if item[1] >= self.stop_at:
            self.stop.set()


def test_an_interrupted_job_stops_at_the_next_second_and_leaves_no_file(tmp_path):
    stop = threading.Event()
    reports = _Recorder(stop, stop_at=1.0)
    job = Job("dog", "rigid", "flat", 3.0, ("glb",), str(tmp_path))
    result = run_job(job, WorkerLink(reports, stop))
    assert result.outcome is Outcome.failed and "interrupted" in result.error
    assert reports.items == [(job.name, 0.0), (job.name, 1.0)]
    assert listing(tmp_path) == []
    queued = run_job(job, WorkerLink(queue.Queue(), stop))
    assert queued.outcome is Outcome.failed and "interrupted" in queued.error


def test_a_job_killed_while_writing_leaves_no_file(tmp_path, monkeypatch):
    from quadpipe import exporters

    real_export = exporters.export_clip

    def export_then_die(clip, path, **options):
        if Path(path).suffix == ".npz":
            raise KeyboardInterrupt
        return real_export(clip, path, **options)

    monkeypatch.setattr(exporters, "export_clip", export_then_die)
    job = Job("dog", "rigid", "flat", SECONDS, ("glb", "npz"), str(tmp_path))
    with pytest.raises(KeyboardInterrupt):
        run_job(job)
    assert listing(tmp_path) == []


def test_an_unwritable_output_fails_before_any_job(tmp_path):
    (tmp_path / "file").write_text("")
    plan = BatchPlan(animals=["dog"], controllers=["rigid"], output=str(tmp_path / "file" / "out"))
    with pytest.raises(QuadpipeError) as caught:
        run_batch(plan, progress=False)
    assert caught.value.issues[0].code == "unwritable-output"


# ---------------------------------------------------------------------------------- Dask


def test_dask_alone_and_local_runs_write_the_same_bytes(tmp_path):
    distributed = pytest.importorskip("distributed")
    plan = BatchPlan(animals=["dog"], controllers=["rigid", "spine_walk"], seconds=SECONDS, formats=["glb", "usdc"])
    local = run_batch(plan.model_copy(update={"output": str(tmp_path / "local")}), workers=2, progress=False)
    with distributed.LocalCluster(
        n_workers=2, processes=True, threads_per_worker=1, host="127.0.0.1", dashboard_address=None
    ) as cluster:
        remote = run_batch(
            plan.model_copy(update={"output": str(tmp_path / "dask")}),
            scheduler=cluster.scheduler_address,
            progress=False,
        )
    alone_job = expand_jobs(plan.model_copy(update={"output": str(tmp_path / "alone")}))[1]
    (tmp_path / "alone").mkdir()
    alone = run_job(alone_job)
    assert [r.outcome for r in local.results + remote.results + [alone]] == [Outcome.ok] * 5
    names = listing(tmp_path / "local")
    assert len(names) == 2 * 3 and names == listing(tmp_path / "dask")
    for name in names:
        assert (tmp_path / "dask" / name).read_bytes() == (tmp_path / "local" / name).read_bytes(), name
    for path in alone_job.files:
        assert path.read_bytes() == (tmp_path / "local" / path.name).read_bytes(), path.name


def test_an_unreachable_scheduler_is_an_input_error(tmp_path, monkeypatch):
    pytest.importorskip("distributed")
    monkeypatch.setattr("quadpipe.batch.scheduling.CONNECT_TIMEOUT_S", 1.0)
    plan = BatchPlan(animals=["dog"], controllers=["rigid"], output=str(tmp_path))
    with pytest.raises(QuadpipeError) as caught:
        run_batch(plan, scheduler="tcp://127.0.0.1:9", progress=False)
    assert caught.value.issues[0].code == "scheduler-unreachable"


def test_bake_and_batch_write_the_same_bytes_for_the_same_job(tmp_path, cli):
    """`quadpipe bake` (fps from the command line, a float) and a batch job (the default fps) agree
    byte for byte, in every format and in the metrics JSON."""
    formats = ["glb", "gltf", "usdc", "bvh", "npz"]
    plan = BatchPlan(animals=["dog"], controllers=["rigid"], seconds=SECONDS, formats=formats)
    report = run_batch(plan.model_copy(update={"output": str(tmp_path / "batch")}), workers=1, progress=False)
    assert report.exit_code == 0
    (tmp_path / "bake").mkdir()
    name = "dog_rigid_flat"
    outputs = [arg for fmt in formats for arg in ("-o", f"{name}.{fmt}")]
    baked = cli("bake", "-a", "dog", "-c", "rigid", "-s", str(SECONDS), *outputs, cwd=tmp_path / "bake")
    assert baked.returncode == 0, baked.stderr
    names = listing(tmp_path / "batch")
    assert names == listing(tmp_path / "bake") and f"{name}.metrics.json" in names and f"{name}.bin" in names
    for file_name in names:
        assert (tmp_path / "bake" / file_name).read_bytes() == (tmp_path / "batch" / file_name).read_bytes(), file_name
