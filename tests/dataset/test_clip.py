"""MCAP clips: round trips, the official mcap reader, windows, corrupt files, atomic writes."""

from dataclasses import replace
from pathlib import Path

import mcap.reader
import numpy as np
import pytest
from mcap.reader import make_reader
from mcap.writer import Writer

import motionkit.dataset.clip as clip_module
from motionkit.dataset import read, read_metadata, write
from motionkit.dataset.clip import read_urdf
from motionkit.dataset.messages import motion_chunk_class
from motionkit.dataset.synthetic import synthetic_trajectory
from motionkit.errors import DatasetError
from motionkit.robot import ironcub


@pytest.fixture(scope="module")
def robot():
    return ironcub()


@pytest.fixture(scope="module")
def walk(robot):
    return synthetic_trajectory(robot, 3.0, 120.0, seed=2)


@pytest.fixture
def walk_file(tmp_path: Path, robot, walk) -> Path:
    return write(tmp_path / "walk.mcap", walk, robot)


def test_round_trip_is_bit_identical(tmp_path: Path, robot, walk) -> None:
    throttled = replace(walk, throttle=np.full((walk.frames, 4), 42.5), thrust=walk.thrust + 10)
    for trajectory in (walk, throttled):
        back = read(write(tmp_path / "clip.mcap", trajectory, robot))
        assert back.equals(trajectory)
        assert back.base_position.dtype == np.float32 and back.time.dtype == np.float64
    assert read(tmp_path / "clip.mcap").throttle is not None


def test_official_reader_with_crcs_decodes_the_same_motion(walk_file: Path, walk) -> None:
    chunk_class = motion_chunk_class()
    times, joints, topics = [], [], set()
    with open(walk_file, "rb") as handle:
        reader = make_reader(handle, validate_crcs=True)
        summary = reader.get_summary()
        for schema, channel, message in reader.iter_messages():
            topics.add((channel.topic, schema.name))
            if channel.topic == "/motion":
                decoded = chunk_class.FromString(message.data)
                times += list(decoded.time)
                joints += list(decoded.joint_positions)
        metadata = {m.name: m.metadata for m in reader.iter_metadata()}
    assert topics == {("/motion", "motionkit.MotionChunk"), ("/tf", "foxglove.FrameTransforms")}
    assert summary.statistics.message_count > 0 and len(summary.chunk_indexes) >= 1
    assert {c.compression for c in summary.chunk_indexes} == {"zstd"}
    np.testing.assert_array_equal(times, walk.time)
    np.testing.assert_array_equal(np.reshape(joints, (-1, 23)), walk.joint_positions)
    assert metadata["motionkit"]["kind"] == "walk"
    assert metadata["motionkit"]["robot_hash"] == walk.metadata.robot_hash


def test_tf_publishes_every_link_at_the_requested_rate(tmp_path: Path, robot, walk) -> None:
    path = write(tmp_path / "tf.mcap", walk, robot, tf_rate=30.0)
    with open(path, "rb") as handle:
        stamps = [m.log_time for _, _, m in make_reader(handle).iter_messages(topics=["/tf"])]
    assert len(stamps) == walk.frames // 4  # every 4th frame of 120 Hz
    assert np.allclose(np.diff(stamps), 1e9 / 30, atol=2)
    without = write(tmp_path / "notf.mcap", walk, robot, tf_rate=0)
    with open(without, "rb") as handle:
        channels = make_reader(handle).get_summary().channels.values()
    assert [c.topic for c in channels] == ["/motion"]


def test_metadata_and_attachment(walk_file: Path, robot, walk) -> None:
    metadata, record = read_metadata(walk_file)
    assert metadata == walk.metadata
    assert int(record["frames"]) == walk.frames and float(record["rate"]) == pytest.approx(120)
    assert read_urdf(walk_file) == robot.urdf_text


def test_window_reads_only_the_chunks_it_needs(tmp_path: Path, robot, monkeypatch) -> None:
    long = synthetic_trajectory(robot, 60.0, 120.0)
    path = write(tmp_path / "long.mcap", long, robot)
    decompressed = []
    original = mcap.reader.breakup_chunk
    monkeypatch.setattr(
        mcap.reader, "breakup_chunk", lambda c, **kw: decompressed.append(c) or original(c, **kw)
    )
    read(path)
    total = len(decompressed)
    decompressed.clear()
    window = read(path, 30.0, 32.0)
    assert total >= 6 and len(decompressed) <= 2
    assert window.equals(long.window(30.0, 32.0))
    assert window.time[0] == pytest.approx(30.0) and window.time[-1] == pytest.approx(32.0)
    assert read(path, end=0.5).equals(long.window(end=0.5))


def test_flipped_bytes_are_detected(walk_file: Path) -> None:
    data = walk_file.read_bytes()
    positions = np.random.default_rng(0).choice(len(data), 60, replace=False)
    for position in [*positions, 0, len(data) - 1, len(data) // 2]:
        corrupt = bytearray(data)
        corrupt[position] ^= 0x10
        walk_file.write_bytes(bytes(corrupt))
        with pytest.raises(DatasetError, match=str(walk_file)):
            read(walk_file)


def test_truncated_files_give_clear_errors(walk_file: Path) -> None:
    data = walk_file.read_bytes()
    for size in (len(data) // 2, len(data) - 1, 10):
        walk_file.write_bytes(data[:size])
        with pytest.raises(DatasetError, match=r"truncated|not an MCAP"):
            read(walk_file)


def _foreign_mcap(path: Path, schema_name: str, metadata: bool) -> Path:
    with open(path, "wb") as stream:
        writer = Writer(stream)
        writer.start()
        schema = writer.register_schema(schema_name, "protobuf", b"")
        channel = writer.register_channel("/motion", "protobuf", schema)
        writer.add_message(channel, 0, b"", 0)
        if metadata:
            writer.add_metadata("motionkit", {"format": "motionkit-clip/1"})
        writer.finish()
    return path


def test_wrong_schema_missing_metadata_and_non_mcap(tmp_path: Path) -> None:
    with pytest.raises(DatasetError, match=r"expected motionkit\.MotionChunk"):
        read(_foreign_mcap(tmp_path / "a.mcap", "geometry_msgs.Pose", metadata=True))
    with pytest.raises(DatasetError, match="no 'motionkit' metadata record"):
        read(_foreign_mcap(tmp_path / "b.mcap", "motionkit.MotionChunk", metadata=False))
    with pytest.raises(DatasetError, match="metadata record lacks 'robot', 'robot_hash'"):
        read(_foreign_mcap(tmp_path / "c.mcap", "motionkit.MotionChunk", metadata=True))
    text = tmp_path / "d.mcap"
    text.write_text("not an mcap file at all, just text " * 10)
    with pytest.raises(DatasetError, match="not an MCAP"):
        read(text)
    with pytest.raises(DatasetError, match="cannot read"):
        read(tmp_path / "missing.mcap")


def test_failed_write_leaves_no_file(tmp_path: Path, robot, walk, monkeypatch) -> None:
    path = tmp_path / "clip.mcap"
    wrong = replace(walk, metadata=replace(walk.metadata, robot_hash="0" * 16))
    with pytest.raises(DatasetError, match="not ironcub"):
        write(path, wrong, robot)

    def explode(arrays):
        raise RuntimeError("disk on fire")

    write(path, walk, robot)
    before = path.read_bytes()
    monkeypatch.setattr(clip_module, "encode_chunk", explode)
    with pytest.raises(RuntimeError):
        write(path, synthetic_trajectory(robot, 1.0), robot)
    assert path.read_bytes() == before  # the old file is untouched
    assert [p.name for p in tmp_path.iterdir()] == ["clip.mcap"]  # no temporary left


def test_write_rejects_a_trajectory_of_another_robot(tmp_path: Path, toy_robot, walk) -> None:
    with pytest.raises(DatasetError, match=r"joint_names .* differ from robot 'toy'"):
        write(tmp_path / "x.mcap", walk, toy_robot)
    assert not (tmp_path / "x.mcap").exists()
