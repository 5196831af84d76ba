"""One clip = one MCAP file: `write(path, trajectory)` and `read(path) -> Trajectory`.

File layout (MCAP, zstd-compressed chunks, indexed, with CRCs):
- /motion: `motionkit.MotionChunk` messages (protobuf), one per block of frames (about one
  second), log time = the block's first frame time;
- /tf: `foxglove.FrameTransforms` at `tf_rate` Hz: world -> root link and every joint of the
  robot, so that Foxglove shows the robot move;
- metadata record `motionkit`: robot, model hash, names, rate, kind, source, generator, config
  and metrics (string map; nested values as JSON); the optional arrays' names and flags
  (corner_names, landmark_names, landmark_parents, has_contact_forces, has_landmarks: absent in
  older files, which read as clips without them);
- attachment `<robot>.urdf`: the robot description the motion was made for.
"""

from __future__ import annotations

import json
import math
import re
import struct
import zlib
from dataclasses import asdict, fields
from io import BytesIO
from pathlib import Path
from typing import IO, Any

import numpy as np
from mcap.stream_reader import CRCValidationError
from mcap.writer import CompressionType, IndexType, Writer
from scipy.spatial.transform import Rotation

from motionkit import __version__
from motionkit.core.errors import DatasetError
from motionkit.dataset.messages import (
    MOTION_SCHEMA,
    TF_SCHEMA,
    decode_chunk,
    encode_chunk,
    encode_frame_transforms,
    motion_schema,
    tf_schema,
)
from motionkit.dataset.trajectory import (
    ARRAY_FIELDS,
    NAME_FIELDS,
    OPTIONAL,
    Metadata,
    Source,
    Trajectory,
    frame_shape,
)
from motionkit.files.inputs import open_input
from motionkit.files.outputs import atomic_output
from motionkit.robot import Robot
from motionkit.robot.geometry import from_rotation
from motionkit.robot.kinematics import joint_transforms

FORMAT = "motionkit-clip/1"
METADATA_NAME = "motionkit"
MOTION_TOPIC = "/motion"
TF_TOPIC = "/tf"
WORLD_FRAME = "world"
_NS = 1_000_000_000
_MAGIC = b"\x89MCAP0\r\n"
_FOOTER = 1 + 8 + 8 + 8 + 4  # opcode, length, summary_start, summary_offset_start, summary_crc
_DATA_END = 1 + 8 + 4  # opcode, length, data_section_crc


# -- writing ------------------------------------------------------------------------------------
def write(path: Path | str, trajectory: Trajectory, robot: Robot, *, tf_rate: float = 15.0) -> Path:
    """Write a clip atomically (temporary file, then rename); tf_rate 0 leaves /tf out.

    The file holds /motion, /tf, the metadata record and the robot's URDF (see the module
    doc); missing folders are made.

    Args:
        path: the .mcap file to write (replaced if it exists).
        trajectory: the clip, with the robot's joint, jet, foot (and corner) names and its
            name and model hash in the metadata.
        robot: the robot the clip was made for.
        tf_rate: rate of the /tf transforms [Hz]; 0 leaves /tf out.

    Returns:
        `path`, as a Path.

    Raises:
        DatasetError: the trajectory's names, robot or model hash differ from `robot`'s.
    """
    check_against_robot(trajectory, robot)
    path = Path(path)
    with atomic_output(path) as stream:
        _write_mcap(stream, trajectory, robot, tf_rate)
    return path


def encode(trajectory: Trajectory, robot: Robot, *, tf_rate: float = 15.0) -> bytes:
    """The bytes `write` puts in a clip file (for a worker that hands its clip to the driver).

    Args:
        trajectory: the clip, as for `write`.
        robot: the robot the clip was made for.
        tf_rate: rate of the /tf transforms [Hz]; 0 leaves /tf out.

    Returns:
        The MCAP file's bytes.

    Raises:
        DatasetError: the trajectory's names, robot or model hash differ from `robot`'s.
    """
    check_against_robot(trajectory, robot)
    buffer = BytesIO()
    _write_mcap(buffer, trajectory, robot, tf_rate)
    return buffer.getvalue()


def corner_names(robot: Robot) -> tuple[str, ...]:
    """The robot's sole corners, feet in spec order: the rows of `contact_forces`.

    Args:
        robot: the robot whose spec names the feet and their corner frames.

    Returns:
        The corner frame names, each foot's corners in its spec's order.
    """
    return tuple(corner for foot in robot.spec.feet for corner in foot.corners)


def check_against_robot(trajectory: Trajectory, robot: Robot) -> None:
    meta = trajectory.metadata
    expected = {
        "joint_names": robot.joint_names,
        "jet_names": tuple(jet.name for jet in robot.spec.jets),
        "foot_names": tuple(foot.side for foot in robot.spec.feet),
    }
    if trajectory.contact_forces is not None:
        expected["corner_names"] = corner_names(robot)
    for name, names in expected.items():
        if getattr(trajectory, name) != names:
            raise DatasetError(
                f"{name} {list(getattr(trajectory, name))} differ from robot '{robot.name}': "
                f"{list(names)}"
            )
    if (meta.robot, meta.robot_hash) != (robot.name, robot.model_hash):
        raise DatasetError(
            f"the clip is for robot {meta.robot} (model {meta.robot_hash}), not {robot.name} "
            f"(model {robot.model_hash})"
        )


def _write_mcap(stream: IO[bytes], trajectory: Trajectory, robot: Robot, tf_rate: float) -> None:
    writer = Writer(
        stream,
        compression=CompressionType.ZSTD,
        index_types=IndexType.ALL,
        enable_data_crcs=True,
    )
    writer.start(profile="", library=f"motionkit {__version__}")
    names = {name: json.dumps(getattr(trajectory, name)) for name in NAME_FIELDS}
    motion = writer.register_channel(
        MOTION_TOPIC,
        "protobuf",
        writer.register_schema(MOTION_SCHEMA, "protobuf", motion_schema()),
        metadata=names
        | {
            "layout": "frame-major arrays; quaternion w,x,y,z; base velocities in the world frame",
            "max_block_seconds": repr(_block_seconds(trajectory)),
        },
    )
    time = trajectory.time
    block = _block_frames(trajectory)
    tf_messages: list[tuple[int, bytes]] = []
    if tf_rate > 0:
        tf = writer.register_channel(
            TF_TOPIC, "protobuf", writer.register_schema(TF_SCHEMA, "protobuf", tf_schema())
        )
        tf_messages = _frame_transforms(trajectory, robot, tf_rate)
    arrays = trajectory.arrays()
    next_tf = 0
    for start in range(0, trajectory.frames, block):
        stop = start + block
        payload = encode_chunk({k: v[start:stop] for k, v in arrays.items()})
        writer.add_message(motion, _ns(time[start]), payload, _ns(time[start]))
        while next_tf < len(tf_messages) and tf_messages[next_tf][0] < stop:
            frame, message = tf_messages[next_tf]
            writer.add_message(tf, _ns(time[frame]), message, _ns(time[frame]))
            next_tf += 1
    writer.add_metadata(METADATA_NAME, _metadata_record(trajectory))
    writer.add_attachment(0, 0, f"{robot.name}.urdf", "application/xml", robot.urdf_text.encode())
    writer.finish()


def _ns(seconds: float) -> int:
    return round(float(seconds) * _NS)


def _block_frames(trajectory: Trajectory) -> int:
    """Frames per /motion message: about one second."""
    return max(1, round(trajectory.rate)) if trajectory.frames > 1 else 1


def _block_seconds(trajectory: Trajectory) -> float:
    block = _block_frames(trajectory)
    starts = trajectory.time[::block]
    ends = trajectory.time[
        np.minimum(np.arange(len(starts)) * block + block - 1, len(trajectory.time) - 1)
    ]
    return float(np.max(ends - starts))


def _metadata_record(trajectory: Trajectory) -> dict[str, str]:
    meta = trajectory.metadata
    return {
        "format": FORMAT,
        "robot": meta.robot,
        "robot_hash": meta.robot_hash,
        "kind": meta.kind,
        "generator": meta.generator,
        "motionkit_version": meta.motionkit_version,
        "joint_names": json.dumps(trajectory.joint_names),
        "jet_names": json.dumps(trajectory.jet_names),
        "foot_names": json.dumps(trajectory.foot_names),
        "frames": str(trajectory.frames),
        "rate": repr(trajectory.rate),
        "duration": repr(trajectory.duration),
        "has_throttle": json.dumps(trajectory.throttle is not None),
        "corner_names": json.dumps(trajectory.corner_names),
        "has_contact_forces": json.dumps(trajectory.contact_forces is not None),
        "landmark_names": json.dumps(trajectory.landmark_names),
        "landmark_parents": json.dumps(trajectory.landmark_parents),
        "has_landmarks": json.dumps(trajectory.landmarks is not None),
        "source": json.dumps(asdict(meta.source)),
        "config": json.dumps(meta.config, sort_keys=True),
        "metrics": json.dumps(meta.metrics, sort_keys=True),
    }


def _frame_transforms(
    trajectory: Trajectory, robot: Robot, tf_rate: float
) -> list[tuple[int, bytes]]:
    """(frame index, FrameTransforms message) at about tf_rate: world -> root, every joint."""
    step = max(1, round(trajectory.rate / tf_rate)) if trajectory.frames > 1 else 1
    frames = np.arange(0, trajectory.frames, step)
    model = robot.model
    joints = [j for link in model.subtree(model.root)[1:] if (j := model.parent_joint(link))]
    column = {name: i for i, name in enumerate(trajectory.joint_names)}
    positions = trajectory.joint_positions[frames].astype(float)
    poses = np.empty((len(frames), len(joints) + 1, 7))
    poses[:, 0, :3] = trajectory.base_position[frames]
    poses[:, 0, 3:] = trajectory.base_orientation[frames]
    for k, joint in enumerate(joints, start=1):
        q = positions[:, column[joint.name]] if joint.name in column else None
        transforms = joint_transforms(joint, q, len(frames))
        poses[:, k, :3] = transforms[:, :3, 3]
        poses[:, k, 3:] = from_rotation(Rotation.from_matrix(transforms[:, :3, :3]))
    poses = poses.astype(np.float32).astype(np.float64)  # float32 precision compresses better
    parents = [WORLD_FRAME] + [j.parent for j in joints]
    children = [model.root] + [j.child for j in joints]
    messages = encode_frame_transforms(trajectory.time[frames], parents, children, poses)
    return list(zip(frames.tolist(), messages, strict=True))


# -- reading ------------------------------------------------------------------------------------
def read(path: Path | str, start: float | None = None, end: float | None = None) -> Trajectory:
    """A clip as arrays.

    With start and/or end, only the frames in [start, end], reading only the chunks that hold
    them; a whole read also checks the file's CRCs and that the metadata's frames, rate and
    duration are the motion's.

    Args:
        path: the .mcap clip.
        start: the first time to keep [s] (None: from the first frame).
        end: the last time to keep [s] (None: to the last frame).

    Returns:
        The clip: float64 time [s], float32 arrays frame-major (see `Trajectory`), its names
        and metadata.

    Raises:
        DatasetError: a file that cannot be read, is not an MCAP motionkit clip, fails a CRC,
            has invalid metadata or motion, or has no frame in [start, end].
    """
    path = Path(path)
    try:
        with open_input(path, DatasetError, "the clip") as handle:
            if start is None and end is None:
                buffer = handle.read()
                _check_file_crcs(buffer, path)  # covers every chunk: no need to check each
                return _read(BytesIO(buffer), path, None, None, chunk_crcs=False)
            return _read(handle, path, start, end, chunk_crcs=True).window(start, end)
    except OSError as exc:
        raise DatasetError(f"{path}: cannot read ({exc.strerror})") from exc


def read_metadata(path: Path | str) -> tuple[Metadata, dict[str, str]]:
    """The clip's metadata and its raw record (frames, rate, names...), without the motion.

    Every field of the record is checked (types, ranges).

    Args:
        path: the .mcap clip.

    Returns:
        The Metadata and the record (string -> string; lists and tables as JSON).

    Raises:
        DatasetError: a file that cannot be read, is not an MCAP motionkit clip, or whose
            record lacks a field or has one of the wrong type.
    """
    path = Path(path)
    try:
        with open_input(path, DatasetError, "the clip") as handle:
            record = _index(handle, path).record
    except OSError as exc:
        raise DatasetError(f"{path}: cannot read ({exc.strerror})") from exc
    return _metadata(record, path), record


def read_urdf(path: Path | str) -> str:
    """The robot description attached to a clip."""
    from mcap.reader import make_reader

    path = Path(path)
    with open_input(path, DatasetError, "the clip") as handle:
        try:
            for attachment in make_reader(handle, validate_crcs=True).iter_attachments():
                if attachment.name.endswith(".urdf"):
                    return attachment.data.decode()
        except Exception as exc:
            raise DatasetError(f"{path}: cannot read the attachments ({exc})") from exc
    raise DatasetError(f"{path}: no robot description (.urdf attachment) in the clip")


class _Index:
    """An open clip: its reader, the /motion channel and the metadata record."""

    def __init__(self, reader: Any, record: dict[str, str], channel: Any) -> None:
        self.reader = reader
        self.record = record
        self.channel = channel


def _index(stream: IO[bytes], path: Path, chunk_crcs: bool = True) -> _Index:
    """Open a clip; `chunk_crcs` False when the whole file's CRCs were checked already."""
    from mcap.reader import make_reader

    try:
        reader = make_reader(stream, validate_crcs=chunk_crcs)
        summary = reader.get_summary()
        if summary is None:
            raise DatasetError(f"{path}: the MCAP file has no summary (index); rewrite it")
        records = {m.name: m.metadata for m in reader.iter_metadata()}
    except DatasetError:
        raise
    except Exception as exc:
        raise DatasetError(f"{path}: not a readable MCAP file ({_describe(exc)})") from exc
    channels = [c for c in summary.channels.values() if c.topic == MOTION_TOPIC]
    if not channels:
        raise DatasetError(f"{path}: no {MOTION_TOPIC} channel; not a motionkit clip")
    schema = summary.schemas.get(channels[0].schema_id)
    if schema is None or schema.name != MOTION_SCHEMA or schema.encoding != "protobuf":
        found = f"{schema.name} ({schema.encoding})" if schema else "no schema"
        raise DatasetError(
            f"{path}: {MOTION_TOPIC} has schema {found}, expected {MOTION_SCHEMA} (protobuf)"
        )
    if METADATA_NAME not in records:
        raise DatasetError(f"{path}: no '{METADATA_NAME}' metadata record; not a motionkit clip")
    return _Index(reader, records[METADATA_NAME], channels[0])


def _describe(exc: Exception) -> str:
    if isinstance(exc, CRCValidationError):
        return f"CRC mismatch: {exc}"
    return f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__


_REQUIRED = (
    "format", "robot", "robot_hash", "kind", "generator", "motionkit_version", "joint_names",
    "jet_names", "foot_names", "frames", "rate", "duration", "source", "config", "metrics",
)  # fmt: skip


def _metadata(record: dict[str, str], path: Path) -> Metadata:
    """The Metadata of a record whose every field has its type (a DatasetError otherwise)."""
    missing = [key for key in _REQUIRED if key not in record]
    if missing:
        raise DatasetError(f"{path}: metadata record lacks {', '.join(map(repr, missing))}")
    if record["format"] != FORMAT:
        raise DatasetError(f"{path}: format '{record['format']}', this motionkit reads {FORMAT}")
    for key in ("robot", "robot_hash"):
        if not record[key].strip():
            raise DatasetError(f"{path}: metadata '{key}' is empty")
    if not re.fullmatch(r"[1-9][0-9]*", record["frames"]):
        raise _wrong(path, "frames", "a whole number of frames (1 or more)", record["frames"])
    for key in ("rate", "duration"):
        if not 0 <= _float(record[key]) < math.inf:
            raise _wrong(path, key, "a finite number >= 0", record[key])
    for key in (*NAME_FIELDS, "landmark_parents", *(f"has_{name}" for name in OPTIONAL)):
        _optional_json(record, key, None, path)  # type-checked (see _JSON_TYPES)
    source = _json(record, "source", path)
    known = {f.name for f in fields(Source)}
    if set(source) - known or not all(isinstance(v, str) for v in source.values()):
        raise _wrong(path, "source", f"an object of strings with keys {sorted(known)}", source)
    try:
        return Metadata(
            robot=record["robot"],
            robot_hash=record["robot_hash"],
            kind=record["kind"],
            generator=record["generator"],
            source=Source(**source),
            config=_json(record, "config", path),
            metrics=_json(record, "metrics", path),
            motionkit_version=record["motionkit_version"],
        )
    except DatasetError as exc:
        raise DatasetError(f"{path}: {exc}") from None


# The type of each JSON field of the metadata record: (check, what the message says).
_JSON_TYPES: dict[str, tuple[Any, str]] = {
    **{name: (lambda v: _is_list(v, str), "a list of names") for name in NAME_FIELDS},
    "landmark_parents": (lambda v: _is_list(v, int), "a list of whole numbers"),
    **{f"has_{name}": (lambda v: isinstance(v, bool), "true or false") for name in OPTIONAL},
    "source": (lambda v: isinstance(v, dict), "an object"),
    "config": (lambda v: isinstance(v, dict), "an object"),
    "metrics": (lambda v: isinstance(v, dict), "an object"),
}


def _is_list(value: Any, kind: type) -> bool:
    return isinstance(value, list) and all(
        isinstance(v, kind) and not isinstance(v, bool) for v in value
    )


def _float(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        return math.nan


def _wrong(path: Path, key: str, expected: str, value: Any) -> DatasetError:
    return DatasetError(f"{path}: metadata '{key}' should be {expected}, got {value!r:.80}")


def _json(record: dict[str, str], key: str, path: Path) -> Any:
    """The JSON value of a record field, checked against its type in _JSON_TYPES."""
    try:
        value = json.loads(record[key])
    except json.JSONDecodeError as exc:
        raise DatasetError(f"{path}: metadata '{key}' is not valid JSON ({exc})") from exc
    test, expected = _JSON_TYPES[key]
    if not test(value):
        raise _wrong(path, key, expected, value)
    return value


def _read(
    stream: IO[bytes], path: Path, start: float | None, end: float | None, chunk_crcs: bool
) -> Trajectory:
    index = _index(stream, path, chunk_crcs)
    metadata = _metadata(index.record, path)
    names = {k: tuple(_optional_json(index.record, k, [], path)) for k in NAME_FIELDS}
    parents = tuple(_optional_json(index.record, "landmark_parents", [], path))
    shapes = {name: frame_shape(name, names) for name in ARRAY_FIELDS}
    lookback = float(index.channel.metadata.get("max_block_seconds", "0"))
    low = None if start is None else max(0, _ns(start - lookback) - 1)
    high = None if end is None else _ns(end) + 1
    parts: dict[str, list[np.ndarray]] = {name: [] for name in ARRAY_FIELDS}
    for log_time, payload in _messages(index, path, low, high):
        try:
            arrays = decode_chunk(payload)
        except DatasetError as exc:  # the decoder knows the bytes, not the file
            raise DatasetError(
                f"{path}: /motion message at {log_time / _NS:.3f} s: {exc}"
            ) from None
        count = len(arrays.get("time", ()))
        for name in ARRAY_FIELDS:
            values = arrays.get(name)
            if values is None:
                continue
            shape = (count, *shapes[name])
            if values.size != np.prod(shape):
                raise DatasetError(
                    f"{path}: /motion message at {log_time / _NS:.3f} s has {values.size} "
                    f"values of {name}, expected {count} frames x {shapes[name] or 1}"
                )
            parts[name].append(values.reshape(shape))
    if not parts["time"]:
        where = "" if start is None and end is None else " in the requested range"
        raise DatasetError(f"{path}: no /motion frames{where}")
    merged = {k: np.concatenate(v) for k, v in parts.items() if v}
    if "contacts" in merged:
        merged["contacts"] = merged["contacts"].astype(bool)
    for name in ARRAY_FIELDS:
        if name in merged:
            continue
        if name in OPTIONAL and not _optional_json(index.record, f"has_{name}", False, path):
            continue  # an optional array the clip does not have
        if np.prod(shapes[name]) != 0:  # only zero-width arrays (no jets, no feet) may be absent
            raise DatasetError(f"{path}: /motion messages lack {name}")
        merged[name] = np.zeros((len(merged["time"]), *shapes[name]))
    trajectory = Trajectory(**merged, **names, landmark_parents=parents, metadata=metadata)
    if start is None and end is None:
        _check_record(trajectory, index.record, path)
    return trajectory


def _check_record(trajectory: Trajectory, record: dict[str, str], path: Path) -> None:
    """The record's frames, rate and duration are the motion's (times not finite are left to
    `dataset validate`'s finite-values check)."""
    if int(record["frames"]) != trajectory.frames:
        raise DatasetError(
            f"{path}: the metadata says {record['frames']} frames, /motion holds "
            f"{trajectory.frames}"
        )
    if not np.all(np.isfinite(trajectory.time)):
        return
    for key in ("rate", "duration"):
        stated, actual = float(record[key]), getattr(trajectory, key)
        if not math.isclose(stated, actual, rel_tol=1e-6, abs_tol=1e-9):
            raise DatasetError(f"{path}: the metadata says {key} {stated:g}, the motion {actual:g}")


def _optional_json(record: dict[str, str], key: str, default: Any, path: Path) -> Any:
    """A JSON value of the metadata record, `default` when the key is absent (older files)."""
    return _json(record, key, path) if key in record else default


def _messages(
    index: _Index, path: Path, low: int | None, high: int | None
) -> list[tuple[int, bytes]]:
    """(log time, payload) of the /motion messages in [low, high) ns. The reader decompresses
    only the chunks whose index says they hold such messages, and checks their CRCs."""
    try:
        messages = index.reader.iter_messages([MOTION_TOPIC], starting_at=low, ending_before=high)
        return [(message.log_time, message.data) for _, _, message in messages]
    except Exception as exc:
        raise DatasetError(f"{path}: the motion is unreadable ({_describe(exc)})") from exc


def _check_file_crcs(buffer: bytes, path: Path) -> None:
    """The MCAP data-section and summary CRCs of a whole file in memory."""
    if len(buffer) < 2 * len(_MAGIC) + _FOOTER or not buffer.startswith(_MAGIC):
        raise DatasetError(f"{path}: not an MCAP file (bad magic or too short)")
    if not buffer.endswith(_MAGIC):
        raise DatasetError(f"{path}: the MCAP file is truncated (no closing magic)")
    footer = len(buffer) - len(_MAGIC) - _FOOTER
    summary_start, _, summary_crc = struct.unpack_from("<QQI", buffer, footer + 9)
    if summary_crc and zlib.crc32(buffer[summary_start or footer : footer + 25]) != summary_crc:
        raise DatasetError(f"{path}: CRC mismatch in the summary section; the file is corrupt")
    data_end = (summary_start or footer) - _DATA_END
    if data_end < len(_MAGIC) or buffer[data_end] != 0x0F:
        raise DatasetError(f"{path}: no data end record where the footer says; the file is corrupt")
    (data_crc,) = struct.unpack_from("<I", buffer, data_end + 9)
    if data_crc and zlib.crc32(buffer[:data_end]) != data_crc:
        raise DatasetError(f"{path}: CRC mismatch in the data section; the file is corrupt")
