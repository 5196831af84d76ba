"""MCAP clips: round trips, the official mcap reader, windows, corrupt files, atomic writes,
the optional contact forces and landmarks (and files written before them)."""

import json
from dataclasses import replace
from pathlib import Path

import mcap.reader
import numpy as np
import pytest
from mcap.reader import make_reader
from mcap.writer import Writer

import motionkit.dataset.clip as clip_module
from motionkit.core.errors import DatasetError
from motionkit.dataset import corner_names, read, read_metadata, write
from motionkit.dataset.clip import read_urdf
from motionkit.dataset.messages import motion_chunk_class
from motionkit.dataset.synthetic import synthetic_trajectory
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


SKELETON = ("pelvis", "l_hip", "l_knee", "r_hip", "r_knee")
PARENTS = (-1, 0, 1, 0, 3)


def with_extras(walk, robot):
    """The walk with planned contact forces and a five-landmark skeleton."""
    rng = np.random.default_rng(3)
    return replace(
        walk,
        corner_names=corner_names(robot),
        contact_forces=rng.normal(50.0, 20.0, (walk.frames, 8, 3)),
        landmark_names=SKELETON,
        landmark_parents=PARENTS,
        landmarks=rng.normal(0.0, 0.5, (walk.frames, len(SKELETON), 3)),
    )


def test_contact_forces_and_landmarks_round_trip(tmp_path: Path, robot, walk) -> None:
    extras = with_extras(walk, robot)
    assert extras.corner_names[:2] == ("l_sole_1", "l_sole_2") and len(extras.corner_names) == 8
    path = write(tmp_path / "extras.mcap", extras, robot)
    back = read(path)
    assert back.equals(extras) and not back.equals(walk)
    assert back.contact_forces.dtype == np.float32 and back.contact_forces.shape == (360, 8, 3)
    assert back.landmark_parents == PARENTS and back.landmarks.shape == (360, 5, 3)
    # windows read only some chunks and still hold the extras of those frames
    window = read(path, 1.0, 1.5)
    assert window.equals(extras.window(1.0, 1.5))
    np.testing.assert_array_equal(window.landmarks[0], extras.landmarks[120])
    np.testing.assert_array_equal(
        extras.select(slice(5, 9)).contact_forces[0], extras.contact_forces[5]
    )
    _, record = read_metadata(path)
    assert json.loads(record["corner_names"]) == list(corner_names(robot))
    assert json.loads(record["landmark_parents"]) == list(PARENTS)
    assert record["has_contact_forces"] == "true" and record["has_landmarks"] == "true"
    # one without the other
    forces_only = replace(extras, landmark_names=(), landmark_parents=(), landmarks=None)
    back = read(write(tmp_path / "forces.mcap", forces_only, robot))
    assert back.equals(forces_only) and back.landmarks is None and back.landmark_names == ()
    # the official reader sees the new fields through the schema embedded in the file
    with open(path, "rb") as handle:
        _, _, message = next(make_reader(handle).iter_messages(topics=["/motion"]))
    decoded = motion_chunk_class().FromString(message.data)
    np.testing.assert_array_equal(
        np.reshape(decoded.contact_forces, (-1, 8, 3)), extras.contact_forces[:120]
    )


def test_a_file_of_the_older_format_reads_without_extras(
    tmp_path: Path, robot, walk, monkeypatch
) -> None:
    """Files written before the extras: schema fields 1-10, no extras keys in the metadata."""
    import motionkit.dataset.messages as messages

    new_keys = ("corner_names", "landmark_names", "landmark_parents")
    new_keys += ("has_contact_forces", "has_landmarks")
    record = clip_module._metadata_record
    with monkeypatch.context() as patch:
        patch.setattr(messages, "CHUNK_FIELDS", messages.CHUNK_FIELDS[:10])
        patch.setattr(
            clip_module,
            "_metadata_record",
            lambda t: {k: v for k, v in record(t).items() if k not in new_keys},
        )
        path = write(tmp_path / "old.mcap", with_extras(walk, robot), robot)  # extras dropped
    _, old_record = read_metadata(path)
    assert not set(new_keys) & set(old_record)
    back = read(path)
    assert back.contact_forces is None and back.landmarks is None and back.corner_names == ()
    assert back.equals(walk)


def test_extras_shapes_and_skeletons_are_checked(robot, walk) -> None:
    extras = with_extras(walk, robot)
    with pytest.raises(DatasetError, match=r"contact_forces has shape \(360, 8, 2\), expected"):
        replace(extras, contact_forces=np.zeros((360, 8, 2)))
    with pytest.raises(DatasetError, match=r"landmarks has shape \(360, 4, 3\), expected"):
        replace(extras, landmarks=np.zeros((360, 4, 3)))
    with pytest.raises(DatasetError, match="corner_names given without contact_forces"):
        replace(extras, contact_forces=None)
    with pytest.raises(DatasetError, match="landmark_parents has 4 entries"):
        replace(extras, landmark_parents=PARENTS[:4])
    with pytest.raises(DatasetError, match=r"landmark_parents\[2\] = 3 \(l_knee\)"):
        replace(extras, landmark_parents=(-1, 0, 3, 0, 3))  # a parent after its child
    with pytest.raises(DatasetError, match="repeat a name"):
        replace(extras, landmark_names=("a", "b", "c", "d", "a"))


def test_contact_forces_must_be_the_robots_corners(tmp_path: Path, robot, walk) -> None:
    from motionkit.dataset.validate import check_corners

    extras = with_extras(walk, robot)
    swapped = replace(extras, corner_names=(*corner_names(robot)[4:], *corner_names(robot)[:4]))
    with pytest.raises(DatasetError, match=r"corner_names \['r_sole_1'.* differ from robot"):
        write(tmp_path / "swapped.mcap", swapped, robot)
    assert check_corners(extras, robot).ok
    failed = check_corners(swapped, robot)
    assert not failed.ok and "expected ['l_sole_1'" in failed.detail


def test_resample_interpolates_the_extras(robot, walk) -> None:
    from motionkit.dataset import resample

    extras = with_extras(walk, robot)
    half = resample(extras, 60.0)  # every other frame of 120 Hz: the frames themselves
    np.testing.assert_allclose(half.contact_forces, extras.contact_forces[::2], atol=1e-4)
    between = resample(extras.window(end=0.5), 80.0)  # frame 1 at 1/80 s: 1.5 frames of 120 Hz
    expected = 0.5 * (extras.landmarks[1] + extras.landmarks[2])
    np.testing.assert_allclose(between.landmarks[1], expected, atol=1e-6)
