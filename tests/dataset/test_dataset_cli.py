"""`motionkit dataset info|validate|export`."""

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from test_cli import run

from motionkit.cli import main
from motionkit.dataset import write
from motionkit.dataset.synthetic import synthetic_trajectory
from motionkit.robot import ironcub


@pytest.fixture(scope="module")
def clips(tmp_path_factory: pytest.TempPathFactory) -> Path:
    robot = ironcub()
    root = tmp_path_factory.mktemp("cli")
    write(root / "good.mcap", synthetic_trajectory(robot, 1.0), robot)
    flight = synthetic_trajectory(robot, 0.5, thrust=100.0, kind="flight", seed=3)
    write(root / "fly.mcap", flight, robot)
    return root


def test_info_json_and_table(clips: Path, capsys: pytest.CaptureFixture) -> None:
    assert main(["dataset", "info", str(clips), "--json"]) == 0
    rows = {Path(r["path"]).stem: r for r in json.loads(capsys.readouterr().out)}
    assert rows["fly"]["kind"] == "flight" and rows["good"]["frames"] == 120
    assert rows["good"]["rate_hz"] == pytest.approx(120.0) and rows["good"]["source"]["licence"]
    assert main(["dataset", "info", str(clips)]) == 0
    assert "2 clips, 1.5 s: flight 0.5 s, walk 1.0 s" in capsys.readouterr().out


def test_validate_exit_codes(clips: Path, tmp_path: Path) -> None:
    result = run("dataset", "validate", str(clips))
    assert result.returncode == 0 and "all clips passed" in result.stdout
    robot = ironcub()
    bad = synthetic_trajectory(robot, 1.0)
    positions = np.array(bad.joint_positions)
    positions[3:5, 0] = 5.0  # torso_pitch far beyond its limit
    write(tmp_path / "bad.mcap", replace(bad, joint_positions=positions), robot)
    result = run("dataset", "validate", str(tmp_path / "bad.mcap"))
    assert result.returncode == 1
    assert "[FAIL] joint position limits: 2 frames beyond; worst torso_pitch" in result.stdout
    result = run("dataset", "validate", str(tmp_path / "missing.mcap"))
    assert result.returncode == 2 and "no such file or folder" in result.stderr


def test_export_both_formats(clips: Path, tmp_path: Path) -> None:
    for fmt in ("npz", "amp-rsl-rl"):
        assert main(["dataset", "export", str(clips), "--format", fmt, "--out", str(tmp_path)]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "fly.npy", "fly.npz", "good.npy", "good.npz",
    ]  # fmt: skip
