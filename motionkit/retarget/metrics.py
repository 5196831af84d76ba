"""Quality of a retargeted motion: sliding, penetration, limits, tracking, smoothness, clearance."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import asdict, dataclass, fields
from itertools import combinations
from typing import Any

import numpy as np

from motionkit.retarget.bodies import avoided, capsules, segment_distance
from motionkit.retarget.config import CleanWalk
from motionkit.retarget.points import Point
from motionkit.retarget.targets import SIDES, Targets
from motionkit.robot import Robot
from motionkit.robot.geometry import Array
from motionkit.robot.kinematics import frame_poses

PENETRATION_LIMIT = 0.005  # m: a frame with a sole corner deeper than this counts as sinking


@dataclass(frozen=True)
class Quality:
    """The figures of a retargeted clip that a batch's summary shows."""

    foot_slide_p95_m_s: float = 0.0
    source_slide_p95_m_s: float = 0.0
    penetration_max_m: float = 0.0
    joint_position_violations: int = 0
    joint_velocity_violations: int = 0
    feet_error_mean_m: float = 0.0
    knees_error_mean_m: float = 0.0
    closest_approach_m: float = 0.0
    closest_jet_or_arm_m: float = 0.0

    @classmethod
    def of(cls, metrics: Mapping[str, Any]) -> Quality:
        """The figures of a clip's metrics (`compute_metrics`' names, in the clip's metadata; 0
        where one is absent)."""
        kinds = {f.name: type(f.default) for f in fields(cls)}
        return cls(**{name: kind(metrics.get(name, 0)) for name, kind in kinds.items()})

    def beyond(self, clean: CleanWalk) -> list[str]:
        """Each figure above that of a clean walk, as 'name value > limit' (none for a clean
        clip)."""
        return [
            f"{name} {getattr(self, name):.4g} > {limit:.4g}"
            for name, limit in asdict(clean).items()
            if getattr(self, name) > limit
        ]


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

    # clearance between non-adjacent bodies: all of them, and the pairs the IK keeps apart
    shapes, adjacent = capsules(robot, points)
    ends = {c.name: (kin.point(c.start), kin.point(c.end)) for c in shapes}
    closest = {"all": (np.inf, ""), "avoided": (np.inf, "")}
    for a, b in combinations(shapes, 2):
        if frozenset((a.name, b.name)) in adjacent:
            continue
        distance = float(np.min(segment_distance(*ends[a.name], *ends[b.name])))
        distance -= a.radius + b.radius
        for group in ("all", "avoided") if avoided(a, b) else ("all",):
            if distance < closest[group][0]:
                closest[group] = (distance, f"{a.name}/{b.name}")
    metrics["closest_approach_m"], metrics["closest_pair"] = closest["all"]
    metrics["closest_jet_or_arm_m"], metrics["closest_jet_or_arm_pair"] = closest["avoided"]
    return metrics
