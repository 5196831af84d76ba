"""Our numpy protobuf codecs against the protobuf library (an independent implementation)."""

import numpy as np
from foxglove_schemas_protobuf.FrameTransforms_pb2 import FrameTransforms
from google.protobuf import descriptor_pb2

from motionkit.dataset.messages import (
    decode_chunk,
    encode_chunk,
    encode_frame_transforms,
    motion_chunk_class,
    tf_schema,
)


def test_chunk_bytes_decode_with_protobuf_and_back() -> None:
    """motion_chunk_class is protobuf's own class, built from the schema we embed in files."""
    rng = np.random.default_rng(0)
    arrays = {
        "time": np.arange(7) / 120.0,
        "base_position": rng.normal(size=(7, 3)).astype(np.float32),
        "joint_positions": rng.normal(size=(7, 23)).astype(np.float32),
        "contacts": rng.integers(0, 2, (7, 2)).astype(bool),
    }
    message = motion_chunk_class().FromString(encode_chunk(arrays))
    np.testing.assert_array_equal(message.time, arrays["time"])
    np.testing.assert_array_equal(message.base_position, arrays["base_position"].ravel())
    np.testing.assert_array_equal(message.joint_positions, arrays["joint_positions"].ravel())
    assert list(message.contacts) == arrays["contacts"].ravel().tolist()
    assert len(message.thrust) == 0  # absent fields stay empty

    decoded = decode_chunk(message.SerializeToString())  # protobuf's own encoding, read by us
    for name, values in arrays.items():
        np.testing.assert_array_equal(decoded[name], values.ravel().astype(decoded[name].dtype))


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
