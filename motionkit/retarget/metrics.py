"""Quality of a retargeted motion: sliding, penetration, limits, tracking, smoothness, clearance."""

from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations

import numpy as np

from motionkit.retarget.points import Point
from motionkit.retarget.targets import SIDES, Targets
from motionkit.robot import Robot
from motionkit.robot.geometry import Array
from motionkit.robot.kinematics import frame_poses
from motionkit.robot.mk1_1 import JET_LENGTH, JET_RADIUS

PENETRATION_LIMIT = 0.005  # m: a frame with a sole corner deeper than this counts as sinking


@dataclass(frozen=True)
class Capsule:
    name: str
    start: Point
    end: Point
    radius: float  # m


class Kinematics:
    """World positions of points fixed in links, over a whole motion."""

    def __init__(self, robot: Robot, base: Array, joints: Array) -> None:
        self.robot, self.base, self.joints = robot, base, joints
        self._poses: dict[str, Array] = {}

    def pose(self, link: str) -> Array:
        if link not in self._poses:
            local = frame_poses(self.robot.model, self.robot.joint_names, self.joints, [link])
            self._poses[link] = self.base @ local[:, 0]
        return self._poses[link]

    def point(self, point: Point) -> Array:
        pose = self.pose(point.link)
        return pose[:, :3, :3] @ point.offset + pose[:, :3, 3]


def capsules(robot: Robot, points: dict[str, Point]) -> tuple[list[Capsule], set[frozenset]]:
    """Limb, foot and jet capsules (radii are rough sizes of iCub's links and the P250), and
    the pairs that share a joint or a mounting (they may touch by design)."""
    shapes, adjacent = [], set()
    poses = robot.model.link_poses()
    hands = dict(zip(robot.spec.hands, SIDES, strict=False))
    for k, side in enumerate(SIDES):
        foot = robot.spec.feet[k]
        sole = np.linalg.inv(poses[foot.sole])
        local = np.array([(sole @ poses[c])[:3, 3] for c in foot.corners])
        shapes += [
            Capsule(f"{side}_thigh", points[f"{side}_hip"], points[f"{side}_knee"], 0.06),
            Capsule(f"{side}_shank", points[f"{side}_knee"], points[f"{side}_ankle"], 0.05),
            Capsule(
                f"{side}_foot",
                Point(foot.sole, local[:2].mean(axis=0)),
                Point(foot.sole, local[2:].mean(axis=0)),
                0.03,
            ),
            Capsule(f"{side}_upper_arm", points[f"{side}_shoulder"], points[f"{side}_elbow"], 0.04),
        ]
        adjacent |= {
            frozenset((f"{side}_thigh", f"{side}_shank")),
            frozenset((f"{side}_shank", f"{side}_foot")),
        }
    for jet in robot.spec.jets:
        top = Point(jet.frame, np.array([0.0, 0.0, -JET_LENGTH]))
        shapes.append(Capsule(f"jet_{jet.name}", Point(jet.frame, np.zeros(3)), top, JET_RADIUS))
        if jet.frame in hands:
            adjacent.add(frozenset((f"jet_{jet.name}", f"{hands[jet.frame]}_upper_arm")))
    return shapes, adjacent


def segment_distance(p0: Array, p1: Array, q0: Array, q1: Array) -> Array:
    """Distance between segments p0-p1 and q0-q1, vectorised over the leading axis."""
    u, v, w = p1 - p0, q1 - q0, p0 - q0
    a, b, c = (u * u).sum(-1), (u * v).sum(-1), (v * v).sum(-1)
    d, e = (u * w).sum(-1), (v * w).sum(-1)
    denominator = np.maximum(a * c - b * b, 1e-12)
    s = np.clip((b * e - c * d) / denominator, 0.0, 1.0)
    t = np.clip((b * s + e) / np.maximum(c, 1e-12), 0.0, 1.0)
    s = np.clip((b * t - d) / np.maximum(a, 1e-12), 0.0, 1.0)
    return np.linalg.norm(w + s[:, None] * u - t[:, None] * v, axis=-1)


def compute_metrics(
    robot: Robot,
    targets: Targets,
    points: dict[str, Point],
    base: Array,
    joints: Array,
) -> dict[str, float | str | int]:
    kin = Kinematics(robot, base, joints)
    time = targets.time
    metrics: dict[str, float | str | int] = {"frames": len(time)}

    # sole corners: sliding during contact, penetration
    slide, lowest = [], []
    for k, foot in enumerate(robot.spec.feet):
        corners = np.stack([kin.pose(c)[:, :3, 3] for c in foot.corners], axis=1)
        # between consecutive frames that are both in contact
        step = np.linalg.norm(np.diff(corners[..., :2], axis=0), axis=-1)
        speed = step / np.diff(time)[:, None]
        both = targets.contacts[1:, k] & targets.contacts[:-1, k]
        slide.append(speed[both].ravel())
        lowest.append(corners[..., 2].min(axis=1))
    slide_all = np.concatenate(slide)
    depth = -np.minimum(np.min(lowest, axis=0), 0.0)
    metrics |= {
        "contact_share": float(targets.contacts.mean()),
        "foot_slide_mean_m_s": float(slide_all.mean()) if slide_all.size else 0.0,
        "foot_slide_p95_m_s": float(np.percentile(slide_all, 95)) if slide_all.size else 0.0,
        "source_slide_p95_m_s": float(np.percentile(targets.source_slide, 95))
        if targets.source_slide.size
        else 0.0,
        "penetration_max_m": float(depth.max()),
        "penetration_share": float((depth > PENETRATION_LIMIT).mean()),
    }

    # limits
    limits = robot.limits
    rate = 1.0 / float(np.median(np.diff(time)))
    velocity = np.gradient(joints, time, axis=0)
    metrics |= {
        "joint_position_violations": int(
            ((joints < limits.lower - 1e-6) | (joints > limits.upper + 1e-6)).sum()
        ),
        "joint_velocity_violations": int((np.abs(velocity) > limits.velocity * 1.001).sum()),
        "max_joint_speed_rad_s": float(np.abs(velocity).max()),
    }

    # tracking of the scaled human
    for name, actual, wanted in (
        ("feet", [kin.pose(f.sole)[:, :3, 3] for f in robot.spec.feet], targets.soles[..., :3, 3]),
        ("knees", [kin.point(points[f"{s}_knee"]) for s in SIDES], targets.knees),
    ):
        error = np.linalg.norm(np.stack(actual, axis=1) - wanted, axis=-1)
        metrics[f"{name}_error_mean_m"] = float(error.mean())
        metrics[f"{name}_error_max_m"] = float(error.max())
    arms = []
    for k, s in enumerate(SIDES):
        shoulder, elbow = kin.point(points[f"{s}_shoulder"]), kin.point(points[f"{s}_elbow"])
        wanted = shoulder + targets.upper_arm_length[k] * targets.upper_arms[:, k]
        arms.append(np.linalg.norm(elbow - wanted, axis=-1))
    metrics["elbows_error_mean_m"] = float(np.mean(arms))
    metrics["elbows_error_max_m"] = float(np.max(arms))

    # smoothness
    acceleration = np.diff(joints, 2, axis=0) * rate**2
    metrics["joint_acceleration_rms_rad_s2"] = float(np.sqrt(np.mean(acceleration**2)))
    metrics["largest_joint_step_rad"] = float(np.abs(np.diff(joints, axis=0)).max())

    # clearance between non-adjacent bodies
    shapes, adjacent = capsules(robot, points)
    ends = {c.name: (kin.point(c.start), kin.point(c.end)) for c in shapes}
    closest, pair = np.inf, ""
    for a, b in combinations(shapes, 2):
        if frozenset((a.name, b.name)) in adjacent:
            continue
        distance = segment_distance(*ends[a.name], *ends[b.name]) - a.radius - b.radius
        if distance.min() < closest:
            closest, pair = float(distance.min()), f"{a.name}/{b.name}"
    metrics["closest_approach_m"] = closest
    metrics["closest_pair"] = pair
    return metrics
