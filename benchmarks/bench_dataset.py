"""MCAP motion datasets: size and read speed of one hour of 120 Hz motion (432,000 frames).

    python benchmarks/bench_dataset.py [--seconds 3600] [--windows 50]

Targets (on the 2-core dev machine): whole read <= 2 s, a random 2 s window <= 20 ms,
file <= 1.2 x the raw float32 size of the arrays. Baselines in the same run: the official mcap
reader decoding /motion into arrays with the protobuf library, and np.load of the raw arrays.
motionkit's whole read also checks the file's data-section and summary CRCs.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np
from mcap.reader import make_reader

from motionkit.dataset import read, write
from motionkit.dataset.messages import motion_chunk_class
from motionkit.dataset.synthetic import synthetic_trajectory
from motionkit.robot import ironcub


def timed(function, repeats: int = 3) -> tuple[float, object]:
    """Best wall time of `repeats` calls, and the last result."""
    best, result = float("inf"), None
    for _ in range(repeats):
        start = time.perf_counter()
        result = function()
        best = min(best, time.perf_counter() - start)
    return best, result


def official_reader(path: Path) -> int:
    """The generic route: mcap's reader (CRCs checked) and protobuf decoding of /motion into
    one array per field, as a user without motionkit would write it."""
    chunk_class = motion_chunk_class()
    fields = [f.name for f in chunk_class.DESCRIPTOR.fields]
    parts: dict[str, list[np.ndarray]] = {name: [] for name in fields}
    with open(path, "rb") as handle:
        for _, _, message in make_reader(handle, validate_crcs=True).iter_messages(["/motion"]):
            decoded = chunk_class.FromString(message.data)
            for name in fields:
                parts[name].append(np.asarray(getattr(decoded, name)))
    arrays = {name: np.concatenate(values) for name, values in parts.items()}
    return len(arrays["time"])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=3600.0)
    parser.add_argument("--windows", type=int, default=50)
    args = parser.parse_args()

    robot = ironcub()
    trajectory = synthetic_trajectory(robot, args.seconds, 120.0)
    raw = sum(v.size * 4 for v in trajectory.arrays().values())
    print(f"motion: {trajectory.frames} frames at 120 Hz ({args.seconds:.0f} s), 23 joints, 4 jets")
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "hour.mcap"
        write_time, _ = timed(lambda: write(path, trajectory, robot), repeats=1)
        size = path.stat().st_size
        npy = Path(folder) / "raw.npz"
        np.savez(npy, **trajectory.arrays())

        read_time, back = timed(lambda: read(path))
        assert back.equals(trajectory), "round trip changed the motion"
        npz_time, _ = timed(lambda: dict(np.load(npy)))
        official_time, frames = timed(lambda: official_reader(path), repeats=1)
        assert frames == trajectory.frames

        rng = np.random.default_rng(0)
        starts = rng.uniform(0, trajectory.duration - 2.0, args.windows)
        window_times = []
        for start in starts:
            begin = time.perf_counter()
            window = read(path, start, start + 2.0)
            window_times.append(time.perf_counter() - begin)
            assert window.frames in (240, 241)
        window_times = np.array(window_times) * 1e3

    ratio = size / raw
    rows = [
        ("write (incl. /tf at 15 Hz)", f"{write_time:.2f} s", ""),
        ("file size", f"{size / 1e6:.1f} MB = {ratio:.3f} x raw float32 ({raw / 1e6:.1f} MB)",
         f"target <= 1.2 x: {'PASS' if ratio <= 1.2 else 'FAIL'}"),
        ("read all (motionkit)", f"{read_time:.3f} s",
         f"target <= 2 s: {'PASS' if read_time <= 2.0 else 'FAIL'}"),
        ("  baseline: mcap reader + protobuf", f"{official_time:.3f} s",
         f"{official_time / read_time:.2f} x motionkit's time"),
        ("  baseline: np.load of raw .npz", f"{npz_time:.3f} s", ""),
        (f"random 2 s window (n={args.windows})",
         f"median {np.median(window_times):.1f} ms, max {window_times.max():.1f} ms",
         f"target <= 20 ms: {'PASS' if window_times.max() <= 20 else 'FAIL'}"),
    ]  # fmt: skip
    for name, value, verdict in rows:
        print(f"{name:<36} {value:<48} {verdict}")


if __name__ == "__main__":
    main()
