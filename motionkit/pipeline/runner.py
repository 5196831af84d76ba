"""One pipeline run: the stages in order for one robot, each run or found cached, then the
table of what was made and OUT/pipeline_summary.json."""

from __future__ import annotations

import json
import time
from pathlib import Path

from motionkit.core.errors import MotionkitError, PipelineError
from motionkit.files.outputs import claim_out, write_text_atomic
from motionkit.pipeline.cache import STAGING, Outcome
from motionkit.pipeline.config import PipelineConfig
from motionkit.pipeline.stages import STAGE_FOLDERS, STAGES, Context, DryRun
from motionkit.robot import Robot
from motionkit.runtime.progress import Progress, silent

STAGE_NAMES = tuple(name for name, _ in STAGES)
# what a run writes in OUT: the stage folders, the cache records, the staging area, the summary
OUT_NAMES = (*STAGE_FOLDERS, ".pipeline", STAGING, "pipeline_summary.json")


def run_pipeline(
    config: PipelineConfig,
    out: Path,
    robot: Robot,
    *,
    mocap_dir: Path | None = None,
    full: bool = False,
    force: bool = False,
    fetch: bool = False,
    until: str | None = None,
    cluster: str | None = None,
    progress: Progress = silent,
) -> list[Outcome]:
    """Run every stage up to `until` (default: all) into its folder of `out` for `robot`.

    The retarget clips and the trajopt library run on the Ray cluster at `cluster`, if given;
    PipelineError naming the stage when one fails (its previous output is kept). `progress`
    receives the stages' lines and the table of what was made. A stage whose inputs are
    unchanged is found cached; the run also writes OUT/pipeline_summary.json.

    Args:
        config: the pipeline's recipes, one per stage.
        out: the output folder (OUT): walk/, flight/, jet/, datasets/, train/.
        robot: the robot every stage works on.
        mocap_dir: retarget every .bvh/.amc under this folder instead of the recipe's clips.
        full: train with the paper's GPU recipe, not the tiny one.
        force: run every stage, cached or not.
        fetch: retarget the CMU clips of the fetch recipe, downloaded into the cache.
        until: the last stage to run, one of STAGE_NAMES (None: all).
        cluster: the address of a Ray cluster for the retarget clips and the flight library
            (None: local processes).
        progress: called with each line of progress.

    Returns:
        One Outcome per stage run, in order: stage, status ('ran' or 'cached'), seconds, what
        it made, its output folder and its cache key.

    Raises:
        PipelineError: an unknown `until`; a recipe or input a stage refuses (checked before
            OUT is made); an `out` that holds files motionkit did not write; or a stage that
            fails, naming it.
    """
    if until is not None and until not in STAGE_NAMES:
        raise PipelineError(f"unknown stage '{until}'; the stages: {', '.join(STAGE_NAMES)}")
    ctx = Context(config, Path(out).resolve(), robot, mocap_dir, full, force, fetch, cluster,
                  progress=progress)  # fmt: skip
    last = STAGE_NAMES.index(until or STAGE_NAMES[-1])
    dry = DryRun(config, ctx.out, robot, mocap_dir, full, force, fetch, cluster)
    for name, stage in STAGES[: last + 1]:  # every recipe and input checked before OUT is made
        try:
            stage(dry)
        except MotionkitError as exc:
            raise PipelineError(f"stage {name}: {exc}") from exc
    claim_out(ctx.out, OUT_NAMES, PipelineError)
    start = time.perf_counter()
    outcomes = []
    for number, (name, stage) in enumerate(STAGES[: last + 1], 1):
        progress(f"\n=== [{number}/{last + 1}] {name}")
        tick = time.perf_counter()
        try:
            outcome = stage(ctx)
        except MotionkitError as exc:  # bad input or a failed solve; a bug keeps its traceback
            seconds = time.perf_counter() - tick
            raise PipelineError(f"stage {name} failed after {seconds:.0f} s: {exc}") from exc
        outcomes.append(outcome)
        if outcome.status == "cached":
            progress(f"cached (key {outcome.key}): {outcome.made}")
        else:
            progress(f"=== {name} done in {outcome.seconds:.0f} s: {outcome.made}")
    total = time.perf_counter() - start
    summary = {"config": str(config.source), "out": str(ctx.out), "robot": robot.name,
               "robot_hash": robot.model_hash, "seconds": round(total, 1),
               "stages": [o.to_dict() for o in outcomes]}  # fmt: skip
    write_text_atomic(ctx.out / "pipeline_summary.json", json.dumps(summary, indent=2) + "\n")
    for line in _table(outcomes, total):
        progress(line)
    return outcomes


def _table(outcomes: list[Outcome], total: float) -> list[str]:
    """What each stage made, where and how long it took."""
    lines = [f"\n{'stage':<10} {'status':<7} {'time':>7}  {'output':<34} made"]
    for o in outcomes:
        when = f"{o.seconds:.0f} s" if o.status == "ran" else "-"
        lines.append(f"{o.stage:<10} {o.status:<7} {when:>7}  {o.output:<34} {o.made}")
    return [*lines, f"total {total:.0f} s"]
