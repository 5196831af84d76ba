"""`motionkit dataset info|validate|export`: thin wrappers over motionkit.dataset."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from motionkit.dataset.clip import read
from motionkit.dataset.collection import MotionDataset, find_clips
from motionkit.dataset.export import FORMATS, export
from motionkit.dataset.validate import Check, validate_clip
from motionkit.errors import DatasetError

EPILOG = """\
PATH is an MCAP clip or a folder of clips (searched recursively). Clips hold the motion on
/motion (motionkit.MotionChunk, protobuf), the robot's frames on /tf (foxglove.FrameTransforms)
and a 'motionkit' metadata record; Foxglove and the mcap CLI open them as they are."""


def add_commands(stages: argparse._SubParsersAction, robot_source: Any) -> None:
    dataset = stages.add_parser(
        "dataset",
        help="inspect, validate and export MCAP motion datasets",
        description="MCAP motion datasets: one file per clip.",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    commands = dataset.add_subparsers(dest="dataset_command", required=True, metavar="ACTION")
    info = commands.add_parser(
        "info", help="clips, durations, rates, labels, sources, metrics", epilog=EPILOG
    )
    info.add_argument("paths", nargs="+", type=Path, metavar="PATH")
    info.add_argument("--json", action="store_true", help="print JSON instead of a table")
    info.set_defaults(handler=_info)

    validate = commands.add_parser(
        "validate",
        help="check clips (schema, CRCs, time, values, velocities, robot limits)",
        description="Check every clip; print a report; exit 1 when a check fails. The robot is "
        "iRonCub unless --urdf/--spec name another.",
        epilog=EPILOG,
    )
    validate.add_argument("paths", nargs="+", type=Path, metavar="PATH")
    robot_source(validate)
    validate.set_defaults(handler=_validate)

    exporter = commands.add_parser(
        "export",
        help="write clips as .npz arrays or amp-rsl-rl .npy dicts",
        description="npz: every array, the names and the metadata (JSON). amp-rsl-rl: the .npy "
        "dict that amp-rsl-rl's motion loader reads (joints_list, joint_positions, root_position, "
        "root_quaternion in x,y,z,w order, fps).",
        epilog=EPILOG,
    )
    exporter.add_argument("paths", nargs="+", type=Path, metavar="PATH")
    exporter.add_argument("--format", choices=FORMATS, required=True)
    exporter.add_argument("--out", type=Path, required=True, help="output folder")
    exporter.set_defaults(handler=_export)


def _info(args: argparse.Namespace) -> int:
    dataset = MotionDataset(args.paths)
    rows = [
        {
            "path": str(clip.path),
            "kind": clip.label,
            "frames": clip.frames,
            "duration_s": round(clip.duration, 4),
            "rate_hz": round(clip.rate, 4),
            "robot": clip.metadata.robot,
            "robot_hash": clip.metadata.robot_hash,
            "generator": clip.metadata.generator,
            "source": vars(clip.metadata.source),
            "metrics": clip.metadata.metrics,
        }
        for clip in dataset.clips
    ]
    if args.json:
        print(json.dumps(rows, indent=2))
        return 0
    print(f"{'clip':<28} {'kind':<9} {'frames':>8} {'seconds':>9} {'Hz':>7}  generator  source")
    for row in rows:
        source = row["source"]
        origin = source["clip"] or source["file"] or "-"
        print(
            f"{Path(row['path']).stem:<28} {row['kind']:<9} {row['frames']:>8} "
            f"{row['duration_s']:>9.2f} {row['rate_hz']:>7.1f}  {row['generator']:<9}  {origin}"
            + (f" ({source['licence']})" if source["licence"] else "")
        )
        for name, value in row["metrics"].items():
            print(f"{'':<30}{name} = {value}")
    labels: dict[str, float] = {}
    for clip in dataset.clips:
        labels[clip.label] = labels.get(clip.label, 0.0) + clip.duration
    summary = ", ".join(f"{k} {v:.1f} s" for k, v in sorted(labels.items()))
    print(f"\n{len(dataset)} clips, {dataset.duration:.1f} s: {summary}")
    return 0


def _validate(args: argparse.Namespace) -> int:
    from motionkit.robot import load_robot

    robot = load_robot(args.urdf, args.spec)
    failed = 0
    for path in find_clips(args.paths):
        checks = validate_clip(path, robot)
        bad = [c for c in checks if not c.ok]
        failed += bool(bad)
        print(f"{path}: {'FAILED' if bad else 'ok'}")
        for check in checks:
            _print_check(check)
    print(f"\n{failed} clip(s) failed" if failed else "\nall clips passed")
    return 1 if failed else 0


def _print_check(check: Check) -> None:
    print(f"  [{'ok' if check.ok else 'FAIL'}] {check.name}: {check.detail}")


def _export(args: argparse.Namespace) -> int:
    paths = find_clips(args.paths)
    stems = [p.stem for p in paths]
    duplicates = sorted({s for s in stems if stems.count(s) > 1})
    if duplicates:
        raise DatasetError(f"clips with the same name would overwrite each other: {duplicates}")
    trajectories = [read(path) for path in paths]  # every clip read before anything is written
    for path, trajectory in zip(paths, trajectories, strict=True):
        written = export(trajectory, path.stem, args.out, args.format)
        print(f"wrote {written} ({trajectory.frames} frames)")
    return 0
