"""Our numpy protobuf codecs against the protobuf library (an independent implementation)."""

import numpy as np
from foxglove_schemas_protobuf.FrameTransforms_pb2 import FrameTransforms
from google.protobuf import descriptor_pb2

from motionkit.dataset.messages import (
    CHUNK_FIELDS,
    decode_chunk,
    encode_chunk,
    encode_frame_transforms,
    motion_chunk_class,
    tf_schema,
)

REPEATED = descriptor_pb2.FieldDescriptorProto.LABEL_REPEATED


def test_chunk_bytes_decode_with_protobuf_and_back() -> None:
    """motion_chunk_class is protobuf's own class, built from the schema we embed in files."""
    rng = np.random.default_rng(0)
    arrays = {
        "time": np.arange(7) / 120.0,
        "base_position": rng.normal(size=(7, 3)).astype(np.float32),
        "joint_positions": rng.normal(size=(7, 23)).astype(np.float32),
        "contacts": rng.integers(0, 2, (7, 2)).astype(bool),
        "contact_forces": rng.normal(size=(7, 8, 3)).astype(np.float32),
        "landmarks": rng.normal(size=(7, 19, 3)).astype(np.float32),
    }
    message = motion_chunk_class().FromString(encode_chunk(arrays))
    np.testing.assert_array_equal(message.time, arrays["time"])
    np.testing.assert_array_equal(message.base_position, arrays["base_position"].ravel())
    np.testing.assert_array_equal(message.joint_positions, arrays["joint_positions"].ravel())
    assert list(message.contacts) == arrays["contacts"].ravel().tolist()
    # frame-major, then corner (landmark) major, then x, y, z
    np.testing.assert_array_equal(message.contact_forces, arrays["contact_forces"].ravel())
    assert message.contact_forces[3 * 8 + 3 + 2] == arrays["contact_forces"][1, 1, 2]
    np.testing.assert_array_equal(message.landmarks, arrays["landmarks"].ravel())
    assert len(message.thrust) == 0  # absent fields stay empty

    decoded = decode_chunk(message.SerializeToString())  # protobuf's own encoding, read by us
    for name, values in arrays.items():
        np.testing.assert_array_equal(decoded[name], values.ravel().astype(decoded[name].dtype))


def test_field_numbers_are_stable() -> None:
    """Numbers in files already written never change; new fields only add numbers."""
    numbers = {f.name: f.number for f in CHUNK_FIELDS}
    assert list(numbers.values()) == list(range(1, 13))
    assert numbers["contacts"] == 10 and numbers["contact_forces"] == 11
    assert numbers["landmarks"] == 12
    fields = motion_chunk_class().DESCRIPTOR.fields_by_name
    assert {name: fields[name].number for name in numbers} == numbers


def test_new_fields_skipped_by_an_older_decoder() -> None:
    """A reader that knows fields 1-10 only (protobuf's class of the old schema) reads a new
    chunk's old fields and keeps the new ones as unknown fields."""
    from google.protobuf import descriptor_pb2, descriptor_pool, message_factory

    arrays = {"time": np.arange(3) / 60.0, "contact_forces": np.ones((3, 8, 3), np.float32)}
    proto = descriptor_pb2.FileDescriptorProto(name="old.proto", package="old", syntax="proto3")
    message = proto.message_type.add(name="MotionChunk")
    for field in CHUNK_FIELDS[:10]:
        message.field.add(
            name=field.name, number=field.number, label=REPEATED, type=field.proto_type
        )
    pool = descriptor_pool.DescriptorPool()
    pool.Add(proto)
    old = message_factory.GetMessageClass(pool.FindMessageTypeByName("old.MotionChunk"))
    decoded = old.FromString(encode_chunk(arrays))
    np.testing.assert_array_equal(decoded.time, arrays["time"])
    assert decoded.SerializeToString() == encode_chunk(arrays)  # the forces kept, unknown


def test_frame_transforms_decode_with_foxglove_schemas() -> None:
    # stamps whose varints differ in length (0, 1, 2 and 5 bytes of nanoseconds, big seconds)
    seconds = np.array([0.0, 1e-9, 1.5, 300.999999999, 86400.25])
    poses = np.random.default_rng(1).normal(size=(5, 3, 7))
    parents, children = ["world", "a", "a"], ["a", "b", "c"]
    messages = encode_frame_transforms(seconds, parents, children, poses)
    for m, encoded in enumerate(messages):
        decoded = FrameTransforms.FromString(encoded)
        assert [t.parent_frame_id for t in decoded.transforms] == parents
        assert [t.child_frame_id for t in decoded.transforms] == children
        for k, transform in enumerate(decoded.transforms):
            stamp = transform.timestamp.seconds + transform.timestamp.nanos * 1e-9
            assert abs(stamp - seconds[m]) < 1e-9
            t, r = transform.translation, transform.rotation
            assert [t.x, t.y, t.z] == poses[m, k, :3].tolist()
            assert [r.w, r.x, r.y, r.z] == poses[m, k, 3:].tolist()


def test_tf_schema_holds_frame_transforms_and_its_imports() -> None:
    names = {f.name for f in descriptor_pb2.FileDescriptorSet.FromString(tf_schema()).file}
    assert {"foxglove/FrameTransforms.proto", "foxglove/FrameTransform.proto"} <= names
    assert "google/protobuf/timestamp.proto" in names
