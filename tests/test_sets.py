"""Sets (#15 item 5): a mesh file as the ground, read from OBJ, PLY, glTF/GLB and USD into a
MuJoCo height field that animals walk on and the controllers' ground rays see.

Thresholds are in pelvis heights (HP) where they are about the animal, in metres where they are
about the file (float32 coordinates in PLY and GLB).
"""

from __future__ import annotations

import functools
import importlib.util
from pathlib import Path

import mujoco
import numpy as np
import pytest

from quadpipe.anatomy.roles import FOOT_BONES, LEGS, ROLES
from quadpipe.clip.kinematics import multiply, rotate, to_y_up
from quadpipe.clip.model import AnimalTrack
from quadpipe.core.errors import Location, QuadpipeError
from quadpipe.sim.simulation import Result, simulate
from quadpipe.world import build_scene, load_scene
from quadpipe.world.placement import ground_height
from quadpipe.world.sets import HeightGrid, SetMesh, read_set, sample_grid, surface_heights
from tests.conftest import REPO, built_animal

BUMPY = REPO / "configs" / "sets" / "bumpy.obj"
HERE = Location("test")

SAME_HEIGHT_M = 1e-5
"""Heights of one set read from different formats agree this closely (float32 files)."""

RAY_TOLERANCE_M = 1e-4
"""MuJoCo's ground rays on the height field agree with the mesh this closely."""

WALK_SECONDS = 20.0
MIN_PELVIS_HP = 0.8
UPRIGHT_DEG = 30.0
MIN_FORWARD_HP = 10.0
"""The walk covers at least this much of the set (the dog covers about 30 HP on flat ground)."""

MIN_BUMP_UNDER_FEET_M = 0.05
"""Some stance frames stand at least this high on the set: the walk crossed its bumps."""

FOOT_ON_SET_HP = 0.015
"""The feet touch the set's surface within 1.5 % HP (#15)."""

MIN_PHASES_ON_SET = 0.95
"""Share of each foot's stance phases in which it comes within `FOOT_ON_SET_HP` of the surface
(MuJoCo lets a foot that lands on a seam between height-field cells sink about its own radius:
see docs/scenes.md, Sets)."""


@functools.cache
def bumpy() -> SetMesh:
    return read_set(BUMPY, "bumpy.obj", HERE)


def grid_of(path: Path) -> HeightGrid:
    return sample_grid(read_set(path, path.name, HERE), None, path.name, HERE)


# --------------------------------------------------------------------------- the shipped set


def test_the_shipped_set_is_what_its_tool_writes() -> None:
    spec = importlib.util.spec_from_file_location("make_set", REPO / "tools" / "make_set.py")
    assert spec is not None and spec.loader is not None
    tool = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(tool)
    assert tool.obj_text() == BUMPY.read_text(encoding="utf-8")
    assert 2000 <= len(bumpy().triangles) <= 8000


def test_a_y_up_obj_is_read_into_quadpipes_frame() -> None:
    triangles = bumpy().triangles
    lows, highs = triangles.reshape(-1, 3).min(axis=0), triangles.reshape(-1, 3).max(axis=0)
    np.testing.assert_allclose(lows, [-3.0, -4.0, 0.0], atol=1e-6)  # x forward, y left, z up
    np.testing.assert_allclose(highs[:2], [37.0, 4.0], atol=1e-6)
    assert 0.05 < highs[2] < 0.3
    normals = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    assert (normals[:, 2] > 0).all()  # the ground faces up


def test_the_height_field_is_the_mesh_as_the_kernels_ground_rays_see_it() -> None:
    setup = build_scene(load_scene("set"), built_animal("dog"))
    model = setup.spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    assert model.ngeom and model.geom("terrain0_mesh").type == mujoco.mjtGeom.mjGEOM_HFIELD
    points = np.random.default_rng(7).uniform([1.5, -3.5], [36.5, 3.5], (300, 2))
    rays = np.array([ground_height(model, data, x, y, 5.0) for x, y in points])
    np.testing.assert_allclose(rays, surface_heights(bumpy(), points), atol=RAY_TOLERANCE_M)


def test_an_animal_starting_on_the_set_is_lifted_onto_it(tmp_path: Path) -> None:
    scene = tmp_path / "scene.yaml"
    scene.write_text(
        f"schema: 1\nname: test\nterrain:\n  - {{type: mesh, file: {BUMPY}}}\nanimals:\n  - {{name: dog, at: [8 m, 1 m]}}\n",
        encoding="utf-8",
    )
    setup = build_scene(load_scene(scene), built_animal("dog"))
    model = setup.spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    lowest = min(data.geom_xpos[g, 2] for g in range(model.ngeom) if model.geom_bodyid[g] != 0)
    assert lowest > surface_heights(bumpy(), np.array([[8.0, 1.0]]))[0] - 0.05


# --------------------------------------------------------------------------- formats


def _write_formats(folder: Path) -> dict[str, Path]:
    """The shipped set written as PLY (z up), GLB (y up), USD y up, and USD z up in centimetres
    under a translated transform: every format and convention the reader handles."""
    import trimesh
    from pxr import Gf, Usd, UsdGeom

    triangles = bumpy().triangles
    points, faces = triangles.reshape(-1, 3), np.arange(triangles.shape[0] * 3).reshape(-1, 3)
    trimesh.Trimesh(points, faces, process=False).export(folder / "set.ply")
    trimesh.Trimesh(to_y_up(points), faces, process=False).export(folder / "set.glb")
    paths = {"obj": BUMPY, "ply": folder / "set.ply", "glb": folder / "set.glb"}
    for name, up, metres, offset in (("y.usda", "y", 1.0, (0.0, 0.0, 0.0)), ("z.usdc", "z", 0.01, (200.0, -50.0, 3.0))):
        stage = Usd.Stage.CreateNew(str(folder / f"set_{name}"))
        UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y if up == "y" else UsdGeom.Tokens.z)
        UsdGeom.SetStageMetersPerUnit(stage, metres)
        xform = UsdGeom.Xform.Define(stage, "/set")
        xform.AddTranslateOp().Set(Gf.Vec3d(*offset))
        mesh = UsdGeom.Mesh.Define(stage, "/set/ground")
        local = (to_y_up(points) if up == "y" else points) / metres - np.array(offset)
        mesh.GetPointsAttr().Set([Gf.Vec3f(*p) for p in local.tolist()])
        mesh.GetFaceVertexCountsAttr().Set([3] * len(faces))
        mesh.GetFaceVertexIndicesAttr().Set(faces.ravel().tolist())
        stage.GetRootLayer().Save()
        paths[f"usd {name}"] = folder / f"set_{name}"
    return paths


def test_the_set_reads_to_the_same_heights_from_obj_ply_glb_and_usd(tmp_path: Path) -> None:
    grids = {kind: grid_of(path) for kind, path in _write_formats(tmp_path).items()}
    reference = grids.pop("obj")
    for kind, grid in grids.items():
        assert grid.heights.shape == reference.heights.shape, kind
        assert grid.cell == pytest.approx(reference.cell, abs=SAME_HEIGHT_M), kind
        np.testing.assert_allclose(grid.origin, reference.origin, atol=SAME_HEIGHT_M, err_msg=kind)
        np.testing.assert_allclose(grid.heights, reference.heights, atol=SAME_HEIGHT_M, err_msg=kind)


# --------------------------------------------------------------------------- errors


def _error(tmp_path: Path, file_name: str, content: bytes | None, extra: str = "") -> str:
    if content is not None:
        (tmp_path / file_name).write_bytes(content)
    scene = tmp_path / "scene.yaml"
    scene.write_text(
        f"schema: 1\nname: test\nterrain:\n  - {{type: mesh, file: {file_name}{extra}}}\n", encoding="utf-8"
    )
    with pytest.raises(QuadpipeError) as caught:
        build_scene(load_scene(scene), built_animal("dog"))
    return str(caught.value)


@pytest.mark.parametrize(
    ("file_name", "content", "code", "message"),
    [
        ("nothere.obj", None, "file-not-found", "set file 'nothere.obj' does not exist (relative to this scene)"),
        ("set.stl", b"solid ground\nendsolid ground\n", "set-format", ".stl is not a mesh format quadpipe reads"),
        ("set.glb", b"glTF\x02\x00\x00\x00garbage", "set-unreadable", "cannot be read as GLTF"),
        ("set.usda", b"#usda 1.0\n(\n  this is not usd\n", "set-unreadable", "cannot be read as USD: "),
        ("set.obj", b"# only points\nv 0 0 0\nv 1 0 0\nv 0 0 1\n", "set-empty", "holds no triangles"),
        ("set.obj", b"v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\n", "set-empty", "covers no ground seen from above"),
    ],
)
def test_a_bad_set_file_is_a_located_error(
    tmp_path: Path, file_name: str, content: bytes | None, code: str, message: str
) -> None:
    text = _error(tmp_path, file_name, content)
    assert text.startswith(f"{tmp_path / 'scene.yaml'}:4:24: error {code}: "), text
    assert message in text
    assert "\n  hint: " in text


def test_a_set_over_the_triangle_limit_is_a_located_error(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("QUADPIPE_MAX_SET_TRIANGLES", "1000")
    text = _error(tmp_path, str(BUMPY), None)
    assert text.startswith(f"{tmp_path / 'scene.yaml'}:4:24: error limit-exceeded: "), text
    assert "triangles" in text and "4000" in text


def test_a_bad_resolution_or_up_axis_is_located_at_its_value(tmp_path: Path) -> None:
    text = _error(tmp_path, str(BUMPY), None, ", up: x, resolution: 1")
    column = 24 + len(str(BUMPY)) + 2
    assert f":4:{column + 4}: error invalid-value: terrain.0.up: must be 'y' or 'z'" in text
    assert f":4:{column + 19}: error invalid-value: terrain.0.resolution: must be at least 2" in text


# --------------------------------------------------------------------------- walking on the set


@functools.cache
def walk(animal: str) -> Result:
    return simulate(animal, "walk", seconds=WALK_SECONDS, scene="set")


def foot_bottoms(track: AnimalTrack, leg: str) -> np.ndarray:
    """(F, 3) the lowest point of a foot's bones per frame (the bottom of the lower end of its
    lowest capsule), world frame, metres."""
    lows = []
    for bone in FOOT_BONES[leg]:
        index = track.roles.index(bone)
        rotation = track.rotations[:, index]
        for shape in track.shapes[index]:
            assert shape.kind == "capsule", shape.kind
            radius, half = shape.size
            centre = track.positions[:, index] + rotate(rotation, np.array(shape.pos))
            axis = rotate(multiply(rotation, np.array(shape.quat)), np.array([0.0, 0.0, 1.0]))
            ends = np.stack([centre + half * axis, centre - half * axis], axis=1)
            lows.append(ends[np.arange(len(ends)), ends[:, :, 2].argmin(axis=1)] - [0.0, 0.0, radius])
    stacked = np.stack(lows, axis=1)
    return stacked[np.arange(len(stacked)), stacked[:, :, 2].argmin(axis=1)]


def stance_phases(contacts: np.ndarray) -> list[slice]:
    """The runs of frames in which a foot is down."""
    edges = np.diff(np.concatenate([[0], contacts.astype(int), [0]]))
    return [slice(a, b) for a, b in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1))]


@pytest.mark.slow
@pytest.mark.parametrize("animal", ["dog", "horse"])
def test_an_animal_walks_across_the_bumpy_set_20_s_without_falling(animal: str) -> None:
    result = walk(animal)
    track = result.clip.animals[0]
    figures = result.metrics["animals"][animal]
    assert not figures["fell"]
    assert figures["pelvis_height_min_hp"] > MIN_PELVIS_HP
    assert figures["forward_hp"] >= MIN_FORWARD_HP
    w, x, y, _ = track.rotations[:, ROLES.index("thorax")].T
    assert np.degrees(np.arccos(np.clip(1 - 2 * (x * x + y * y), -1, 1))).max() < UPRIGHT_DEG
    stance_heights = [
        surface_heights(bumpy(), foot_bottoms(track, leg)[track.foot_contacts[:, k]]) for k, leg in enumerate(LEGS)
    ]
    assert np.nanmax(np.concatenate(stance_heights)) > MIN_BUMP_UNDER_FEET_M


@pytest.mark.slow
@pytest.mark.parametrize(
    "animal",
    ["dog", "horse"],
)
def test_the_clips_feet_touch_the_sets_surface_within_1_5_percent_hp(animal: str) -> None:
    track = walk(animal).clip.animals[0]
    for k, leg in enumerate(LEGS):
        bottoms = foot_bottoms(track, leg)
        gaps = (bottoms[:, 2] - surface_heights(bumpy(), bottoms)) / track.pelvis_height
        down = track.foot_contacts[:, k]
        assert not np.isnan(gaps[down]).any(), f"{leg}: a foot stood off the set"
        assert np.median(np.abs(gaps[down])) < FOOT_ON_SET_HP, leg
        phases = stance_phases(down)
        touching = [np.abs(gaps[phase]).min() < FOOT_ON_SET_HP for phase in phases]
        assert len(phases) >= WALK_SECONDS / 2, leg  # it kept stepping
        assert np.mean(touching) >= MIN_PHASES_ON_SET, f"{leg}: {touching.count(False)} of {len(phases)} steps off"
