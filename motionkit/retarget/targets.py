"""From human landmarks to robot IK targets: scaling, ground, contacts, locked feet.

The human is scaled by the leg-length ratio (about the world origin) and lifted so that its
ankles in contact are at the robot's ankle height (`Targets.human`, written into the clip as its
landmarks); then rebuilt with the robot's segment lengths: the pelvis follows the scaled hip
midpoint; knees and ankles lie along the human's thigh and shank directions at the robot's thigh
and shank lengths. A human foot is in contact while the lower of its ankle and toe is near where
that landmark stands (its lowest nearby: floors are not quite level) and the slower of the two is
nearly still, with hysteresis (`detect_contacts`). During a contact the sole target is flat on the
ground (z = 0) and locked where the contact began (the IK holds it there, motionkit/retarget/
tasks.py); over `release_time` before it the target closes in on the lock, and after it blends
back to the free pose, both along smoothsteps (`lock_offsets`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.spatial.transform import Rotation

from motionkit.core.errors import RetargetError
from motionkit.core.filters import low_pass
from motionkit.retarget.config import RetargetConfig
from motionkit.retarget.points import Point
from motionkit.robot import Robot
from motionkit.robot.geometry import Array

SIDES = ("l", "r")
NEEDED = (
    "l_hip", "l_knee", "l_ankle", "l_toe", "r_hip", "r_knee", "r_ankle", "r_toe",
    "spine", "neck", "l_shoulder", "l_elbow", "r_shoulder", "r_elbow",
)  # fmt: skip


@dataclass(frozen=True)
class Targets:
    """Per-frame IK targets (world frame, robot scale) and what they were made from."""

    time: Array  # (T,)
    scale: float  # robot leg length / human leg length
    contacts: np.ndarray  # (T, 2) bool, left and right
    root: Array  # (T, 4, 4) pose of the robot's root link
    torso: Array  # (T, 3, 3) orientation of the torso frame
    soles: Array  # (T, 2, 4, 4) sole poses
    hold: Array  # (T, 2) 1 in contact, fading to 0 over release_time after it, else 0
    knees: Array  # (T, 2, 3)
    upper_arms: Array  # (T, 2, 3) unit directions shoulder -> elbow
    upper_arm_length: Array  # (2,) robot shoulder-elbow distance [m]
    source_slide: Array  # (n,) human foot horizontal speed in contact frames [m/s]
    human: dict[str, Array]  # (T, 3) each: the low-passed landmarks, scaled and lifted like root


def slowed(targets: Targets, factor: float) -> Targets:
    """The targets performed `factor` times slower (the same frames, further apart)."""
    return replace(targets, time=targets.time * factor, source_slide=targets.source_slide / factor)


def _unit(vectors: Array) -> Array:
    return vectors / np.maximum(np.linalg.norm(vectors, axis=-1, keepdims=True), 1e-9)


def body_frames(left: Array, up: Array) -> Array:
    """(T, 3, 3) rotations with columns forward, left, up from left and approximate up axes."""
    left = _unit(left)
    forward = _unit(np.cross(left, up))
    return np.stack([forward, left, np.cross(forward, left)], axis=-1)


def _runs(mask: Array) -> list[tuple[int, int]]:
    """[start, stop) of the runs of True."""
    edges = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1), strict=True))


def clean_runs(mask: Array, shortest: int) -> Array:
    """Fill gaps and then drop runs shorter than `shortest` frames."""
    out = mask.copy()
    for start, stop in _runs(~out):
        if 0 < start and stop < len(out) and stop - start < shortest:
            out[start:stop] = True
    for start, stop in _runs(out):
        if stop - start < shortest:
            out[start:stop] = False
    return out


def standing_height(heights: Array, lowest: float, rate: float, config: RetargetConfig) -> Array:
    """(T,) the height [m] a foot landmark has when its foot is down, near each frame: its
    lowest within ground_window [s] either side (a floor that is not level, a marker that
    drifts), but at most ground_range above `lowest`, the landmark's lowest on either foot (a
    foot held up for long)."""
    from scipy.ndimage import minimum_filter1d

    size = 2 * max(1, round(config.ground_window * rate)) + 1
    local = minimum_filter1d(heights, size, mode="nearest")
    return np.minimum(local, lowest + config.ground_range)


def foot_clearance(
    ankle: Array, toe: Array, lowest: tuple[float, float], rate: float, config: RetargetConfig
) -> Array:
    """(T,) how high the foot's lower end is above where it stands [m]: the smaller of the
    ankle's and the toe's heights above their standing heights (a foot rolling on its heel or
    its ball keeps one of them there; both rise when it leaves the ground). `lowest`: the
    lowest ankle and toe heights on either foot."""
    return np.minimum(
        ankle[:, 2] - standing_height(ankle[:, 2], lowest[0], rate, config),
        toe[:, 2] - standing_height(toe[:, 2], lowest[1], rate, config),
    )


def pivot_speed(ankle: Array, toe: Array, time: Array) -> Array:
    """(T,) the speed [m/s] of the slower of ankle and toe, vertical motion included: the one
    the foot turns about when it rolls on the ground; in the air both move."""
    return np.minimum(
        np.linalg.norm(np.gradient(ankle, time, axis=0), axis=1),
        np.linalg.norm(np.gradient(toe, time, axis=0), axis=1),
    )


def hysteresis(enter: Array, stay: Array) -> Array:
    """True from a frame where `enter` holds for as long as `stay` holds (`enter` implies
    `stay`)."""
    out = np.zeros(len(enter), dtype=bool)
    for start, stop in _runs(stay):
        hits = np.flatnonzero(enter[start:stop])
        if hits.size:
            out[start + hits[0] : stop] = True
    return out


def detect_contacts(
    ankle: Array,
    toe: Array,
    time: Array,
    config: RetargetConfig,
    lowest: tuple[float, float] | None = None,
) -> Array:
    """(T,) bool: the foot is on the ground. It lands when its lower end comes within
    contact_height of where it stands and its pivot is slower than contact_speed; it stays down
    until either passes contact_hysteresis times its threshold. Runs and gaps shorter than
    min_run are removed. `lowest`: the lowest ankle and toe heights on either foot (default:
    this foot's)."""
    rate = 1.0 / float(np.median(np.diff(time)))
    if lowest is None:
        lowest = (float(ankle[:, 2].min()), float(toe[:, 2].min()))
    clearance = foot_clearance(ankle, toe, lowest, rate, config)
    speed = pivot_speed(ankle, toe, time)
    enter = (clearance < config.contact_height) & (speed < config.contact_speed)
    factor = config.contact_hysteresis
    stay = (clearance < factor * config.contact_height) & (speed < factor * config.contact_speed)
    return clean_runs(hysteresis(enter, stay), max(1, round(config.min_run * rate)))


class RobotGeometry:
    """What the targets need of the robot, at its zero pose, in the root frame."""

    def __init__(self, robot: Robot, points: dict[str, Point], torso_frame: str) -> None:
        poses = robot.model.link_poses()
        robot.model.require_frames([torso_frame], "the retargeting torso frame")

        def at(name: str) -> Array:
            point = points[name]
            return (poses[point.link] @ np.append(point.offset, 1.0))[:3]

        self.hip = np.array([at(f"{s}_hip") for s in SIDES])
        self.thigh = np.array([np.linalg.norm(at(f"{s}_knee") - at(f"{s}_hip")) for s in SIDES])
        self.shank = np.array([np.linalg.norm(at(f"{s}_ankle") - at(f"{s}_knee")) for s in SIDES])
        self.upper_arm = np.array(
            [np.linalg.norm(at(f"{s}_elbow") - at(f"{s}_shoulder")) for s in SIDES]
        )
        forward = np.asarray(robot.spec.forward, dtype=float)
        up = np.array([0.0, 0.0, 1.0])
        # columns: the robot's forward, left and up axes in its root frame
        self.align = np.stack([forward, np.cross(up, forward), up], axis=1)
        self.torso = poses[torso_frame][:3, :3]
        soles = [poses[foot.sole] for foot in robot.spec.feet]
        self.sole_rotation = np.array([pose[:3, :3] for pose in soles])
        self.ankle_to_sole = np.array(
            [
                pose[:3, :3].T @ (pose[:3, 3] - at(f"{s}_ankle"))
                for pose, s in zip(soles, SIDES, strict=True)
            ]
        )
        self.corners = np.array(
            [
                [(np.linalg.inv(pose) @ poses[c])[:3, 3] for c in foot.corners]
                for pose, foot in zip(soles, robot.spec.feet, strict=True)
            ]
        )

    @property
    def ankle_height(self) -> float:
        """Height of the ankle point above the sole [m]."""
        return float(-np.mean(self.ankle_to_sole[:, 2]))

    @property
    def leg_length(self) -> float:
        return float(np.mean(self.thigh + self.shank))


def make_targets(
    landmarks: dict[str, Array], rate: float, geometry: RobotGeometry, config: RetargetConfig
) -> Targets:
    missing = [name for name in NEEDED if name not in landmarks]
    if missing:
        raise RetargetError(f"the human motion lacks landmarks {missing}")
    h = {name: np.asarray(values, dtype=float) for name, values in landmarks.items()}
    frames = len(h["l_hip"])
    if frames < 2:
        raise RetargetError("the human motion has fewer than 2 frames")
    if config.smoothing_hz > 0:
        h = {name: low_pass(values, rate, config.smoothing_hz) for name, values in h.items()}
    time = np.arange(frames) / rate

    thighs = [np.linalg.norm(h[f"{s}_knee"] - h[f"{s}_hip"], axis=1) for s in SIDES]
    shanks = [np.linalg.norm(h[f"{s}_ankle"] - h[f"{s}_knee"], axis=1) for s in SIDES]
    human_leg = float(np.median(np.concatenate(thighs) + np.concatenate(shanks)))
    scale = geometry.leg_length / human_leg

    # ground and contacts, at human scale
    low = np.stack([np.minimum(h[f"{s}_ankle"][:, 2], h[f"{s}_toe"][:, 2]) for s in SIDES], 1)
    ground = float(np.percentile(low.min(axis=1), 2))
    ankles, toes = ([h[f"{s}_{part}"][:, 2].min() for s in SIDES] for part in ("ankle", "toe"))
    lowest = (float(min(ankles)), float(min(toes)))
    contacts = np.stack(
        [detect_contacts(h[f"{s}_ankle"], h[f"{s}_toe"], time, config, lowest) for s in SIDES],
        axis=1,
    )
    middle = [0.5 * (h[f"{s}_ankle"] + h[f"{s}_toe"]) for s in SIDES]
    speed = np.stack(
        [np.linalg.norm(np.gradient(m[:, :2], time, axis=0), axis=1) for m in middle], 1
    )

    # root and torso orientation from the human's pelvis and chest frames
    pelvis = body_frames(h["l_hip"] - h["r_hip"], h["spine"] - 0.5 * (h["l_hip"] + h["r_hip"]))
    chest = body_frames(h["l_shoulder"] - h["r_shoulder"], h["neck"] - h["spine"])
    root_rotation = pelvis @ geometry.align.T
    torso = chest @ geometry.align.T @ geometry.torso
    # heights: the human's ankle height in contact maps to the robot's ankle height
    ankle_heights = np.concatenate(
        [h[f"{s}_ankle"][contacts[:, k], 2] for k, s in enumerate(SIDES)]
    )
    human_ankle = float(np.median(ankle_heights)) - ground if ankle_heights.size else 0.0
    lift = geometry.ankle_height - scale * (ground + human_ankle)
    human = {name: scale * values + [0.0, 0.0, lift] for name, values in h.items()}
    hips_middle = 0.5 * (human["l_hip"] + human["r_hip"])
    root = np.broadcast_to(np.eye(4), (frames, 4, 4)).copy()
    root[:, :3, :3] = root_rotation
    root[:, :3, 3] = hips_middle - root_rotation @ geometry.hip.mean(axis=0)

    knees, soles = np.empty((frames, 2, 3)), np.empty((frames, 2, 4, 4))
    hold = np.zeros((frames, 2))
    for k, s in enumerate(SIDES):
        hip = root[:, :3, 3] + root_rotation @ geometry.hip[k]
        knees[:, k] = hip + geometry.thigh[k] * _unit(h[f"{s}_knee"] - h[f"{s}_hip"])
        ankle = knees[:, k] + geometry.shank[k] * _unit(h[f"{s}_ankle"] - h[f"{s}_knee"])
        soles[:, k], hold[:, k] = _sole_targets(
            ankle,
            h[f"{s}_toe"] - h[f"{s}_ankle"],
            h[f"{s}_knee"] - h[f"{s}_ankle"],
            contacts[:, k],
            k,
            geometry,
            config,
            rate,
        )
    # upper arms turned outward about the chest's forward axis (keeps the arm jets off the body)
    arms = np.stack(
        [
            Rotation.from_rotvec(chest[:, :, 0] * sign * config.arm_abduction).apply(
                _unit(h[f"{s}_elbow"] - h[f"{s}_shoulder"])
            )
            for s, sign in zip(SIDES, (1.0, -1.0), strict=True)
        ],
        axis=1,
    )
    return Targets(
        time=time,
        scale=scale,
        contacts=contacts,
        root=root,
        torso=torso,
        soles=soles,
        hold=hold,
        knees=knees,
        upper_arms=arms,
        upper_arm_length=geometry.upper_arm,
        source_slide=speed[contacts],
        human=human,
    )


def smoothstep(u: Array) -> Array:
    """3 u^2 - 2 u^3 of u clipped to [0, 1]: 0 to 1 with zero slope at both ends."""
    u = np.clip(u, 0.0, 1.0)
    return u * u * (3.0 - 2.0 * u)


def lock_offsets(planar: Array, contact: Array, window: int) -> tuple[Array, Array, Array]:
    """Offsets (T, 3) of x, y and yaw that take the free sole `planar` (T, 3) onto the contact
    locks, the weight (T,) of the lock against the human's height and tilt, and the hold
    weight (T,) of the IK's landing correction.

    A contact's lock is the sole where the contact began. In the contact the offset holds the
    sole there; over `window` frames before it the sole closes in on it (the offset's weight
    rising from 0 to 1), so that a foot that lands moving stops over its lock rather than
    skidding into it; over `window` frames after it the offset the lock had last is carried
    out as the weight falls. The weights rise and fall as smoothsteps (3 u^2 - 2 u^3 of the
    share u of the window gone by), flat at both ends: a sole arrives at its lock, and leaves
    it, at the lock's (zero) speed. Where two contacts' windows overlap, their weights share
    1."""
    frames = len(planar)
    runs = _runs(contact)
    offset, total = np.zeros((frames, 3)), np.zeros(frames)
    keep, hold = contact.astype(float), contact.astype(float)
    index = np.arange(frames)
    for n, (start, stop) in enumerate(runs):
        lock = planar[start]
        offset[start:stop] = lock - planar[start:stop]
        total[start:stop] = 1.0
        before = slice(max(runs[n - 1][1] if n else 0, start - window), start)
        rising = smoothstep(1.0 - (start - index[before]) / window)
        offset[before] += rising[:, None] * (lock - planar[before])
        after = slice(stop, min(runs[n + 1][0] if n + 1 < len(runs) else frames, stop + window))
        falling = smoothstep(1.0 - (index[after] - stop + 1) / window)
        offset[after] += falling[:, None] * (lock - planar[stop - 1])
        hold[after] = falling
        for part, weight in ((before, rising), (after, falling)):
            total[part] += weight
            keep[part] = np.maximum(keep[part], weight)
    share = np.maximum(total, 1.0)
    return offset / share[:, None], keep, hold / share


def _sole_targets(
    ankle: Array,
    foot: Array,
    shank: Array,
    contact: Array,
    side: int,
    geometry: RobotGeometry,
    config: RetargetConfig,
    rate: float,
) -> tuple[Array, Array]:
    """Sole poses (T, 4, 4) and hold weights (T,): the free pose from the rebuilt ankle and the
    human foot frame (forward along the foot, left along the ankle's pitch axis, which stays
    defined when the foot points down at toe-off); flat and locked on the ground in contact;
    blended around contacts. The hold weight says how much of the landing correction applies."""
    frames = len(ankle)
    left = _unit(np.cross(shank, foot))
    frame = body_frames(left, np.cross(_unit(foot), left))
    yaw = np.unwrap(np.arctan2(-left[:, 0], left[:, 1]))
    heading = Rotation.from_euler("Z", yaw[:, None])
    tilt = heading.inv() * Rotation.from_matrix(frame)  # pitch and roll relative to the heading
    forward = tilt.apply([1.0, 0.0, 0.0])
    pitch = np.arctan2(-forward[:, 2], forward[:, 0])
    neutral = Rotation.from_euler("Y", float(np.median(pitch[contact] if contact.any() else pitch)))
    tilt = tilt * neutral.inv()
    align = Rotation.from_matrix(geometry.align.T @ geometry.sole_rotation[side])
    position = ankle + (heading * tilt * align).apply(geometry.ankle_to_sole[side])
    window = max(1, round(config.release_time * rate))
    planar = np.column_stack([position[:, :2], yaw])
    offset, keep, hold = lock_offsets(planar, contact, window)
    free = 1.0 - keep  # weight of the human's height and tilt
    partial_tilt = Rotation.from_rotvec(tilt.as_rotvec() * free[:, None])
    turn = Rotation.from_euler("Z", (yaw + offset[:, 2])[:, None])
    rotation = (turn * partial_tilt * align).as_matrix()
    sole = np.broadcast_to(np.eye(4), (frames, 4, 4)).copy()
    sole[:, :3, :3] = rotation
    sole[:, :2, 3] = position[:, :2] + offset[:, :2]
    sole[:, 2, 3] = free * position[:, 2]
    # no corner below the ground, nor below the clearance of a swinging sole
    lowest = np.min(np.einsum("tij,cj->tci", rotation, geometry.corners[side])[..., 2], axis=1)
    sole[:, 2, 3] = np.maximum(sole[:, 2, 3], free * config.swing_clearance - lowest)
    return sole, hold
