"""Retargeting 20 clips in this process (--jobs 1), in two local processes (--jobs 2) and on a
local Ray cluster of 2 CPUs that this script starts and stops: wall time and per-task overhead.

    python benchmarks/bench_cluster.py [--clips 20] [--frames 240]

The clips are time-shifted windows of the three sample walks (motionkit/sample/cmu), written as
BVH into a temporary folder. Per-task overhead: (wall x workers - the tasks' own seconds) / tasks,
the time a task costs beyond its work (process or worker start, pickling, the driver's writes,
and for Ray the connection). BLAS runs one thread per task (Ray's workers do by default). Every
backend's files are compared byte for byte. Needs the [ik] and [cluster] extras.
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")  # one BLAS thread per task, as on Ray
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse
import contextlib
import io
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

from motionkit.mocap import load_mocap
from motionkit.mocap.writers import write_bvh
from motionkit.recipes import sample_mocap
from motionkit.retarget.batch import ClipInput, ClipResult, resolve_inputs, run_retarget
from motionkit.retarget.config import RetargetConfig
from motionkit.robot import ironcub

SHIFT_S = 0.1  # each variant of a walk starts this much later than the one before


def make_clips(folder: Path, count: int, frames: int) -> list[ClipInput]:
    """`count` BVH windows of `frames` frames of the sample walks, each shifted in time."""
    walks = [load_mocap(clip.path, asf=clip.asf) for clip in resolve_inputs([str(sample_mocap())])]
    for k in range(count):
        walk = walks[k % len(walks)]
        start = round((k // len(walks)) * SHIFT_S * walk.rate)
        end = min(start + frames, walk.rotations.shape[0])
        window = replace(
            walk,
            name=f"{walk.name}_{k:02d}",
            root_translation=walk.root_translation[start:end],
            rotations=walk.rotations[start:end],
        )
        write_bvh(folder / f"{window.name}.bvh", window)
    return resolve_inputs([str(folder)])


@contextlib.contextmanager
def local_ray_head(cpus: int) -> Iterator[str]:
    """A Ray head on 127.0.0.1 in its own process group, ended (only it) on the way out."""
    ports = []
    for _ in range(7):
        with socket.socket() as s:
            s.bind(("127.0.0.1", 0))
            ports.append(s.getsockname()[1])
    gcs, client, *agents = ports
    ray = str(Path(sys.executable).with_name("ray"))
    env = os.environ | {"RAY_USAGE_STATS_ENABLED": "0"}
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(Path.cwd()), env.get("PYTHONPATH")]))
    command = [
        ray, "start", "--head", "--block", "--node-ip-address=127.0.0.1", f"--port={gcs}",
        f"--num-cpus={cpus}", "--include-dashboard=false", f"--dashboard-port={agents[0]}",
        f"--dashboard-agent-listen-port={agents[1]}", f"--dashboard-agent-grpc-port={agents[2]}",
        f"--metrics-export-port={agents[3]}", f"--runtime-env-agent-port={agents[4]}",
        f"--ray-client-server-port={client}", "--object-store-memory=200000000",
    ]  # fmt: skip
    head = subprocess.Popen(
        command, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
        start_new_session=True,
    )  # fmt: skip
    address = f"127.0.0.1:{gcs}"
    try:
        for _ in range(120):
            status = subprocess.run([ray, "status", f"--address={address}"], env=env,
                                    capture_output=True, text=True)  # fmt: skip
            if status.returncode == 0 and "CPU" in status.stdout:
                break
            if head.poll() is not None:
                raise SystemExit(f"ray start ended with status {head.returncode}")
            time.sleep(1.0)
        else:
            raise SystemExit("the Ray head did not come up in 2 minutes")
        yield address
    finally:
        if head.poll() is None:
            head.send_signal(signal.SIGTERM)
            with contextlib.suppress(subprocess.TimeoutExpired):
                head.wait(30)
        with contextlib.suppress(ProcessLookupError):
            os.killpg(head.pid, signal.SIGKILL)


def timed(
    clips: list[ClipInput], out: Path, jobs: int, cluster: str | None
) -> tuple[float, list[ClipResult]]:
    robot, config = ironcub(), RetargetConfig()
    began = time.perf_counter()
    with contextlib.redirect_stdout(io.StringIO()):
        results = run_retarget(clips, out, config, jobs, robot, cluster)
    wall = time.perf_counter() - began
    failed = [r.name for r in results if r.output is None]
    if failed:
        raise SystemExit(f"failed: {failed}")
    return wall, results


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--clips", type=int, default=20)
    parser.add_argument("--frames", type=int, default=240, help="frames per clip (120 Hz)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        (root / "in").mkdir()
        clips = make_clips(root / "in", args.clips, args.frames)
        frames = sum(load_mocap(c.path).frames for c in clips)
        print(f"{len(clips)} clips, {frames} frames, default retarget config (balance filter)")
        runs = {}
        runs["--jobs 1"] = (1, *timed(clips, root / "jobs1", 1, None))
        runs["--jobs 2"] = (2, *timed(clips, root / "jobs2", 2, None))
        began = time.perf_counter()
        with local_ray_head(2) as address:
            started = time.perf_counter() - began
            runs["--cluster (2 CPUs)"] = (2, *timed(clips, root / "ray", 2, address))
        print(f"(the Ray head took {started:.1f} s to start; not counted below)\n")
        print(f"{'backend':<20} {'wall [s]':>9} {'clips/s':>8} {'task sum [s]':>13} "
              f"{'overhead/task [s]':>18} {'speed-up':>9}")  # fmt: skip
        base = runs["--jobs 1"][1]
        for name, (workers, wall, results) in runs.items():
            work = sum(r.seconds for r in results)
            overhead = (wall * workers - work) / len(results)
            print(f"{name:<20} {wall:9.2f} {len(results) / wall:8.2f} {work:13.2f} "
                  f"{overhead:18.3f} {base / wall:9.2f}")  # fmt: skip
        reference = {p.name: p.read_bytes() for p in (root / "jobs1").glob("*.mcap")}
        same = all(
            {p.name: p.read_bytes() for p in (root / folder).glob("*.mcap")} == reference
            for folder in ("jobs2", "ray")
        )
        print(f"\nclip files byte-identical across the three: {'yes' if same else 'NO'}")


if __name__ == "__main__":
    main()
