"""PATH -> clips: files, folders (newest first), waypoints, contact forces, and clear errors for
missing or corrupt files, raised before any server starts (in Python and from the CLI)."""

import json
import os
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from motionkit.cli import main
from motionkit.core.errors import ViewerError
from motionkit.dataset import corner_names, write
from motionkit.dataset.synthetic import synthetic_trajectory
from motionkit.robot import ironcub
from motionkit.viewer.sources import (
    check_robot,
    contact_forces,
    describe,
    load_motion,
    resolve_clips,
    waypoints,
)


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A training run: rollouts in a subfolder, one with waypoints and metrics."""
    robot = ironcub()
    root = tmp_path_factory.mktemp("run")
    (root / "rollouts").mkdir()
    old = synthetic_trajectory(robot, 0.5, seed=1)
    write(root / "rollouts" / "old.mcap", old, robot)
    new = synthetic_trajectory(robot, 0.5, seed=2, kind="rollout")
    meta = replace(
        new.metadata,
        generator="rollout",
        config={"waypoints": [[0, 0, 0.6], [1.0, 0.5, 0.6], [2, 0, 1.5]]},
        metrics={"return": 12.5, "episode_s": 0.5},
    )
    write(root / "rollouts" / "new.mcap", replace(new, metadata=meta), robot)
    os.utime(root / "rollouts" / "old.mcap", (1_000_000, 1_000_000))
    (root / "notes.txt").write_text("not a clip")
    return root


def test_folder_is_searched_recursively_newest_first(run_dir: Path) -> None:
    clips = resolve_clips(run_dir)
    assert [c.name for c in clips] == ["new", "old"]
    assert clips[0].frames == 60 and clips[0].rate == pytest.approx(120.0)
    assert clips[0].metadata.generator == "rollout"
    assert resolve_clips(run_dir / "rollouts" / "old.mcap")[0].name == "old"


def test_waypoints_from_metadata(run_dir: Path) -> None:
    new, old = resolve_clips(run_dir)
    np.testing.assert_allclose(waypoints(new), [[0, 0, 0.6], [1.0, 0.5, 0.6], [2, 0, 1.5]])
    assert waypoints(old).shape == (0, 3)
    bad = replace(new, record={**new.record, "waypoints": json.dumps([[1, 2]])})
    with pytest.raises(ViewerError, match=r"waypoints.*list of \[x, y, z\]"):
        waypoints(bad)


def test_waypoints_of_a_rollout_drop_their_times(run_dir: Path) -> None:
    """`motionkit play` and the evaluation rollouts store [time, x, y, z] rows."""
    new = resolve_clips(run_dir)[0]
    rows = [[0.0, 1.5, 0.0, 0.6], [2.25, 3.0, 1.0, 1.2]]
    played = replace(new, record={**new.record, "waypoints": json.dumps(rows)})
    np.testing.assert_allclose(waypoints(played), [[1.5, 0.0, 0.6], [3.0, 1.0, 1.2]])


def test_description_names_clip_source_and_metrics(run_dir: Path) -> None:
    text = describe(resolve_clips(run_dir)[0], "a warning")
    assert "**new** — rollout, made by rollout" in text
    assert "60 frames, 0.49 s at 120.0 Hz" in text and "synthetic-2" in text
    assert "| return | 12.5 |" in text and "⚠ a warning" in text


def test_contact_forces_when_present() -> None:
    robot = ironcub()
    motion = synthetic_trajectory(robot, 0.1)
    corners = corner_names(robot)
    assert contact_forces(motion, corners) is None
    forces = np.arange(motion.frames * 8 * 3, dtype=float).reshape(motion.frames, 8, 3)
    planned = replace(motion, corner_names=corners, contact_forces=forces)
    np.testing.assert_array_equal(contact_forces(planned, corners), forces)
    # rows follow the robot's corners, by name; corners without a force get none
    right_first = (*corners[4:], *corners[:4])
    shown = contact_forces(planned, right_first)
    np.testing.assert_array_equal(shown[:, :4], forces[:, 4:])
    left = replace(planned, corner_names=corners[:4], contact_forces=forces[:, :4])
    np.testing.assert_array_equal(contact_forces(left, corners)[:, 4:], 0.0)
    with pytest.raises(ViewerError, match=r"corners \['l_sole_1'.*not sole corners"):
        contact_forces(planned, corners[1:])


def test_clip_with_forces_at_unknown_corners_is_refused(tmp_path: Path) -> None:
    robot = ironcub()
    motion = synthetic_trajectory(robot, 0.2)
    forces = np.zeros((motion.frames, 8, 3))
    planned = replace(motion, corner_names=corner_names(robot), contact_forces=forces)
    clip = resolve_clips(write(tmp_path / "hop.mcap", planned, robot))[0]
    assert check_robot(clip, robot) == ""
    renamed = {**clip.record, "corner_names": json.dumps(["l_heel", *corner_names(robot)[1:]])}
    with pytest.raises(ViewerError, match=r"hop\.mcap: .* corners \['l_heel'\] that robot"):
        check_robot(replace(clip, record=renamed), robot)


def test_other_robot_is_refused_and_other_model_warned(run_dir: Path, toy_robot) -> None:
    clip = resolve_clips(run_dir)[0]
    assert check_robot(clip, ironcub()) == ""
    with pytest.raises(ViewerError, match="not those of robot 'toy'"):
        check_robot(clip, toy_robot)
    other = replace(clip, metadata=replace(clip.metadata, robot_hash="0123456789abcdef"))
    assert "model 0123456789abcdef" in check_robot(other, ironcub())


def test_missing_and_empty(tmp_path: Path) -> None:
    with pytest.raises(ViewerError, match=r"nothing\.mcap: no such file or folder"):
        resolve_clips(tmp_path / "nothing.mcap")
    with pytest.raises(ViewerError, match=r"no \.mcap clips in this folder"):
        resolve_clips(tmp_path)


@pytest.fixture
def corrupt(tmp_path: Path) -> dict[str, Path]:
    robot = ironcub()
    good = tmp_path / "good.mcap"
    write(good, synthetic_trajectory(robot, 2.0), robot)
    data = bytearray(good.read_bytes())
    truncated = tmp_path / "truncated.mcap"
    truncated.write_bytes(bytes(data[: len(data) // 2]))
    flipped = tmp_path / "flipped.mcap"
    data[len(data) // 3] ^= 0xFF  # inside the compressed motion: only the CRCs notice
    flipped.write_bytes(bytes(data))
    text = tmp_path / "text.mcap"
    text.write_text("hello")
    return {"truncated": truncated, "flipped": flipped, "text": text}


def test_corrupt_files_name_the_file(corrupt: dict[str, Path]) -> None:
    for name in ("truncated", "text"):
        with pytest.raises(ViewerError, match=rf"{name}\.mcap"):
            resolve_clips(corrupt[name])
    clip = resolve_clips(corrupt["flipped"])[0]  # the index is intact...
    with pytest.raises(ViewerError, match=r"flipped\.mcap.*(CRC|corrupt)"):
        load_motion(clip, ironcub())  # ...the motion is not


def test_cli_fails_before_the_server_starts(
    corrupt: dict[str, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys
) -> None:
    pytest.importorskip("viser")
    import motionkit.viewer.app as app

    def no_server(*args: object, **kwargs: object) -> None:
        raise AssertionError("the server must not start")

    monkeypatch.setattr(app.viser, "ViserServer", no_server)
    for path in (*corrupt.values(), tmp_path / "missing.mcap"):
        assert main(["view", str(path), "--port", "8099"]) == 2
        error = capsys.readouterr().err
        assert error.startswith("motionkit: error: ") and path.name in error
    assert main(["view"]) == 2
    assert "give a clip, folder or run" in capsys.readouterr().err


def test_console_script_exits_non_zero(corrupt: dict[str, Path]) -> None:
    from test_cli import run

    result = run("view", str(corrupt["truncated"]))
    assert result.returncode == 2 and "truncated.mcap" in result.stderr
    assert "http://" not in result.stdout  # no server was announced
    result = run("view", "--help")
    assert result.returncode == 0 and "--robot" in result.stdout and "127.0.0.1" in result.stdout
