"""Synthetic human gaits for the retargeting tests, written as CMU-style BVH files.

A gait is a list of stances per foot and a height plan for the pelvis. In a stance the foot
rolls onto the ground about its heel (landing pitch < 0) or its ball (> 0), stays flat, then
rolls over the ball before lift-off; a foot that lands moving still slides `skid` metres. A
swing goes from one stance to the next with a lift of `lift` metres; a stance with a height is a
foot held in the air. The pelvis is above the middle of the feet (low-passed) at the planned
height (hops: ballistic flights), lowered where a leg could not reach its ankle. Joint rotations
are built from these positions (CMU BVH joint names, centimetres, 120 Hz), so the file read back
gives them again; the plan is the hand-known truth of the contacts.

    path = write_gait(tmp_path, "hop")        # tmp_path/gait_hop.bvh, readable by load_mocap
    gait = GAITS["hop"]()                     # the plan: stances, flights, on_ground()
    python tests/retarget/gaits.py FOLDER     # every gait into FOLDER (for `motionkit retarget`)

Units: metres, seconds, radians; Z up, walking along +x.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from itertools import pairwise
from pathlib import Path

import numpy as np
from scipy.signal import butter, sosfiltfilt
from scipy.spatial.transform import Rotation

from motionkit.mocap.skeleton import MocapClip, Skeleton
from motionkit.mocap.writers import write_bvh

RATE = 120.0
THIGH, SHANK, HIP_Y, ANKLE_HEIGHT = 0.42, 0.42, 0.09, 0.08
REACH = 0.985 * (THIGH + SHANK)  # the farthest a hip gets from its ankle (knees never locked)
BALL = np.array([0.15, 0.0, -0.05])  # the toe landmark (ball of the foot) from the ankle
HEEL_SOLE = np.array([-0.05, 0.0, -ANKLE_HEIGHT])  # sole points the foot rolls about
BALL_SOLE = np.array([0.15, 0.0, -ANKLE_HEIGHT])
SKID_TIME = 0.1  # s: a foot that lands moving stops over this time
STAND = 0.90  # m: pelvis height of a person standing
GRAVITY = 9.81
Value = np.ndarray | float


@dataclass(frozen=True)
class Stance:
    """One foot on the ground (or held `height` above it) from `start` to `stop` [s], its ankle
    at (x, y) when flat."""

    start: float
    stop: float
    x: float
    y: float
    yaw: float = 0.0
    land: float = 0.0  # foot pitch at touchdown [rad]: < 0 heel first (toe up), > 0 toe first
    push: float = 0.3  # foot pitch at lift-off, rolled over the ball [rad]
    roll: float = 0.08  # s of rolling in after touchdown and out before lift-off
    skid: float = 0.0  # m slid forward after touchdown (the foot lands moving)
    lift: float = 0.1  # m: height of the swing that arrives at this stance
    rise: float = 0.2  # s: the swing's lift-up (and let-down) time
    height: float = 0.0  # m: > 0, a foot held in the air there (the free leg of a hop)
    point: float = 0.0  # rad of foot pitch throughout (a held foot pointing its toe)


@dataclass(frozen=True)
class Gait:
    name: str
    duration: float
    feet: tuple[tuple[Stance, ...], tuple[Stance, ...]]  # left, right
    pelvis: tuple[tuple[float, float, float], ...]  # (time, height, vertical speed) knots
    lean: float = 0.0  # rad of forward pelvis pitch per metre the pelvis is below STAND
    arm_lift: float = 0.0  # rad of both arms forward per m/s the pelvis rises
    floor: float = 0.0  # m the floor rises per metre along x (a capture floor not quite level)
    jitter: float = 0.0  # rad of joint-angle noise (and jitter / 2 m of root noise)
    seed: int = 0
    # what a test checks: frames of these (start, stop) times are in flight (no foot down)
    flights: tuple[tuple[float, float], ...] = field(default_factory=tuple)

    @property
    def time(self) -> np.ndarray:
        return np.arange(round(self.duration * RATE)) / RATE

    def on_ground(self) -> np.ndarray:
        """(T, 2) bool: the planned contacts, touchdown to lift-off, left and right."""
        t = self.time
        return np.stack(
            [
                np.any([(s.start <= t) & (t < s.stop) for s in feet if s.height == 0], axis=0)
                for feet in self.feet
            ],
            axis=1,
        )


def smoothstep(s: np.ndarray) -> np.ndarray:
    s = np.clip(s, 0.0, 1.0)
    return s * s * (3.0 - 2.0 * s)


def hermite(s: np.ndarray, p0: Value, p1: Value, m0: Value, m1: Value) -> np.ndarray:
    """Cubic Hermite at s in [0, 1] (tangents scaled by the segment's duration)."""
    s = s[:, None] if np.ndim(p0) else s
    s2, s3 = s * s, s * s * s
    return (
        (2 * s3 - 3 * s2 + 1) * p0
        + (s3 - 2 * s2 + s) * m0
        + (3 * s2 - 2 * s3) * p1
        + (s3 - s2) * m1
    )


def _heading(yaw: np.ndarray | float) -> np.ndarray:
    yaw = np.asarray(yaw, dtype=float)
    return np.stack([np.cos(yaw), np.sin(yaw)], axis=-1)


def _pitch(angle: np.ndarray) -> np.ndarray:
    """(n, 3, 3) rotations about y (positive: the toe goes down)."""
    c, s = np.cos(angle), np.sin(angle)
    zero, one = np.zeros_like(angle), np.ones_like(angle)
    return np.stack([c, zero, s, zero, one, zero, -s, zero, c], axis=-1).reshape(-1, 3, 3)


def _stance_pose(stance: Stance, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Ankle positions (n, 3) and foot pitch (n,) during `stance`."""
    rolled_in = smoothstep((t - stance.start) / stance.roll)
    rolled_out = smoothstep((t - stance.stop + stance.roll) / stance.roll)
    pitch = stance.point + stance.land * (1.0 - rolled_in) + stance.push * rolled_out
    # the foot turns about the heel when its toe is up, else about the ball
    pivot = np.where(pitch[:, None] < 0.0, HEEL_SOLE, BALL_SOLE)
    tilted = np.einsum("tij,tj->ti", _pitch(pitch), pivot)
    slid = stance.skid * (1.0 - np.clip((t - stance.start) / SKID_TIME, 0.0, 1.0)) ** 2
    flat = np.array([stance.x, stance.y, ANKLE_HEIGHT + stance.height])
    turn = Rotation.from_euler("z", stance.yaw)
    ankle = flat + turn.apply(pivot - tilted)
    ankle[:, :2] -= slid[:, None] * _heading(stance.yaw)
    return ankle, pitch


def _swing_pose(a: Stance, b: Stance, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Ankle (n, 3), pitch and yaw (n,) from lift-off of `a` to touchdown of `b`."""
    duration = b.start - a.stop
    s = (t - a.stop) / duration
    (p0,), (theta0,) = _stance_pose(a, np.array([a.stop]))
    (p1,), (theta1,) = _stance_pose(b, np.array([b.start]))
    v1 = 2.0 * b.skid / SKID_TIME * _heading(b.yaw)  # still moving at touchdown
    ankle = np.empty((len(t), 3))
    ankle[:, :2] = hermite(s, p0[:2], p1[:2], np.zeros(2), v1 * duration)
    rise = min(b.rise, duration / 2)
    bump = smoothstep((t - a.stop) / rise) * smoothstep((b.start - t) / rise)
    ankle[:, 2] = p0[2] + (p1[2] - p0[2]) * smoothstep(s) + b.lift * bump
    blend = smoothstep(s)
    return ankle, theta0 + (theta1 - theta0) * blend, a.yaw + (b.yaw - a.yaw) * blend


def foot_motion(stances: Sequence[Stance], t: np.ndarray) -> tuple[np.ndarray, ...]:
    """Ankle (T, 3), pitch and yaw (T,) of a foot over its stances and the swings between
    (held at the first and last stance outside them)."""
    ankle, pitch, yaw = np.empty((len(t), 3)), np.empty(len(t)), np.empty(len(t))
    for n, stance in enumerate(stances):
        lower = -np.inf if n == 0 else stance.start
        upper = np.inf if n == len(stances) - 1 else stance.stop
        here = (lower <= t) & (t < upper)
        if here.any():
            ankle[here], pitch[here] = _stance_pose(stance, t[here])
        yaw[here] = stance.yaw
        if n + 1 < len(stances):
            after = stances[n + 1]
            between = (stance.stop <= t) & (t < after.start)
            if between.any():
                ankle[between], pitch[between], yaw[between] = _swing_pose(
                    stance, after, t[between]
                )
    return ankle, pitch, yaw


def pelvis_height(knots: Sequence[tuple[float, float, float]], t: np.ndarray) -> np.ndarray:
    """A cubic Hermite chain through (time, height, vertical speed) knots; a segment between a
    take-off (z, v) and a landing (z, -v) with v = g T / 2 is the ballistic flight."""
    z = np.full(len(t), knots[0][1])
    for (t0, z0, v0), (t1, z1, v1) in pairwise(knots):
        here = (t0 <= t) & (t < t1)
        z[here] = hermite((t[here] - t0) / (t1 - t0), z0, z1, v0 * (t1 - t0), v1 * (t1 - t0))
    z[t >= knots[-1][0]] = knots[-1][1]
    return z


def _soft_min(values: np.ndarray, width: float = 0.01) -> np.ndarray:
    """A smooth minimum along axis 1, never above the true one."""
    low = values.min(axis=1, keepdims=True)
    return low[:, 0] - width * np.log(np.exp(-(values - low) / width).sum(axis=1))


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _frame(down: np.ndarray, lateral: np.ndarray) -> np.ndarray:
    """(T, 3, 3) segment rotations: the segment's rest axis -z along `down`, y near `lateral`."""
    up = -_unit(down)
    left = _unit(lateral - np.sum(lateral * up, axis=1, keepdims=True) * up)
    return np.stack([np.cross(left, up), left, up], axis=-1)


# the skeleton: name, parent, rest offset (m, Z up); leaves become BVH End Sites
_BONES: tuple[tuple[str, str, tuple[float, float, float]], ...] = (
    ("Hips", "", (0.0, 0.0, 0.0)),
    *(
        bone
        for side, y in (("Left", HIP_Y), ("Right", -HIP_Y))
        for bone in (
            (f"{side}UpLeg", "Hips", (0.0, y, 0.0)),
            (f"{side}Leg", f"{side}UpLeg", (0.0, 0.0, -THIGH)),
            (f"{side}Foot", f"{side}Leg", (0.0, 0.0, -SHANK)),
            (f"{side}ToeBase", f"{side}Foot", tuple(BALL)),
            (f"{side}ToeBase_End", f"{side}ToeBase", (0.06, 0.0, -0.03)),
        )
    ),
    ("Spine", "Hips", (0.0, 0.0, 0.12)),
    ("Spine1", "Spine", (0.0, 0.0, 0.2)),
    ("Neck", "Spine1", (0.0, 0.0, 0.18)),
    ("Head", "Neck", (0.0, 0.0, 0.08)),
    ("Head_End", "Head", (0.0, 0.0, 0.15)),
    *(
        bone
        for side, y in (("Left", 1.0), ("Right", -1.0))
        for bone in (
            (f"{side}Shoulder", "Spine1", (0.0, 0.02 * y, 0.15)),
            (f"{side}Arm", f"{side}Shoulder", (0.0, 0.16 * y, 0.0)),
            (f"{side}ForeArm", f"{side}Arm", (0.0, 0.0, -0.28)),
            (f"{side}Hand", f"{side}ForeArm", (0.0, 0.0, -0.25)),
            (f"{side}Hand_End", f"{side}Hand", (0.0, 0.0, -0.08)),
        )
    ),
)


def skeleton() -> Skeleton:
    names = tuple(name for name, _, _ in _BONES)
    parents = tuple(names.index(p) if p else -1 for _, p, _ in _BONES)
    return Skeleton(names, parents, np.array([offset for _, _, offset in _BONES]))


def _pelvis(gait: Gait, ankles: np.ndarray, yaws: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pelvis positions (T, 3) and yaw (T,): above the middle of the feet (low-passed at
    1.5 Hz), at the planned height or lower where an ankle would be out of reach."""
    t = gait.time
    sos = butter(2, 1.5, fs=RATE, output="sos")
    xy = sosfiltfilt(sos, ankles[:, :, :2].mean(axis=1), axis=0)
    yaw = sosfiltfilt(sos, yaws.mean(axis=1))
    caps = []
    for k, sign in enumerate((1.0, -1.0)):
        hip = xy + sign * HIP_Y * np.stack([-np.sin(yaw), np.cos(yaw)], axis=1)
        distance = np.linalg.norm(ankles[:, k, :2] - hip, axis=1)
        if distance.max() >= REACH:
            raise ValueError(f"{gait.name}: an ankle is {distance.max():.2f} m from its hip")
        caps.append(ankles[:, k, 2] + np.sqrt(REACH**2 - distance**2))
    planned = pelvis_height(gait.pelvis, t) + gait.floor * xy[:, 0]
    height = _soft_min(np.stack([planned, *caps], axis=1))
    return np.column_stack([xy, height]), yaw


def _leg(hip: np.ndarray, ankle: np.ndarray, forward: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World rotations of thigh and shank reaching from `hip` to `ankle`, knee forward."""
    reach = ankle - hip
    lateral = _unit(np.cross(forward, reach))
    half = np.linalg.norm(reach, axis=1, keepdims=True) / 2
    bend = _unit(np.cross(reach, lateral)) * np.sqrt(THIGH**2 - half**2)
    knee = hip + reach / 2 + bend
    return _frame(knee - hip, lateral), _frame(ankle - knee, lateral)


def _arms(world: np.ndarray, index: dict[str, int], swing: np.ndarray, lift: np.ndarray) -> None:
    """Upper arms swung forward by `swing` (left; the right one back) plus `lift` (both), a
    little outward; elbows bent 0.3 rad."""
    base = world[:, index["Spine1"]]
    for side, sign in (("Left", 1.0), ("Right", -1.0)):
        angles = np.column_stack([-sign * swing - lift, np.full_like(swing, sign * 0.1)])
        arm = base @ Rotation.from_euler("YX", angles).as_matrix()
        world[:, index[f"{side}Arm"]] = arm
        world[:, index[f"{side}ForeArm"]] = arm @ Rotation.from_euler("y", -0.3).as_matrix()


def _world_rotations(gait: Gait, bones: Skeleton) -> tuple[np.ndarray, np.ndarray]:
    """Root positions (T, 3) and world rotations of every joint (T, J, 3, 3)."""
    t = gait.time
    motions = [foot_motion(stances, t) for stances in gait.feet]
    ankles = np.stack([m[0] for m in motions], axis=1)
    ankles[..., 2] += gait.floor * ankles[..., 0]
    pitches, yaws = (np.stack([m[i] for m in motions], axis=1) for i in (1, 2))
    pelvis, heading = _pelvis(gait, ankles, yaws)
    index = {name: j for j, name in enumerate(bones.names)}
    lean = gait.lean * np.maximum(STAND - pelvis[:, 2], 0.0)  # crouched: leaning forward
    base = Rotation.from_euler("ZY", np.column_stack([heading, lean])).as_matrix()
    world = np.broadcast_to(base[:, None], (len(t), len(bones), 3, 3)).copy()  # trunk: the base
    for k, side in enumerate(("Left", "Right")):
        hip = pelvis + base @ bones.offsets[index[f"{side}UpLeg"]]
        thigh, shank = _leg(hip, ankles[:, k], base[:, :, 0])
        foot = Rotation.from_euler("ZY", np.stack([yaws[:, k], pitches[:, k]], axis=1))
        world[:, index[f"{side}UpLeg"]], world[:, index[f"{side}Leg"]] = thigh, shank
        world[:, index[f"{side}Foot"]] = world[:, index[f"{side}ToeBase"]] = foot.as_matrix()
    lead = np.sum((ankles[:, 1] - ankles[:, 0])[:, :2] * base[:, :2, 0], axis=1)
    lift = gait.arm_lift * np.gradient(pelvis[:, 2], t)
    _arms(world, index, 0.4 * np.tanh(lead / 0.4), lift)  # right foot ahead: left arm forward
    for j, parent in enumerate(bones.parents):
        if bones.names[j].endswith(("_End", "Hand")):
            world[:, j] = world[:, parent]  # hands and end sites: no rotation of their own
    return pelvis, world


def gait_clip(gait: Gait, source: Path | None = None) -> MocapClip:
    """The gait as a MocapClip in metres, Z up (root = pelvis, local rotations), with the
    gait's jitter added."""
    bones = skeleton()
    root, world = _world_rotations(gait, bones)
    local = world.copy()
    for j, parent in enumerate(bones.parents[1:], start=1):
        local[:, j] = np.swapaxes(world[:, parent], 1, 2) @ world[:, j]
    if gait.jitter:
        rng = np.random.default_rng(gait.seed)
        noise = Rotation.from_rotvec(rng.normal(0.0, gait.jitter, (*local.shape[:2], 3)))
        local = noise.as_matrix() @ local
        root = root + rng.normal(0.0, gait.jitter / 2, root.shape)
    path = source or Path(f"gait_{gait.name}.bvh")
    return MocapClip(gait.name, path, "bvh", RATE, bones, root, local, 1.0, False)


def write_gait(folder: Path, name: str) -> Path:
    """GAITS[name] as folder/gait_<name>.bvh (centimetres, like CMU's conversions)."""
    path = Path(folder) / f"gait_{name}.bvh"
    return write_bvh(path, gait_clip(GAITS[name](), path), units="cm")


def _walk(
    steps: Sequence[tuple[str, float, float, float, float, float]],
    start: float,
    double_support: float = 0.12,
    width: float = 0.1,
    push: float = 0.3,
) -> tuple[tuple[Stance, ...], tuple[Stance, ...]]:
    """Stances of a walk from standing at x = 0: steps (side, x, swing time, lift, landing
    pitch, skid) one after the other, each lifting `double_support` s after the last landed."""
    feet: dict[str, list[Stance]] = {
        side: [Stance(-1.0, np.inf, 0.0, y)] for side, y in (("l", width), ("r", -width))
    }
    t = start
    for side, x, swing, lift, land, skid in steps:
        last = feet[side][-1]
        feet[side][-1] = replace(last, stop=t, push=push)
        y = width if side == "l" else -width
        feet[side].append(Stance(t + swing, np.inf, x, y, land=land, skid=skid, lift=lift))
        t += swing + double_support
    return tuple(feet["l"]), tuple(feet["r"])


def _hops(
    flights: Sequence[tuple[float, float]],
    take_off: float = 0.93,
    prepare: float = 0.6,
    recover: float = 0.6,
) -> tuple[tuple[float, float, float], ...]:
    """Pelvis knots of hops from standing: crouch for `prepare` s, ballistic flights (each as
    long as its `flights` interval), crouches between, and back to standing in `recover` s."""
    knots = [(0.0, STAND, 0.0), (flights[0][0] - prepare, STAND, 0.0)]
    for up, down in flights:
        speed = GRAVITY * (down - up) / 2
        knots += [(up, take_off, speed), (down, take_off, -speed)]
    end = flights[-1][1] + recover
    return (*knots, (end, STAND, 0.0), (end + 10.0, STAND, 0.0))


def _flights(start: float, airborne: Sequence[float], grounded: float) -> list[tuple[float, float]]:
    """(take-off, landing) times of hops `airborne` s long, `grounded` s apart."""
    flights = []
    for duration in airborne:
        flights.append((start, start + duration))
        start += duration + grounded
    return flights


def _hop_stances(
    flights: Sequence[tuple[float, float]],
    forward: Sequence[float],
    lifts: Sequence[float],
    y: float,
    skid: float,
) -> tuple[Stance, ...]:
    """One foot's stances around `flights` (hops `forward` m long, the foot `lifts` m up): it
    rolls over the ball to take off, lands toe first, and still slides `skid` m when the hop
    went forward."""
    stances = [Stance(-1.0, flights[0][0], 0.0, y, push=0.5)]
    x = 0.0
    for n, ((_, down), step, lift) in enumerate(zip(flights, forward, lifts, strict=True)):
        x += step
        stop = flights[n + 1][0] if n + 1 < len(flights) else np.inf
        slide = skid if step > 0 else 0.0
        stances.append(
            Stance(down, stop, x, y, land=0.35, push=0.5, roll=0.1, skid=slide, lift=lift)
        )
    return tuple(stances)


def start_walk_stop() -> Gait:
    """Stand, speed up, five long steps lifting the knees high (ankles up to 28 cm) that land
    heel first still sliding 3-5 cm, slow down, stand."""
    steps = [
        ("r", 0.35, 0.45, 0.10, -0.15, 0.0),
        ("l", 1.05, 0.45, 0.22, -0.35, 0.03),
        ("r", 1.90, 0.42, 0.28, -0.35, 0.05),
        ("l", 2.75, 0.42, 0.28, -0.35, 0.04),
        ("r", 3.50, 0.45, 0.22, -0.30, 0.03),
        ("l", 4.05, 0.45, 0.12, -0.20, 0.0),
        ("r", 4.05, 0.45, 0.06, 0.0, 0.0),
    ]
    pelvis = ((0.0, STAND, 0.0), (10.0, STAND, 0.0))
    return Gait("start_walk_stop", 6.0, _walk(steps, start=1.0, push=0.4), pelvis)


def hop() -> Gait:
    """Two-footed hops, leaning forward in the crouches: three high ones (0.4 s in the air, the
    feet 20 cm up; 30 cm forward, 30 cm, in place) and two low rebounds in place (0.25 s, the
    feet 6 cm up). Both feet take off over the ball and land together, toe first."""
    flights = _flights(1.4, (0.4, 0.4, 0.4, 0.25, 0.25), 0.4)
    forward, lifts = (0.3, 0.3, 0.0, 0.0, 0.0), (0.2, 0.2, 0.2, 0.06, 0.06)
    feet = tuple(_hop_stances(flights, forward, lifts, y, skid=0.02) for y in (0.1, -0.1))
    pelvis = _hops(flights)
    return Gait("hop", 5.8, feet, pelvis, lean=2.0, arm_lift=0.5, flights=tuple(flights))


def hop_one_leg() -> Gait:
    """Four hops on the left foot, 30 cm forward each (0.35 s in the air), each landing still
    sliding 4 cm; the right foot, held up 20-25 cm with its toe pointed, kicks forward to take
    off and swings back to land; then it is put down beside the left."""
    flights = _flights(1.4, (0.35,) * 4, 0.3)
    left = _hop_stances(flights, (0.3,) * 4, (0.15,) * 4, 0.1, skid=0.04)
    held = [Stance(-1.0, 0.6, 0.0, -0.1, push=0.2)]
    for n, (up, down) in enumerate(flights):
        for time, ahead, height in ((up - 0.05, 0.45, 0.25), (down, -0.12, 0.2)):
            held.append(
                Stance(time, time + 0.05, 0.3 * n + ahead, -0.1, height=height, lift=0.0, point=0.7)
            )
    down = flights[-1][1] + 0.6
    held.append(Stance(down, np.inf, 1.2, -0.1, land=-0.1, lift=0.0, rise=0.3))
    pelvis = _hops(flights, prepare=0.5)
    feet = (left, tuple(held))
    return Gait(
        "hop_one_leg", down + 1.0, feet, pelvis, lean=1.5, arm_lift=0.4, flights=tuple(flights)
    )


def heel_toe_walk() -> Gait:
    """A walk whose steps land alternately heel first (toe 26 deg up) and toe first (17 deg
    down), on a floor rising 1 cm per metre, with joint-angle jitter (0.11 deg per joint and
    frame, 1 mm at the root)."""
    xs = (0.33, 0.98, 1.63, 2.28, 2.93, 3.58, 3.58)
    steps = [
        ("rl"[n % 2], x, 0.4, 0.1 if n < 6 else 0.05, (-0.45, 0.3)[n % 2] if n < 6 else 0.0, 0.01)
        for n, x in enumerate(xs)
    ]
    pelvis = ((0.0, STAND, 0.0), (10.0, STAND, 0.0))
    feet = _walk(steps, start=0.6)
    return Gait("heel_toe_walk", 5.0, feet, pelvis, floor=0.01, jitter=0.002, seed=3)


GAITS: dict[str, Callable[[], Gait]] = {
    "start_walk_stop": start_walk_stop,
    "hop": hop,
    "hop_one_leg": hop_one_leg,
    "heel_toe_walk": heel_toe_walk,
}


def main() -> None:
    """python tests/retarget/gaits.py FOLDER: write every gait there (for the CLI)."""
    import sys

    if len(sys.argv) != 2:
        raise SystemExit("usage: python tests/retarget/gaits.py FOLDER")
    folder = Path(sys.argv[1])
    folder.mkdir(parents=True, exist_ok=True)
    for name in GAITS:
        print(write_gait(folder, name))


if __name__ == "__main__":
    main()
