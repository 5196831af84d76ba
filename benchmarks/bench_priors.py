"""Can the robot perform its walking priors? The walk recipe against the plain retargeter.

    python benchmarks/bench_priors.py [CLIP ...] [--recipe sample_walks] [--slowdown N]

Clips default to the recipe's (the offline sample, motionkit/sample/cmu). Each clip is
retargeted twice in the same run: plain (the baseline: no balance filter, no swing clearance, at
the human's pace, the whole take) and with the recipe (by default the filter, a 1.5 cm swing
clearance, 1.25x slower, 11_01 trimmed to its walk). Per clip and setting: the physics check
(share of single-support frames whose needed centre of pressure lies in the stance sole; share
of single-support frames with every joint within its effort limit; worst joint), the open-loop
MuJoCo tracking (share of 1 s windows, every 0.1 s, that fall: PD plus inverse-dynamics
feed-forward, and PD alone) and the retargeter's acceptance figures (foot slide p95,
penetration, limit violations, mean foot error). Targets with the recipe: CoP inside on at
least 90 % and torques within limits on at least 90 % of single-support frames, falls at most
half of the baseline's, and the acceptance figures (slide p95 <= 1 cm/s, penetration <= 2 mm, no
limit violations, foot error <= 3 cm).
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse
import tempfile
import time
from dataclasses import replace
from pathlib import Path

from motionkit import recipes
from motionkit.cli import recipe_argument
from motionkit.dataset import read
from motionkit.dataset.physics import check_physics
from motionkit.dataset.tracking import track_windows
from motionkit.retarget.batch import ClipInput, resolve_inputs, retarget_clip
from motionkit.retarget.config import RetargetConfig
from motionkit.robot import ironcub


def measure(clip: ClipInput, config: RetargetConfig, out: Path) -> dict[str, float | str]:
    start = time.perf_counter()
    result = retarget_clip(clip, out, config)
    if result.output is None:
        raise SystemExit(f"{clip.path}: {result.error}")
    seconds = time.perf_counter() - start
    robot = ironcub()
    trajectory = read(result.output)
    physics = check_physics(trajectory, robot).summary()
    q = result.quality
    return {
        "seconds": seconds,
        "cop_single": physics["cop_inside_share_single_support"],
        "torque_single": physics["torque_within_share_single_support"],
        "worst": physics["worst_joint"],
        "falls_ff": track_windows(trajectory, robot, stride=0.1).fall_share,
        "falls_pd": track_windows(trajectory, robot, stride=0.1, feedforward=False).fall_share,
        "slide": 100 * q.foot_slide_p95_m_s,
        "sink": 1000 * q.penetration_max_m,
        "limits": q.joint_position_violations + q.joint_velocity_violations,
        "feet": 100 * q.feet_error_mean_m,
        "knees": 100 * q.knees_error_mean_m,
    }


HEADER = (
    f"{'clip':<20} {'setting':<9} {'CoP in':>7} {'tau ok':>7} {'worst':>14} {'fall ff':>8} "
    f"{'fall pd':>8} {'slide':>6} {'sink':>5} {'lim':>4} {'feet':>5} {'knees':>6} {'s':>5}"
)
UNITS = (
    f"{'':<20} {'':<9} {'single':>7} {'single':>7} {'joint':>14} {'1 s':>8} {'1 s':>8} "
    f"{'cm/s':>6} {'mm':>5} {'':>4} {'cm':>5} {'cm':>6} {'':>5}"
)


def share(value: float | None) -> str:
    return "-" if value is None else f"{value:.3f}"  # None: no frame of that kind


def row(name: str, setting: str, m: dict[str, float | str]) -> str:
    return (
        f"{name[:20]:<20} {setting:<9} {share(m['cop_single']):>7} {share(m['torque_single']):>7} "
        f"{m['worst']:>14} {m['falls_ff']:>8.3f} {m['falls_pd']:>8.3f} {m['slide']:>6.2f} "
        f"{m['sink']:>5.2f} {m['limits']:>4d} {m['feet']:>5.2f} {m['knees']:>6.2f} "
        f"{m['seconds']:>5.1f}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("clips", nargs="*", help="mocap files or folders (default: the recipe's)")
    parser.add_argument(
        "--recipe",
        type=recipe_argument("retarget"),
        default=recipes.find("retarget", "sample_walks"),
        help="retarget recipe: a file or a built-in name (default: sample_walks)",
    )
    parser.add_argument("--passes", type=int, help="balance filter passes (default: the recipe's)")
    parser.add_argument("--slowdown", type=float, help="default: the recipe's")
    args = parser.parse_args()
    recipe = RetargetConfig.from_toml(args.recipe)
    base = args.recipe.parent
    listed = [str(base / c) if (base / c).exists() else c for c in recipe.clips]
    clips = resolve_inputs(args.clips or listed)
    filtered = replace(
        recipe,
        slowdown=recipe.slowdown if args.slowdown is None else args.slowdown,
        balance=replace(recipe.balance, passes=args.passes or recipe.balance.passes),
    )
    plain = replace(
        filtered,
        balance=replace(recipe.balance, passes=0),
        swing_clearance=0.0,
        slowdown=1.0,
        trim={},
    )
    print(f"recipe {args.recipe}: slowdown {filtered.slowdown}, trim {dict(filtered.trim)}")
    print(HEADER)
    print(UNITS)
    with tempfile.TemporaryDirectory() as out:
        for clip in clips:
            print(row(clip.name, "plain", measure(clip, plain, Path(out))))
            print(row(clip.name, "recipe", measure(clip, filtered, Path(out))), flush=True)
    print(
        "\nCoP in / tau ok: single-support frames with the needed CoP in the stance sole / every "
        "joint within its effort limit; fall: share of 1 s windows that fall tracked open loop "
        "(ff: PD + inverse-dynamics feed-forward; pd: PD alone)"
    )


if __name__ == "__main__":
    main()
