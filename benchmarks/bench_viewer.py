"""The viewer: opening a 10-minute 120 Hz clip, the cost of one displayed frame, real-time play.

    python benchmarks/bench_viewer.py [--seconds 600] [--frames 2000]

Targets: a 10-minute clip opens in <= 2 s; a 120 Hz clip plays at real time (one frame
update well under 1/120 s = 8.3 ms). Baseline in the same run: the naive per-frame update, which
recomputes the link poses with the model's generic forward kinematics (a dict walk with scipy
rotations per joint), converts each link's rotation with scipy, and sends the link poses one
message at a time instead of as one atomic update.
"""

from __future__ import annotations

import argparse
import socket
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from motionkit.dataset import Trajectory, corner_names, write
from motionkit.dataset.synthetic import synthetic_trajectory
from motionkit.mocap.naming import LANDMARKS, skeleton
from motionkit.robot import ironcub
from motionkit.viewer.app import ViewerApp
from motionkit.viewer.meshes import robot_meshes
from motionkit.viewer.sources import resolve_clips


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def with_overlays(trajectory: Trajectory) -> Trajectory:
    """Every overlay drawn: a 19-landmark skeleton and 8 corner forces on each frame."""
    rng = np.random.default_rng(1)
    names, parents = skeleton(LANDMARKS)
    frames, robot = trajectory.frames, ironcub()
    return replace(
        trajectory,
        landmark_names=names,
        landmark_parents=parents,
        landmarks=rng.normal(size=(frames, len(names), 3)).astype(np.float32),
        corner_names=corner_names(robot),
        contact_forces=rng.uniform(0, 60, size=(frames, 8, 3)).astype(np.float32),
    )


def naive_update(app: ViewerApp, frame: int) -> None:
    """The baseline: generic FK from scratch and one message per link property."""
    motion, scene = app.motion, app.scene
    assert motion is not None
    q = dict(zip(motion.joint_names, motion.joint_positions[frame].astype(float), strict=True))
    base = np.eye(4)
    w, x, y, z = motion.base_orientation[frame]
    base[:3, :3] = Rotation.from_quat([x, y, z, w]).as_matrix()
    base[:3, 3] = motion.base_position[frame]
    poses = app.robot.model.link_poses(q)
    for link, handle in scene.frames.items():
        pose = base @ poses[link]
        qx, qy, qz, qw = Rotation.from_matrix(pose[:3, :3]).as_quat()
        handle.wxyz = (qw, qx, qy, qz)
        handle.position = pose[:3, 3]


def per_frame(function, frames: np.ndarray) -> np.ndarray:
    times = np.empty(len(frames))
    for k, frame in enumerate(frames):
        start = time.perf_counter()
        function(int(frame))
        times[k] = time.perf_counter() - start
    return times * 1e3


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=600.0)
    parser.add_argument("--frames", type=int, default=2000, help="frames timed per method")
    args = parser.parse_args()

    start = time.perf_counter()
    robot = ironcub()
    robot_s = time.perf_counter() - start
    start = time.perf_counter()
    robot_meshes(robot, use_cache=False)
    meshes_cold_s = time.perf_counter() - start
    robot_meshes(robot)  # fills the cache every later start reads
    trajectory = with_overlays(synthetic_trajectory(robot, args.seconds, 120.0, thrust=100.0))
    print(f"clip: {trajectory.frames} frames at 120 Hz ({args.seconds:.0f} s), 23 joints, 4 jets, "
          "skeleton and contact forces")  # fmt: skip
    print(f"robot model built once per process: {robot_s:.2f} s; meshes without cache: "
          f"{meshes_cold_s:.2f} s (cached afterwards)")  # fmt: skip
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "ten_minutes.mcap"
        write(path, trajectory, robot)
        opens = []
        for _ in range(3):
            start = time.perf_counter()
            clips = resolve_clips(path)
            listed = time.perf_counter()
            app = ViewerApp(robot, clips, port=free_port())
            opened = time.perf_counter()
            opens.append((listed - start, opened - start))
            app.close()
        listed_s, open_s = min(o[1] for o in opens), min(o[0] for o in opens)
        print(f"open (metadata check, whole read with CRCs, scene, server up): best of 3 "
              f"{listed_s:.2f} s (metadata {open_s * 1e3:.0f} ms)  target <= 2 s: "
              f"{'ok' if listed_s <= 2 else 'MISSED'}")  # fmt: skip

        app = ViewerApp(robot, resolve_clips(path), port=free_port())
        try:
            frames = np.random.default_rng(0).integers(0, trajectory.frames, args.frames)
            poser = app.scene.poser
            motion = app.motion
            assert motion is not None
            fk = per_frame(
                lambda f: poser.poses(
                    motion.base_position[f], motion.base_orientation[f], motion.joint_positions[f]
                ),
                frames,
            )
            ours = per_frame(app._show, frames)
            naive = per_frame(lambda f: naive_update(app, f), frames)
            budget = 1e3 / 120
            print("\nper displayed frame [ms]   mean    p99   share of the 1/120 s budget")
            for name, times in (("link poses only", fk), ("viewer update", ours),
                                ("naive baseline", naive)):  # fmt: skip
                print(f"  {name:<22} {times.mean():6.3f} {np.percentile(times, 99):6.3f}   "
                      f"{times.mean() / budget:6.1%}")  # fmt: skip
            print(f"  naive / viewer: {naive.mean() / ours.mean():.1f}x")

            shown = []
            original = app._show
            app._show = lambda f: (shown.append(f), original(f))[1]  # type: ignore[method-assign]
            app.set_time(0.0)
            shown.clear()
            app.play()
            start = time.perf_counter()
            time.sleep(3.0)
            wall = time.perf_counter() - start
            app.play(False)
            clip_s = app.playback.now if app.playback else 0.0
            print(f"\nplaying 3 s of wall time: clip time advanced {clip_s:.3f} s in {wall:.3f} s "
                  f"(x{clip_s / wall:.3f}); {len(shown) / wall:.0f} frames shown per second "
                  f"(clip rate 120)")  # fmt: skip
        finally:
            app.close()


if __name__ == "__main__":
    main()
