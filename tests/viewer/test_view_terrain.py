"""A clip's terrain (a rollout or play on a course): read from its metadata, drawn as a mesh by
the browser viewer and as a heightfield by the offscreen renderer, at the recorded heights."""

from __future__ import annotations

import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from viewer_support import free_port

from motionkit.core.errors import ViewerError
from motionkit.dataset import write
from motionkit.dataset.synthetic import synthetic_trajectory
from motionkit.robot import ironcub
from motionkit.viewer.sources import resolve_clips
from motionkit.viewer.terrain import TerrainPatch, clip_terrain, grid_mesh, hfield_data

# 3 rows (y = 1.0, 1.5, 2.0) x 4 columns (x = -1.0 ... 0.5), a pit in the middle of the top row
HEIGHTS = [[0.0, 0.0, 0.1, 0.1], [0.0, 0.0, 0.1, 0.1], [0.0, -0.5, -0.5, 0.0]]
TERRAIN = {"kind": "pits", "level": 9, "cell": 0.5, "origin": [-1.0, 1.0], "heights": HEIGHTS}


@pytest.fixture(scope="module")
def clip_path(tmp_path_factory: pytest.TempPathFactory) -> Path:
    robot = ironcub()
    motion = synthetic_trajectory(robot, 0.5, 30.0)
    meta = replace(motion.metadata, config={"terrain": TERRAIN})
    return write(
        tmp_path_factory.mktemp("clips") / "play.mcap", replace(motion, metadata=meta), robot
    )


def test_the_terrain_is_read_from_the_clip(clip_path: Path) -> None:
    [info] = resolve_clips(clip_path)
    patch = clip_terrain(info)
    assert patch is not None and patch.label == "pits, level 9"
    np.testing.assert_array_equal(patch.heights, HEIGHTS)
    assert patch.size == (1.5, 1.0) and patch.centre == (-0.25, 1.5)
    bare = replace(info, metadata=replace(info.metadata, config={}))
    assert clip_terrain(bare) is None
    for bad in ({"heights": [[1.0]], "origin": [0, 0], "cell": 0.1}, {"heights": [[0, 1]]}):
        broken = replace(info, metadata=replace(info.metadata, config={"terrain": bad}))
        with pytest.raises(ViewerError, match="metadata 'terrain'"):
            clip_terrain(broken)


def test_the_grid_mesh_has_the_heights_at_its_vertices() -> None:
    patch = TerrainPatch(np.array(HEIGHTS), (-1.0, 1.0), 0.5)
    vertices, faces = grid_mesh(patch)
    assert vertices.shape == (12, 3) and faces.shape == (12, 3)  # 2 triangles x 6 cells
    np.testing.assert_allclose(vertices[5], [-0.5, 1.5, 0.0])  # row 1, column 1
    np.testing.assert_allclose(vertices[9], [-0.5, 2.0, -0.5])  # row 2, column 1
    # every triangle faces up (counter-clockwise seen from above)
    a, b, c = (vertices[faces[:, k], :2] for k in range(3))
    cross = (b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0]
    assert (cross > 0).all()


def test_the_renderers_heightfield_stands_where_the_grid_does() -> None:
    """MuJoCo's ray cast onto the visual model's heightfield, at grid points: the heights."""
    mujoco = pytest.importorskip("mujoco")
    from motionkit.viewer.offscreen import visual_model

    patch = TerrainPatch(np.array(HEIGHTS), (-1.0, 1.0), 0.5)
    data, low, span = hfield_data(patch)
    assert (low, span) == (-0.5, pytest.approx(0.6)) and data[2, 1] == 0.0  # rows from -y up
    model = visual_model(ironcub(), [], 64, 64, patch)
    state = mujoco.MjData(model)
    mujoco.mj_forward(model, state)
    terrain = model.geom("terrain").id
    hit = np.zeros(1, np.int32)
    for row, y in enumerate((1.0, 1.5, 2.0)):
        for column, x in enumerate((-1.0, -0.5, 0.0, 0.5)):
            inward = 0.005 * np.sign(np.array(patch.centre) - [x, y])  # off the edges
            start = np.array([x + inward[0], y + inward[1], 5.0])
            distance = mujoco.mj_ray(model, state, start, np.array([0, 0, -1.0]), None, 1, -1, hit)
            assert hit[0] == terrain
            assert 5.0 - distance == pytest.approx(HEIGHTS[row][column], abs=0.011)
    floor = [g for g in range(model.ngeom) if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_PLANE]
    assert model.geom_pos[floor[0], 2] < -0.5  # below the pit: it shows


def test_the_browser_viewer_draws_the_terrain_as_a_mesh(clip_path: Path) -> None:
    pytest.importorskip("viser")
    from motionkit.viewer.app import ViewerApp

    app = ViewerApp(ironcub(), resolve_clips(clip_path), port=free_port())
    try:
        mesh = app._terrain
        assert mesh is not None and mesh.visible
        np.testing.assert_allclose(mesh.vertices[9], [-0.5, 2.0, -0.5])  # the pit, row 2
        assert len(mesh.faces) == 12
        app.show_terrain.value = False
        deadline = time.monotonic() + 5
        while mesh.visible and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not mesh.visible
    finally:
        app.close()
