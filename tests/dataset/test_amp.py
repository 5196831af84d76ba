"""AMP features against hand-computed values on the toy biped; resampling; pairs; statistics."""

import numpy as np
import pytest

from motionkit.dataset import Metadata, Trajectory, amp_features, amp_pairs, feature_names, resample
from motionkit.dataset.amp import FeatureLayout, feature_stats

YAW_RATE, PITCH, HIP_SPEED = 0.5, 0.3, 0.5


def turning_walk(robot, seconds: float = 1.0, rate: float = 120.0, pitch: float = 0.0):
    """Base yawing at YAW_RATE (pitched by `pitch`), moving along world x at 1 m/s; the left hip
    at 0.2 + HIP_SPEED t; thrust 30 and 40 N."""
    t = np.arange(round(seconds * rate) + 1) / rate
    yaw = YAW_RATE * t
    # q = Rz(yaw) * Ry(pitch), as (w, x, y, z)
    cy, sy, cp, sp = np.cos(yaw / 2), np.sin(yaw / 2), np.cos(pitch / 2), np.sin(pitch / 2)
    quat = np.stack([cy * cp, -sy * sp, cy * sp, sy * cp], axis=1)
    joints = np.zeros((len(t), len(robot.joint_names)))
    velocities = np.zeros_like(joints)
    hip = robot.joint_names.index("l_hip")
    joints[:, hip], velocities[:, hip] = 0.2 + HIP_SPEED * t, HIP_SPEED
    return Trajectory(
        time=t,
        base_position=np.stack([t, 0 * t, 0.8 + 0 * t], axis=1),
        base_orientation=quat,
        joint_names=robot.joint_names,
        joint_positions=joints,
        joint_velocities=velocities,
        base_linear_velocity=np.tile([1.0, 0.0, 0.0], (len(t), 1)),
        base_angular_velocity=np.tile([0.0, 0.0, YAW_RATE], (len(t), 1)),
        thrust=np.tile([30.0, 40.0], (len(t), 1)),
        contacts=np.stack([t < 0.5, t >= 0.5], axis=1),
        jet_names=("a", "b"),
        foot_names=("left", "right"),
        metadata=Metadata("toy", "x", "walk", "synthetic"),
    )


def columns(robot, features: np.ndarray, prefix: str) -> np.ndarray:
    names = feature_names(robot)
    return features[:, [i for i, n in enumerate(names) if n.startswith(prefix)]]


def test_features_by_hand(toy_robot) -> None:
    trajectory = turning_walk(toy_robot)
    chi = amp_features(trajectory, toy_robot)
    t, q = trajectory.time, 0.2 + HIP_SPEED * trajectory.time
    yaw = YAW_RATE * t
    assert (
        chi.shape == (len(t), 4 + 3 + 3 + 7 + 7 + 9 + 2) == (len(t), len(feature_names(toy_robot)))
    )
    close = {"atol": 2e-6}
    # heading removed from a pure yaw: the identity
    np.testing.assert_allclose(
        columns(toy_robot, chi, "base_orientation"), [[1, 0, 0, 0]] * len(t), **close
    )
    # world (1, 0, 0) seen from a base yawed by `yaw`
    expected = np.stack([np.cos(yaw), -np.sin(yaw), 0 * t], axis=1)
    np.testing.assert_allclose(columns(toy_robot, chi, "base_linear_velocity"), expected, **close)
    np.testing.assert_allclose(
        columns(toy_robot, chi, "base_angular_velocity"), [[0, 0, YAW_RATE]] * len(t), **close
    )
    np.testing.assert_allclose(columns(toy_robot, chi, "joint_position.l_hip"), q[:, None], **close)
    np.testing.assert_allclose(columns(toy_robot, chi, "joint_velocity.l_hip"), HIP_SPEED, **close)
    # left sole 0.65 m below the hip (0, 0.1, -0.1) along the leg; right sole straight down;
    # the elbow 0.2 m below the shoulder (0, 0.15, 0.1)
    left = np.stack([-0.65 * np.sin(q), 0.1 + 0 * q, -0.1 - 0.65 * np.cos(q)], axis=1)
    np.testing.assert_allclose(columns(toy_robot, chi, "l_sole."), left, **close)
    np.testing.assert_allclose(
        columns(toy_robot, chi, "r_sole."), [[0, -0.1, -0.75]] * len(t), **close
    )
    np.testing.assert_allclose(
        columns(toy_robot, chi, "elbow."), [[0, 0.15, -0.1]] * len(t), **close
    )
    np.testing.assert_allclose(columns(toy_robot, chi, "thrust"), [[30, 40]] * len(t))


def test_heading_free_orientation_keeps_pitch(toy_robot) -> None:
    trajectory = turning_walk(toy_robot, pitch=PITCH)
    free = columns(toy_robot, amp_features(trajectory, toy_robot), "base_orientation")
    pitch_only = [np.cos(PITCH / 2), 0, np.sin(PITCH / 2), 0]
    np.testing.assert_allclose(free, [pitch_only] * trajectory.frames, atol=2e-6)
    world = amp_features(trajectory, toy_robot, heading_free=False)
    np.testing.assert_allclose(
        columns(toy_robot, world, "base_orientation"), trajectory.base_orientation, atol=1e-7
    )


def test_resample_is_exact_on_linear_and_constant_rate_motion(toy_robot) -> None:
    trajectory = turning_walk(toy_robot, seconds=1.0, rate=120.0)
    at_60 = resample(trajectory, 60.0)
    t = np.arange(61) / 60.0
    np.testing.assert_allclose(at_60.time, t, atol=1e-12)
    hip = toy_robot.joint_names.index("l_hip")
    np.testing.assert_allclose(at_60.joint_positions[:, hip], 0.2 + HIP_SPEED * t, atol=1e-6)
    yaw = YAW_RATE * t
    np.testing.assert_allclose(
        at_60.base_orientation,
        np.stack([np.cos(yaw / 2), 0 * t, 0 * t, np.sin(yaw / 2)], 1),
        atol=1e-6,
    )
    np.testing.assert_array_equal(at_60.contacts[:, 0], t < 0.5)
    # slerp between two frames a quarter turn apart lands halfway
    two = trajectory.select(np.array([0, 120]))
    mid = resample(two, 2.0).base_orientation[1]
    half = YAW_RATE * 0.25
    np.testing.assert_allclose(mid, [np.cos(half), 0, 0, np.sin(half)], atol=1e-6)


def test_pairs_weights_and_statistics(toy_robot) -> None:
    short, long = turning_walk(toy_robot, seconds=0.5), turning_walk(toy_robot, seconds=1.0)
    pairs = amp_pairs([short, long], toy_robot, rate=30.0, weights=[3.0, 1.0])
    assert len(pairs.current) == 15 + 30
    np.testing.assert_array_equal(pairs.current[1:15], pairs.following[:14])  # chi_t+1 of clip 0
    assert not np.array_equal(pairs.following[14], pairs.current[15])  # no pair across clips
    assert pairs.probability[pairs.clip == 0].sum() == pytest.approx(0.75)
    assert pairs.probability.sum() == pytest.approx(1.0)
    every = np.concatenate([amp_features(resample(c, 30.0), toy_robot) for c in (short, long)])
    np.testing.assert_allclose(pairs.stats.mean, every.mean(axis=0), atol=1e-6)
    np.testing.assert_allclose(pairs.stats.std, np.maximum(every.std(axis=0), 1e-3), atol=1e-6)
    normalized = pairs.stats.normalize(every)
    varying = every.std(axis=0) > 1e-3
    np.testing.assert_allclose(normalized[:, varying].std(axis=0), 1.0, atol=1e-4)
    stats = feature_stats([np.array([[1.0], [3.0]])])
    assert stats.mean.tolist() == [2.0] and stats.std.tolist() == [1.0]
    current, following = pairs.sample(np.random.default_rng(0), 8)
    assert current.shape == following.shape == (8, pairs.current.shape[1])


def test_layout_blocks_of_the_toy_biped(toy_robot) -> None:
    layout = FeatureLayout.of(toy_robot)
    sizes = [len(columns) for _, columns in layout.blocks]
    assert sizes == [4, 3, 3, 7, 7, 9, 2] and layout.size == 35
    assert layout.names == tuple(feature_names(toy_robot))
    assert layout.slice("joint_velocity") == slice(17, 24)
    assert layout.names[layout.slice("thrust")] == ("thrust.a", "thrust.b")
    chi = amp_features(turning_walk(toy_robot), toy_robot)
    np.testing.assert_array_equal(chi[:, layout.slice("thrust")], [[30, 40]] * len(chi))
    with pytest.raises(KeyError):
        layout.slice("heights")


def test_layout_join_orders_and_checks_the_blocks(toy_robot) -> None:
    layout = FeatureLayout.of(toy_robot)
    parts = {name: np.full((2, len(columns)), i) for i, (name, columns) in enumerate(layout.blocks)}
    chi = layout.join(dict(reversed(parts.items())))  # the layout's order, not the mapping's
    np.testing.assert_array_equal(chi[0], np.repeat(np.arange(7), [4, 3, 3, 7, 7, 9, 2]))
    with pytest.raises(ValueError, match="thrust has 3 columns, not 2"):
        layout.join({**parts, "thrust": np.zeros((2, 3))})
    with pytest.raises(ValueError, match="feature blocks"):
        layout.join({k: v for k, v in parts.items() if k != "thrust"})
