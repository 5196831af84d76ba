"""Real CMU walks made into takes that start, stop, turn, change pace, hop and jump.

Each helper takes a mocap clip (motionkit.mocap.MocapClip: metres, Z up) and returns a new one:
the same skeleton with its root moved and turned, its frames held or resampled. `TAKES` chains
them on the offline sample's walks (motionkit/sample/cmu: the CMU takes 02_01, 11_01 and 35_01;
the same files as ../shared/mocap/cmu), and `write_take` writes one as a BVH file that
`motionkit retarget` reads. Nothing is copied into the repository: takes are made when a test
(or this script) asks.

    python tests/retarget/takes.py FOLDER     # every take into FOLDER as <name>.bvh
    python tests/retarget/takes.py --table    # the table of docs/retarget.md: every take
                                              # retargeted with the defaults, its figures

Units: metres, seconds, radians.
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

from motionkit.mocap import MocapClip, load_mocap
from motionkit.mocap.writers import write_bvh
from motionkit.recipes import sample_mocap

GRAVITY = 9.81


def _frames(clip: MocapClip, index: np.ndarray) -> MocapClip:
    """The clip's frames `index` (integers, in any order and repeated)."""
    return replace(
        clip,
        root_translation=clip.root_translation[index],
        rotations=clip.rotations[index],
        translations=None if clip.translations is None else clip.translations[index],
    )


def cut(clip: MocapClip, start: float, end: float) -> MocapClip:
    """The frames from `start` to `end` [s], both kept."""
    return _frames(clip, np.arange(round(start * clip.rate), round(end * clip.rate) + 1))


def held(clip: MocapClip, before: float = 0.0, after: float = 0.0) -> MocapClip:
    """The take with its first frame held for `before` seconds and its last for `after`: a
    walk that starts from standing, one that stops."""
    first, last = round(before * clip.rate), round(after * clip.rate)
    index = np.concatenate([np.zeros(first, int), np.arange(clip.frames), [clip.frames - 1] * last])
    return _frames(clip, index.astype(int))


def retimed(clip: MocapClip, speed: float) -> MocapClip:
    """The take played `speed` times as fast (< 1: slower) at the same frame rate: frame n is
    the take at n speed / rate seconds (root positions interpolated linearly, joint rotations
    along the shortest arc)."""
    source = np.arange(clip.frames) / clip.rate
    at = np.arange(0.0, source[-1] + 1e-9, speed / clip.rate)
    root = np.stack([np.interp(at, source, clip.root_translation[:, i]) for i in range(3)], 1)
    joints = clip.rotations.shape[1]
    rotations = np.stack(
        [Slerp(source, Rotation.from_matrix(clip.rotations[:, j]))(at).as_matrix()
         for j in range(joints)],
        axis=1,
    )  # fmt: skip
    if clip.translations is not None:
        raise ValueError("retimed: a clip with joint translations")
    return replace(clip, root_translation=root, rotations=rotations)


def _feet(clip: MocapClip) -> list[np.ndarray]:
    """(T, 3) the middle of each foot (ankle to toe), left and right."""
    marks = clip.landmarks()
    return [0.5 * (marks[f"{s}_ankle"] + marks[f"{s}_toe"]) for s in "lr"]


def moved(clip: MocapClip, heading: np.ndarray, shift: np.ndarray) -> MocapClip:
    """The whole body turned by `heading` (T,) [rad] about the vertical through the origin,
    then moved by `shift` (T, 3) [m]: frame by frame, a rigid motion of the world."""
    turn = Rotation.from_euler("z", heading[:, None]).as_matrix()
    root = np.einsum("tij,tj->ti", turn, clip.root_translation) + shift
    rotations = clip.rotations.copy()
    rotations[:, 0] = turn @ clip.rotations[:, 0]
    return replace(clip, root_translation=root, rotations=rotations)


def turned(clip: MocapClip, angle: float) -> MocapClip:
    """The take turned by `angle` [rad] (> 0: to the left) about the vertical, progressively:
    each frame turns the body by its share of the angle about the foot it stands on (the slower
    foot), the shares weighted by how much faster the other foot moves (1 from 0.3 m/s more),
    so that a stance foot pivots in place and a person on both feet does not turn."""
    feet = _feet(clip)
    speed = np.stack(
        [np.linalg.norm(np.gradient(f[:, :2], axis=0), axis=1) * clip.rate for f in feet], 1
    )
    weight = np.clip(np.abs(speed[:, 0] - speed[:, 1]) / 0.3, 0.0, 1.0)[1:]
    if weight.sum() == 0:
        raise ValueError("turned: the take never stands on one foot")
    heading = np.concatenate([[0.0], np.cumsum(weight)]) * angle / weight.sum()
    pivots = np.where((speed[:, 0] <= speed[:, 1])[:, None], feet[0], feet[1])
    shift = np.zeros((clip.frames, 3))
    for t in range(1, clip.frames):
        # the pivot stays where the previous frame's turn and shift put it
        pivot = pivots[t]
        before = Rotation.from_euler("z", heading[t - 1]).apply(pivot) + shift[t - 1]
        shift[t] = before - Rotation.from_euler("z", heading[t]).apply(pivot)
    shift[:, 2] = 0.0
    return moved(clip, heading, shift)


def hopped(clip: MocapClip, at: float, flight: float, forward: float = 0.0) -> MocapClip:
    """The take with a hop: from `at` [s] the whole body flies for `flight` seconds on a
    ballistic arc (g s (flight - s) / 2 high at s into it: g flight^2 / 8 at the top) and
    `forward` metres along its heading (the pelvis's forward at take-off), then lands and stays
    moved by that. Made for a take that stands on both feet around `at`."""
    marks = clip.landmarks()
    take_off = min(round(at * clip.rate), clip.frames - 1)
    across = marks["l_hip"][take_off] - marks["r_hip"][take_off]
    ahead = np.array([across[1], -across[0], 0.0]) / np.linalg.norm(across[:2])
    s = np.clip(np.arange(clip.frames) / clip.rate - at, 0.0, flight)
    shift = forward * (s / flight)[:, None] * ahead
    shift[:, 2] = 0.5 * GRAVITY * s * (flight - s)
    return moved(clip, np.zeros(clip.frames), shift)


Step = Callable[[MocapClip], MocapClip]


@dataclass(frozen=True)
class Take:
    """A take made from a sample walk: its file and the helpers applied in order."""

    clip: str
    steps: tuple[Step, ...]
    what: str


TAKES: dict[str, Take] = {
    "start_turn_stop": Take(
        "02_01.bvh",
        (lambda c: turned(c, np.pi / 2), lambda c: held(c, before=1.0, after=1.0)),
        "02_01 turned 90 deg left, standing 1 s before and after",
    ),
    "fast_right_turn": Take(
        "35_01.amc",
        (
            lambda c: retimed(c, 1.25),
            lambda c: turned(c, -np.pi / 3),
            lambda c: held(c, before=1.0, after=0.5),
        ),
        "35_01 1.25x as fast, turned 60 deg right, standing 1 s before, 0.5 s after",
    ),
    "slow_walk_stop": Take(
        "11_01.amc",
        (lambda c: cut(c, 0.0, 2.7), lambda c: retimed(c, 0.7), lambda c: held(c, after=1.0)),
        "11_01's first 2.7 s (standing, two steps) 0.7x as fast, standing 1 s after",
    ),
    "hop_then_walk": Take(
        "02_01.bvh",
        (lambda c: held(c, before=1.5), lambda c: hopped(c, at=0.4, flight=0.3)),
        "02_01 after 1.5 s standing with a 0.3 s hop in place (11 cm) at 0.4 s",
    ),
    "walk_stop_jump": Take(
        "35_01.amc",
        (lambda c: held(c, after=2.0), lambda c: hopped(c, at=3.5, flight=0.35, forward=0.25)),
        "35_01 stopping, then a 0.35 s jump 25 cm forward (15 cm high), standing after",
    ),
}


def make_take(name: str) -> MocapClip:
    """Take `name` of TAKES, made from the offline sample."""
    take = TAKES[name]
    clip = replace(load_mocap(sample_mocap() / take.clip), name=name)
    for step in take.steps:
        clip = step(clip)
    return clip


def write_take(folder: Path, name: str) -> Path:
    """Take `name` as FOLDER/<name>.bvh (centimetres)."""
    return write_bvh(Path(folder) / f"{name}.bvh", make_take(name))


COLUMNS = (
    ("slide p95 [mm/s]", lambda m: f"{1000 * m['foot_slide_p95_m_s']:.1g}"),
    ("sink [mm]", lambda m: f"{1000 * m['penetration_max_m']:.2f}"),
    ("limit violations", lambda m: m["joint_position_violations"] + m["joint_velocity_violations"]),
    ("CoP in support", lambda m: f"{m['physics']['cop_inside_share']:.2f}"),
    ("(1 foot)", lambda m: f"{m['physics']['cop_inside_share_single_support']:.2f}"),
    ("torques in limits", lambda m: f"{m['physics']['torque_within_share']:.2f}"),
    ("(1 foot)", lambda m: f"{m['physics']['torque_within_share_single_support']:.2f}"),
    ("friction in cone", lambda m: f"{m['physics']['friction_within_share']:.2f}"),
    ("residual force p95 [body weights]", lambda m: f"{m['physics']['residual_force_p95_bw']:.2f}"),
)


def table(folder: Path) -> list[str]:
    """Every take written to FOLDER/in and retargeted with the defaults into FOLDER/out: a
    Markdown table of each one's frames and figures (slide and sinking of the feet in contact,
    limit violations, physics)."""
    from motionkit.retarget import RetargetConfig, resolve_inputs, run_retarget

    (folder / "in").mkdir(parents=True, exist_ok=True)
    for key in TAKES:
        write_take(folder / "in", key)
    results = run_retarget(resolve_inputs([str(folder / "in")]), folder / "out", RetargetConfig())
    lines = [
        "| take | frames | " + " | ".join(name for name, _ in COLUMNS) + " |",
        "|---" * (len(COLUMNS) + 2) + "|",
    ]
    for result in results:
        m = result.metrics
        figures = " | ".join(str(value(m)) for _, value in COLUMNS) if m else result.error
        lines.append(f"| {result.name} | {result.frames} | {figures} |")
    return lines


if __name__ == "__main__":
    if sys.argv[1:] == ["--table"]:
        import tempfile

        with tempfile.TemporaryDirectory() as scratch:
            print("\n".join(table(Path(scratch))))
    else:
        out = Path(sys.argv[1] if len(sys.argv) > 1 else "takes")
        out.mkdir(parents=True, exist_ok=True)
        for key in TAKES:
            print(write_take(out, key))
