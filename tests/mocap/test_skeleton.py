"""Rotations, forward kinematics by hand, Y-up -> Z-up, units, landmark approximations."""

from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from motionkit.mocap import LANDMARKS, MocapClip, Skeleton
from motionkit.mocap.skeleton import (
    UNITS,
    Y_UP_TO_Z_UP,
    axis_rotation,
    euler_matrix,
    forward_kinematics,
    y_up_euler,
)

S = np.sqrt(0.5)


def test_axis_rotations_by_hand() -> None:
    quarter = np.pi / 2
    np.testing.assert_allclose(axis_rotation("z", quarter) @ [1, 0, 0], [0, 1, 0], atol=1e-12)
    np.testing.assert_allclose(axis_rotation("x", quarter) @ [0, 1, 0], [0, 0, 1], atol=1e-12)
    np.testing.assert_allclose(axis_rotation("y", quarter) @ [0, 0, 1], [1, 0, 0], atol=1e-12)
    np.testing.assert_allclose(axis_rotation("y", np.pi / 4) @ [1, 0, 0], [S, 0, -S], atol=1e-12)


@pytest.mark.parametrize("axes", ["xyz", "zxy", "zyx", "yxz", "zx", "y"])
def test_euler_matrix_is_the_intrinsic_product(axes: str) -> None:
    angles = np.random.default_rng(1).uniform(-3, 3, (5, len(axes)))
    expected = Rotation.from_euler(axes.upper(), angles).as_matrix()
    np.testing.assert_allclose(euler_matrix(axes, angles), expected, atol=1e-12)
    product = np.eye(3)
    for axis, angle in zip(axes, angles[0], strict=True):
        product = product @ axis_rotation(axis, angle)
    np.testing.assert_allclose(euler_matrix(axes, angles)[0], product, atol=1e-12)


def test_y_up_to_z_up() -> None:
    a = Y_UP_TO_Z_UP
    np.testing.assert_allclose(a @ [0, 1, 0], [0, 0, 1])  # up stays up
    np.testing.assert_allclose(a @ [0, 0, 1], [0, -1, 0])  # Y-up forward (+z) -> -y
    np.testing.assert_allclose(a @ [1, 0, 0], [1, 0, 0])
    angles = np.array([[0.3, -1.1, 2.0]])
    for axes in ("zyx", "xzy", "yxz"):
        yup = euler_matrix(axes, angles)
        np.testing.assert_allclose(y_up_euler(axes, angles), a @ yup @ a.T, atol=1e-12)


def _chain_clip(rotations: np.ndarray, translations: np.ndarray | None = None) -> MocapClip:
    skeleton = Skeleton(
        ("root", "a", "b"), (-1, 0, 1), np.array([[0, 0, 0], [0, 0, -1.0], [1, 0, 0]])
    )
    frames = rotations.shape[0]
    root = np.tile([1.0, 2.0, 3.0], (frames, 1))
    return MocapClip(
        "chain", Path("chain"), "bvh", 100.0, skeleton, root, rotations, 1.0, False, translations
    )


def test_forward_kinematics_by_hand() -> None:
    rot = np.broadcast_to(np.eye(3), (3, 3, 3, 3)).copy()
    rot[1, 1] = axis_rotation("z", np.pi / 2)  # a turns: b's offset x -> y
    rot[2, 0] = axis_rotation("x", np.pi / 2)  # root turns: a's offset -z -> +y, b's x stays
    rot[2, 1] = axis_rotation("y", -np.pi / 2)  # then a turns x -> +z, seen from the root: +z -> -y
    pos = _chain_clip(rot).joint_positions()
    np.testing.assert_allclose(pos[0], [[1, 2, 3], [1, 2, 2], [2, 2, 2]], atol=1e-12)
    np.testing.assert_allclose(pos[1], [[1, 2, 3], [1, 2, 2], [1, 3, 2]], atol=1e-12)
    np.testing.assert_allclose(pos[2], [[1, 2, 3], [1, 3, 3], [1, 2, 3]], atol=1e-12)


def test_per_frame_translations_replace_offsets() -> None:
    rot = np.broadcast_to(np.eye(3), (2, 3, 3, 3)).copy()
    trans = np.zeros((2, 3, 3))
    trans[:, 1] = [[0, 0, -1], [0, 0, -2]]
    trans[:, 2] = [[1, 0, 0], [0.5, 0, 0]]
    pos = _chain_clip(rot, trans).joint_positions()
    np.testing.assert_allclose(pos[:, 2], [[2, 2, 2], [1.5, 2, 1]])


def test_fk_matches_a_loop_over_frames() -> None:
    rng = np.random.default_rng(3)
    parents = (-1, 0, 1, 1, 3)
    offsets = rng.normal(size=(5, 3))
    rotations = Rotation.random(40, random_state=4).as_matrix().reshape(8, 5, 3, 3)
    root = rng.normal(size=(8, 3))
    fast = forward_kinematics(parents, offsets, root, rotations)
    for t in range(8):
        world, pos = [rotations[t, 0]], [root[t]]
        for j in range(1, 5):
            p = parents[j]
            pos.append(pos[p] + world[p] @ offsets[j])
            world.append(world[p] @ rotations[t, j])
        np.testing.assert_allclose(fast[t], pos, atol=1e-12)


def test_skeleton_validates() -> None:
    with pytest.raises(ValueError, match="before"):
        Skeleton(("a", "b", "c"), (-1, 2, 0), np.zeros((3, 3)))
    with pytest.raises(ValueError, match="unique"):
        Skeleton(("a", "a"), (-1, 0), np.zeros((2, 3)))
    sk = Skeleton(("a", "b"), (-1, 0), np.array([[0, 0, 0], [0, 0, 2.0]]))
    assert sk.index("b") == 1 and len(sk) == 2
    np.testing.assert_allclose(sk.rest_positions(), [[0, 0, 0], [0, 0, 2]])


def test_units_table() -> None:
    assert UNITS["cmu"] == pytest.approx(0.05644, abs=1e-5)
    assert UNITS["inch"] == 0.0254 and UNITS["cm"] == 0.01 and UNITS["m"] == 1.0


def _torso_clip(names: tuple[str, ...], mapping: dict[str, str]) -> MocapClip:
    """Joints on a vertical line: pelvis z=1, neck z=1.6, shoulders +-0.2 at z=1.5."""
    place = {"pelvis": (0, 0, 1.0), "l_hip": (0.1, 0, 0.9), "r_hip": (-0.1, 0, 0.9),
             "neck": (0, 0, 1.6), "l_shoulder": (0.2, 0, 1.5), "r_shoulder": (-0.2, 0, 1.5),
             "spine": (0, 0, 1.2), "chest": (0, 0, 1.5)}  # fmt: skip
    by_joint = {mapping[k]: place.get(k, (0.0, 0.0, 0.5)) for k in mapping}
    offsets = np.array([by_joint.get(n, (0.0, 0.0, 0.0)) for n in names], dtype=float)
    rot = np.broadcast_to(np.eye(3), (1, len(names), 3, 3))
    sk = Skeleton(names, (-1,) + (0,) * (len(names) - 1), offsets)
    return MocapClip(
        "t", Path("t"), "bvh", 1.0, sk, np.zeros((1, 3)), rot, 1.0, False, None, mapping
    )


def test_absent_landmarks_are_approximated() -> None:
    required = [k for k in LANDMARKS if k not in ("pelvis", "spine", "chest", "neck")]
    names = ("root", *required)
    mapping = {k: k for k in required}
    marks = _torso_clip(names, mapping).landmarks()
    assert tuple(marks) == LANDMARKS
    np.testing.assert_allclose(marks["pelvis"][0], [0, 0, 0.9])  # hip midpoint
    np.testing.assert_allclose(marks["neck"][0], [0, 0, 1.5])  # shoulder midpoint
    np.testing.assert_allclose(marks["chest"][0], [0, 0, 0.9 + 0.6 * 2 / 3])
    np.testing.assert_allclose(marks["spine"][0], [0, 0, 0.9 + 0.6 / 3])
    with_spine = {**mapping, "pelvis": "p", "neck": "n", "spine": "s"}
    marks = _torso_clip(("root", *required, "p", "n", "s"), with_spine).landmarks()
    np.testing.assert_allclose(marks["chest"][0], [0, 0, (1.2 + 1.6) / 2])
    with_chest = {**mapping, "pelvis": "p", "neck": "n", "chest": "c"}
    marks = _torso_clip(("root", *required, "p", "n", "c"), with_chest).landmarks()
    np.testing.assert_allclose(marks["spine"][0], [0, 0, (1.0 + 1.5) / 2])
    marks["spine"][0] = 9.0  # landmarks are fresh arrays
