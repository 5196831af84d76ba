"""Datasets of many clips (weights, labels) and the npz / amp-rsl-rl exports."""

import json
from pathlib import Path

import numpy as np
import pytest

from motionkit.core.errors import DatasetError
from motionkit.dataset import MotionDataset, write
from motionkit.dataset.export import export, to_amp_rsl_rl
from motionkit.dataset.synthetic import synthetic_trajectory
from motionkit.robot import ironcub


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    robot = ironcub()
    root = tmp_path_factory.mktemp("clips")
    write(root / "walk_a.mcap", synthetic_trajectory(robot, 1.0, seed=1), robot)
    write(root / "sub" / "walk_b.mcap", synthetic_trajectory(robot, 2.0, seed=2), robot)
    flight = synthetic_trajectory(robot, 1.5, 100.0, thrust=120.0, kind="flight")
    write(root / "fly.mcap", flight, robot)
    return root


def test_dataset_weights_labels_and_pairs(folder: Path) -> None:
    dataset = MotionDataset([folder], weights={"walk": 2.0, "walk_b": 5.0})
    assert [c.name for c in dataset.clips] == ["fly", "walk_b", "walk_a"]  # sorted paths
    weight = {c.name: c.weight for c in dataset.clips}
    assert weight == {"walk_a": 2.0, "walk_b": 5.0, "fly": 1.0}  # name beats label; default 1
    assert dataset.duration == pytest.approx(1.0 + 2.0 + 1.5, abs=0.05)
    walks = MotionDataset([folder], labels=["walk"])
    assert {c.label for c in walks.clips} == {"walk"} and len(walks) == 2
    pairs = walks.amp_pairs(ironcub(), rate=60.0)
    assert len(pairs.current) == 59 + 119
    with pytest.raises(DatasetError, match="no clips labelled landing"):
        MotionDataset([folder], labels=["landing"])
    with pytest.raises(DatasetError, match="no such file or folder"):
        MotionDataset([folder / "nope"])


def test_npz_export_round_trip(folder: Path, tmp_path: Path) -> None:
    from motionkit.dataset import read

    trajectory = read(folder / "fly.mcap")
    path = export(trajectory, "fly", tmp_path, "npz")
    data = np.load(path)
    for name, values in trajectory.arrays().items():
        np.testing.assert_array_equal(data[name], values)
    assert list(data["joint_names"]) == list(trajectory.joint_names)
    assert json.loads(str(data["metadata"]))["kind"] == "flight"


def test_amp_rsl_rl_layout(folder: Path, tmp_path: Path) -> None:
    from motionkit.dataset import read

    trajectory = read(folder / "walk_a.mcap")
    path = export(trajectory, "walk_a", tmp_path, "amp-rsl-rl")
    data = np.load(path, allow_pickle=True).item()  # how amp-rsl-rl loads it
    assert set(data) == {
        "joints_list",
        "joint_positions",
        "root_position",
        "root_quaternion",
        "fps",
    }
    assert data["joints_list"] == list(trajectory.joint_names) and data["fps"] == pytest.approx(
        120.0
    )
    np.testing.assert_allclose(data["joint_positions"], trajectory.joint_positions)
    np.testing.assert_allclose(data["root_position"], trajectory.base_position)
    # x, y, z, w order: the last column is the scalar part
    np.testing.assert_allclose(data["root_quaternion"][:, 3], trajectory.base_orientation[:, 0])
    # uneven steps (frame 60 dropped): resampled to the median rate, frame 60 interpolated
    converted = to_amp_rsl_rl(trajectory.select(np.r_[0:60, 61:120]))
    assert len(converted["joint_positions"]) == 120 and converted["fps"] == pytest.approx(120.0)
    np.testing.assert_allclose(
        converted["joint_positions"][60], trajectory.joint_positions[60], atol=2e-3
    )
