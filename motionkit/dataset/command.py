"""`motionkit dataset info|validate|export`: thin wrappers over motionkit.dataset."""

from __future__ import annotations

import argparse
import json
from dataclasses import asdict
from pathlib import Path
from typing import Any

from motionkit.core.errors import DatasetError
from motionkit.dataset.clip import read
from motionkit.dataset.collection import MotionDataset, find_clips
from motionkit.dataset.export import FORMATS, export
from motionkit.dataset.physics import PhysicsConfig, check_physics
from motionkit.dataset.validate import Check, read_sound, read_valid, validate_clip
from motionkit.files.outputs import check_writable

PHYSICS_HELP = (
    "a TOML file of physics-check settings and thresholds (keys of "
    "motionkit.dataset.physics.PhysicsConfig; default: its defaults)"
)
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
        "info",
        help="clips, durations, rates, labels, sources, metrics",
        description="List the clips. Each is read whole first (schema, metadata, CRCs, "
        "increasing times, finite values, unit quaternions): a damaged clip is an error naming "
        "it, not a row.",
        epilog=EPILOG,
    )
    info.add_argument("paths", nargs="+", type=Path, metavar="PATH")
    info.add_argument("--json", action="store_true", help="print JSON instead of a table")
    info.add_argument(
        "--index-only",
        action="store_true",
        help="read only each clip's index and metadata (fast; a damaged motion goes unnoticed)",
    )
    info.set_defaults(handler=_info)

    validate = commands.add_parser(
        "validate",
        help="check clips (schema, CRCs, time, values, velocities, robot limits)",
        description="Check every clip; print a report; exit 1 when a check fails. The robot is "
        "iRonCub unless --urdf/--spec name another.",
        epilog=EPILOG,
    )
    validate.add_argument("paths", nargs="+", type=Path, metavar="PATH")
    validate.add_argument("--physics", type=Path, metavar="TOML", help=PHYSICS_HELP)
    robot_source(validate)
    validate.set_defaults(handler=_validate)

    physics = commands.add_parser(
        "check-physics",
        help="inverse dynamics along clips: torques, centre of pressure, friction, residual",
        description="Inverse dynamics (pinocchio) along each clip: joint torques against the "
        "effort limits, the centre of pressure of the ground wrench the motion needs against the "
        "support polygon, friction-cone use, and the base wrench that contacts and thrust "
        "cannot explain. Contact forces are the clip's own where it has them (trajopt), else "
        "the least-squares split over the sole corners on the floor. Exit 1 when a clip falls "
        "short of a threshold (--physics).",
        epilog=EPILOG,
    )
    physics.add_argument("paths", nargs="+", type=Path, metavar="PATH")
    physics.add_argument("--json", action="store_true", help="print JSON instead of a table")
    physics.add_argument("--physics", type=Path, metavar="TOML", help=PHYSICS_HELP)
    robot_source(physics)
    physics.set_defaults(handler=_check_physics)

    exporter = commands.add_parser(
        "export",
        help="write clips as .npz arrays or amp-rsl-rl .npy dicts",
        description="npz: every array, the names and the metadata (JSON). amp-rsl-rl: the .npy "
        "dict that amp-rsl-rl's motion loader reads (joints_list, joint_positions, root_position, "
        "root_quaternion in x,y,z,w order, fps). Every clip must pass the checks of `dataset "
        "validate` against the robot (iRonCub unless --urdf/--spec name another) before "
        "anything is written.",
        epilog=EPILOG,
    )
    exporter.add_argument("paths", nargs="+", type=Path, metavar="PATH")
    exporter.add_argument("--format", choices=FORMATS, required=True)
    exporter.add_argument("--out", type=Path, required=True, help="output folder")
    robot_source(exporter)
    exporter.set_defaults(handler=_export)


def _info(args: argparse.Namespace) -> int:
    dataset = MotionDataset(args.paths)
    if not args.index_only:
        _check_sound([clip.path for clip in dataset.clips])
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
        source = {k: _printable(v) for k, v in row["source"].items()}
        origin = source["clip"] or source["file"] or "-"
        print(
            f"{_printable(Path(row['path']).stem):<28} {row['kind']:<9} {row['frames']:>8} "
            f"{row['duration_s']:>9.2f} {row['rate_hz']:>7.1f}  {row['generator']:<9}  {origin}"
            + (f" ({source['licence']})" if source["licence"] else "")
        )
        for name, value in row["metrics"].items():
            print(f"{'':<30}{_printable(name)} = {_printable(str(value))}")
    labels: dict[str, float] = {}
    for clip in dataset.clips:
        labels[clip.label] = labels.get(clip.label, 0.0) + clip.duration
    summary = ", ".join(f"{k} {v:.1f} s" for k, v in sorted(labels.items()))
    print(f"\n{len(dataset)} clips, {dataset.duration:.1f} s: {summary}")
    return 0


def _printable(text: str) -> str:
    """A clip's text for the terminal: control characters (escape sequences, newlines) shown
    escaped, not sent."""
    return "".join(c if c.isprintable() else ascii(c)[1:-1] for c in text)


def _check_sound(paths: list[Path]) -> None:
    """A DatasetError naming every clip that is not sound (see `read_sound`)."""
    problems = []
    for path in paths:
        try:
            read_sound(path)
        except DatasetError as exc:
            problems.append(str(exc))
    if len(problems) == 1:
        raise DatasetError(problems[0])
    if problems:
        raise DatasetError(f"{len(problems)} damaged clips: {'; '.join(problems)}")


def _validate(args: argparse.Namespace) -> int:
    from motionkit.robot import load_robot

    physics = _physics_config(args.physics)
    robot = load_robot(args.urdf, args.spec)
    failed = warned = 0
    for path in find_clips(args.paths):
        checks = validate_clip(path, robot, physics)
        bad = [c for c in checks if not c.ok and not c.warning]
        failed += bool(bad)
        warned += any(not c.ok and c.warning for c in checks)
        print(f"{path}: {'FAILED' if bad else 'ok'}")
        for check in checks:
            _print_check(check)
    print(f"\n{failed} clip(s) failed" if failed else "\nall clips passed")
    if warned:
        print(f"{warned} clip(s) with physics warnings")
    return 1 if failed else 0


def _print_check(check: Check) -> None:
    status = "ok" if check.ok else "WARN" if check.warning else "FAIL"
    print(f"  [{status}] {check.name}: {check.detail}")


def _physics_config(path: Path | None) -> PhysicsConfig:
    return PhysicsConfig.from_toml(path) if path is not None else PhysicsConfig()


# (figure, column title, width) of the check-physics table
PHYSICS_COLUMNS = (
    ("frames", "frames", 7),
    ("single_support_frames", "single", 7),
    ("torque_within_share", "tau ok", 7),
    ("torque_ratio_p90", "tau p90", 8),
    ("worst_joint", "worst joint", 16),
    ("cop_inside_share", "CoP in", 7),
    ("cop_inside_share_single_support", "CoP in 1", 9),
    ("friction_within_share", "mu ok", 6),
    ("explained_share", "explained", 10),
    ("residual_force_p95_bw", "resid p95", 10),
)


def _check_physics(args: argparse.Namespace) -> int:
    from motionkit.robot import load_robot

    config = _physics_config(args.physics)
    robot = load_robot(args.urdf, args.spec)
    rows, short = [], 0
    for path in find_clips(args.paths):
        report = check_physics(read(path), robot, config)
        warnings = report.warnings()
        short += bool(warnings)
        rows.append({"path": str(path), **report.summary(), "warnings": warnings})
    if args.json:
        print(json.dumps({"config": asdict(config), "clips": rows}, indent=2))
        return 1 if short else 0
    print(f"{'clip':<28}" + "".join(f"{title:>{width}} " for _, title, width in PHYSICS_COLUMNS))
    for row in rows:
        cells = "".join(f"{_cell(row[key]):>{width}} " for key, _, width in PHYSICS_COLUMNS)
        print(f"{Path(row['path']).stem[:27]:<28}{cells}")
        for warning in row["warnings"]:
            print(f"{'':<30}below threshold: {warning}")
    print(
        "\ntau ok: frames with every joint within its effort limit; CoP in: contact frames whose "
        "needed centre of pressure lies in the support (1: single support); explained: frames "
        f"whose residual is within {config.residual_tolerance} body weights; resid p95 in body "
        "weights"
    )
    return 1 if short else 0


def _cell(value: object) -> str:
    if value is None:
        return "-"
    if isinstance(value, float):
        return f"{value:.3f}"
    return str(value)


def _export(args: argparse.Namespace) -> int:
    check_writable(args.out, DatasetError)
    paths = find_clips(args.paths)
    stems = [p.stem for p in paths]
    duplicates = sorted({s for s in stems if stems.count(s) > 1})
    if duplicates:
        raise DatasetError(f"clips with the same name would overwrite each other: {duplicates}")
    from motionkit.robot import load_robot

    robot = load_robot(args.urdf, args.spec)
    # every clip read and checked before anything is written
    trajectories = [read_valid(path, robot) for path in paths]
    for path, trajectory in zip(paths, trajectories, strict=True):
        written = export(trajectory, path.stem, args.out, args.format)
        print(f"wrote {written} ({trajectory.frames} frames)")
    return 0
