"""Rigid transforms as 4x4 homogeneous matrices; URDF roll-pitch-yaw; quaternions (w, x, y, z).

Quaternion order everywhere in motionkit is scalar first: (w, x, y, z), as in MuJoCo.
"""

import warnings

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

Array = NDArray[np.float64]


def rpy_to_matrix(rpy: Array) -> Array:
    """URDF rpy: fixed-axis rotations about x, then y, then z (R = Rz Ry Rx)."""
    return Rotation.from_euler("xyz", rpy).as_matrix()


def matrix_to_rpy(rotation: Array) -> Array:
    with warnings.catch_warnings():  # at pitch +-90 deg scipy picks yaw 0: still the same rotation
        warnings.simplefilter("ignore", UserWarning)
        return Rotation.from_matrix(rotation).as_euler("xyz")


def matrix_to_quat(rotation: Array) -> Array:
    """Rotation matrix to a unit quaternion (w, x, y, z) with w >= 0."""
    x, y, z, w = Rotation.from_matrix(rotation).as_quat()
    quat = np.array([w, x, y, z])
    return quat if w >= 0 else -quat


def make_transform(xyz: Array | None = None, rpy: Array | None = None) -> Array:
    transform = np.eye(4)
    if rpy is not None:
        transform[:3, :3] = rpy_to_matrix(np.asarray(rpy, dtype=float))
    if xyz is not None:
        transform[:3, 3] = xyz
    return transform


def invert(transform: Array) -> Array:
    inverse = np.eye(4)
    inverse[:3, :3] = transform[:3, :3].T
    inverse[:3, 3] = -transform[:3, :3].T @ transform[:3, 3]
    return inverse


def axis_angle(axis: Array, angle: float) -> Array:
    """Homogeneous rotation about a unit axis through the origin."""
    transform = np.eye(4)
    transform[:3, :3] = Rotation.from_rotvec(np.asarray(axis) * angle).as_matrix()
    return transform


# -- quaternion arrays (..., 4) in (w, x, y, z) order ------------------------------------------
def to_rotation(quats: Array) -> Rotation:
    """scipy Rotation from (N, 4) quaternions in (w, x, y, z) order."""
    return Rotation.from_quat(np.asarray(quats, dtype=float)[..., [1, 2, 3, 0]])


def from_rotation(rotation: Rotation) -> Array:
    """(N, 4) quaternions (w, x, y, z) with w >= 0 from a scipy Rotation."""
    quats = rotation.as_quat()[..., [3, 0, 1, 2]]
    return np.where(quats[..., :1] < 0, -quats, quats)


def quat_rotate_inverse(quats: Array, vectors: Array) -> Array:
    """World vectors (N, 3) expressed in the frames whose orientations are quats (N, 4)."""
    return to_rotation(quats).inv().apply(vectors)


def angular_velocity(time: Array, quats: Array) -> Array:
    """World-frame angular velocity (N, 3) of an orientation track by central differences of
    the relative rotations (one-sided at the ends)."""
    rotation = to_rotation(quats)
    steps = (rotation[1:] * rotation[:-1].inv()).as_rotvec() / np.diff(time)[:, None]
    omega = np.empty((len(time), 3))
    omega[0], omega[-1] = steps[0], steps[-1]
    omega[1:-1] = 0.5 * (steps[1:] + steps[:-1])
    return omega
