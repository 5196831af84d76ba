"""Protobuf messages of a clip: motionkit.MotionChunk on /motion, foxglove.FrameTransforms on /tf.

Generic MCAP tools decode both from the schemas embedded in the file. motionkit itself encodes
and decodes them with numpy, straight from the protobuf wire format (packed repeated fields are
little-endian arrays), which is what makes reading an hour of motion take a fraction of a second.
The tests check these codecs against the protobuf library.

A MotionChunk holds consecutive frames; every array is frame-major (frame 0's values first).
Field numbers never change; new fields get new numbers, so that older files still read.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from google.protobuf import descriptor_pb2
from google.protobuf.descriptor import FileDescriptor

from motionkit.core.errors import DatasetError

MOTION_SCHEMA = "motionkit.MotionChunk"
TF_SCHEMA = "foxglove.FrameTransforms"

_F = descriptor_pb2.FieldDescriptorProto


@dataclass(frozen=True)
class ChunkField:
    name: str
    number: int
    proto_type: int
    dtype: str  # numpy dtype of the packed values


# The MotionChunk fields, in field-number order. Widths per frame come from the trajectory.
CHUNK_FIELDS = (
    ChunkField("time", 1, _F.TYPE_DOUBLE, "<f8"),  # s
    ChunkField("base_position", 2, _F.TYPE_FLOAT, "<f4"),  # m, world
    ChunkField("base_orientation", 3, _F.TYPE_FLOAT, "<f4"),  # quaternion w, x, y, z
    ChunkField("joint_positions", 4, _F.TYPE_FLOAT, "<f4"),  # rad
    ChunkField("joint_velocities", 5, _F.TYPE_FLOAT, "<f4"),  # rad/s
    ChunkField("base_linear_velocity", 6, _F.TYPE_FLOAT, "<f4"),  # m/s, world
    ChunkField("base_angular_velocity", 7, _F.TYPE_FLOAT, "<f4"),  # rad/s, world
    ChunkField("thrust", 8, _F.TYPE_FLOAT, "<f4"),  # N per jet
    ChunkField("throttle", 9, _F.TYPE_FLOAT, "<f4"),  # % per jet; empty when absent
    ChunkField("contacts", 10, _F.TYPE_BOOL, "u1"),  # per foot
    # optional, empty when absent; frame-major, then corner/landmark-major, then x, y, z
    ChunkField("contact_forces", 11, _F.TYPE_FLOAT, "<f4"),  # N per sole corner, world
    ChunkField("landmarks", 12, _F.TYPE_FLOAT, "<f4"),  # m per skeleton landmark, world
)
_BY_NUMBER = {f.number: f for f in CHUNK_FIELDS}


def motion_schema() -> bytes:
    """The FileDescriptorSet of motionkit.MotionChunk (proto3: repeated scalars are packed)."""
    proto = descriptor_pb2.FileDescriptorProto(
        name="motionkit/MotionChunk.proto", package="motionkit", syntax="proto3"
    )
    message = proto.message_type.add(name="MotionChunk")
    for field in CHUNK_FIELDS:
        message.field.add(
            name=field.name, number=field.number, label=_F.LABEL_REPEATED, type=field.proto_type
        )
    return descriptor_pb2.FileDescriptorSet(file=[proto]).SerializeToString()


def motion_chunk_class() -> type:
    """The protobuf message class of MotionChunk, built from the schema (for generic decoding)."""
    from google.protobuf import descriptor_pool, message_factory

    pool = descriptor_pool.DescriptorPool()
    for proto in descriptor_pb2.FileDescriptorSet.FromString(motion_schema()).file:
        pool.Add(proto)
    return message_factory.GetMessageClass(pool.FindMessageTypeByName(MOTION_SCHEMA))


def tf_schema() -> bytes:
    """The FileDescriptorSet of foxglove.FrameTransforms and the files it imports."""
    from foxglove_schemas_protobuf import FrameTransforms_pb2

    files: list[descriptor_pb2.FileDescriptorProto] = []
    seen: set[str] = set()

    def add(descriptor: FileDescriptor) -> None:
        if descriptor.name in seen:
            return
        seen.add(descriptor.name)
        for dependency in descriptor.dependencies:
            add(dependency)
        proto = descriptor_pb2.FileDescriptorProto()
        descriptor.CopyToProto(proto)
        files.append(proto)

    add(FrameTransforms_pb2.DESCRIPTOR)
    return descriptor_pb2.FileDescriptorSet(file=files).SerializeToString()


# -- wire format --------------------------------------------------------------------------------
def _varint(value: int) -> bytes:
    out = bytearray()
    while True:
        byte = value & 0x7F
        value >>= 7
        if value:
            out.append(byte | 0x80)
        else:
            out.append(byte)
            return bytes(out)


def _read_varint(data: bytes, position: int) -> tuple[int, int]:
    value = shift = 0
    while True:
        if position >= len(data) or shift > 63:
            raise DatasetError("truncated or invalid varint in a MotionChunk message")
        byte = data[position]
        value |= (byte & 0x7F) << shift
        position += 1
        if not byte & 0x80:
            return value, position
        shift += 7


def encode_chunk(arrays: dict[str, np.ndarray]) -> bytes:
    """One MotionChunk from arrays keyed by field name (absent or empty fields are omitted)."""
    parts = []
    for field in CHUNK_FIELDS:
        array = arrays.get(field.name)
        if array is None or array.size == 0:
            continue
        data = np.ascontiguousarray(array, dtype=field.dtype).tobytes()
        parts += [_varint(field.number << 3 | 2), _varint(len(data)), data]
    return b"".join(parts)


def decode_chunk(data: bytes) -> dict[str, np.ndarray]:
    """The flat arrays of one MotionChunk keyed by field name; unknown fields are skipped."""
    arrays: dict[str, np.ndarray] = {}
    position = 0
    while position < len(data):
        key, position = _read_varint(data, position)
        number, wire_type = key >> 3, key & 7
        if wire_type != 2:
            raise DatasetError(
                f"MotionChunk field {number} has wire type {wire_type}; motionkit reads packed "
                "repeated fields (wire type 2) only"
            )
        length, position = _read_varint(data, position)
        end = position + length
        if end > len(data):
            raise DatasetError(f"MotionChunk field {number} runs past the end of the message")
        field = _BY_NUMBER.get(number)
        if field is not None:
            arrays[field.name] = np.frombuffer(
                data, field.dtype, length // np.dtype(field.dtype).itemsize, position
            )
        position = end
    return arrays


def encode_frame_transforms(
    seconds: np.ndarray, parents: list[str], children: list[str], poses: np.ndarray
) -> list[bytes]:
    """foxglove.FrameTransforms messages, one per time, vectorised over times.

    seconds: (M,) stamps; parents/children: frame ids of the N transforms; poses: (M, N, 7) as
    translation x, y, z and quaternion w, x, y, z. Every field is written, zeros included, so
    that all messages with the same stamp length share one byte layout.
    """
    stamps = [_timestamp(float(s)) for s in seconds]
    # foxglove order: translation x y z, then rotation x y z w
    values = np.ascontiguousarray(poses[..., [0, 1, 2, 4, 5, 6, 3]], dtype="<f8")
    messages: list[bytes] = [b""] * len(stamps)
    for stamp_length in sorted({len(s) for s in stamps}):
        rows = [i for i, s in enumerate(stamps) if len(s) == stamp_length]
        template, stamp_at, value_at = _tf_layout(stamp_length, parents, children)
        buffer = np.tile(template, (len(rows), 1))
        stamp_bytes = np.frombuffer(b"".join(stamps[i] for i in rows), np.uint8)
        buffer[:, stamp_at] = np.tile(stamp_bytes.reshape(len(rows), stamp_length), len(parents))
        buffer[:, value_at] = values[rows].reshape(len(rows), -1).view(np.uint8)
        for row, encoded in zip(rows, buffer, strict=True):
            messages[row] = encoded.tobytes()
    return messages


def _timestamp(seconds: float) -> bytes:
    whole = int(np.floor(seconds))
    nanos = round((seconds - whole) * 1e9)
    if nanos >= 1_000_000_000:
        whole, nanos = whole + 1, nanos - 1_000_000_000
    return b"\x08" + _varint(whole) + b"\x10" + _varint(nanos)


def _tf_layout(
    stamp_length: int, parents: list[str], children: list[str]
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A FrameTransforms byte template with zeros for stamps and values, and the byte indices
    where each transform's stamp and its seven doubles go."""
    template = bytearray()
    stamp_at: list[int] = []
    value_at: list[int] = []
    for parent, child in zip(parents, children, strict=True):
        body = bytearray(b"\x0a" + _varint(stamp_length))
        stamp_start = len(body)
        body += bytes(stamp_length)
        for tag, name in ((b"\x12", parent), (b"\x1a", child)):
            encoded = name.encode()
            body += tag + _varint(len(encoded)) + encoded
        doubles: list[int] = []
        for tag, count in ((b"\x22", 3), (b"\x2a", 4)):
            body += tag + _varint(9 * count)
            for k in range(count):
                body.append((k + 1) << 3 | 1)
                doubles.append(len(body))
                body += bytes(8)
        header = b"\x0a" + _varint(len(body))
        offset = len(template) + len(header)
        stamp_at += range(offset + stamp_start, offset + stamp_start + stamp_length)
        value_at += [offset + d + b for d in doubles for b in range(8)]
        template += header + body
    return np.frombuffer(bytes(template), np.uint8), np.array(stamp_at), np.array(value_at)
