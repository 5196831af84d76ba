"""Many clips: inputs (files, folders, CMU clip ids) to MCAP files, in parallel processes, with
progress lines, the quality table and OUT/retarget_summary.json (`run_retarget`)."""

from __future__ import annotations

import json
import re
import time as clock
from collections.abc import Callable, Iterable
from contextlib import nullcontext
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

from motionkit.core.errors import MotionkitError, RetargetError
from motionkit.dataset import Source
from motionkit.files.digests import code_digest, digest, file_digest, versions
from motionkit.files.outputs import claimed_out, inside, up_to_date, write_files, write_text_atomic
from motionkit.retarget.config import CleanWalk, RetargetConfig
from motionkit.retarget.metrics import Quality
from motionkit.robot import Robot, ironcub
from motionkit.runtime.executors import Executor, open_executor
from motionkit.runtime.progress import LineProgress, Progress, silent

MOCAP_SUFFIXES = (".bvh", ".amc")
SUMMARY = "retarget_summary.json"
_CMU_NAME = re.compile(r"(?:^|[^0-9])(\d{1,3}_\d{1,2})(?:[^0-9]|$)")


@dataclass(frozen=True)
class ClipInput:
    """One mocap take to retarget: its file, the ASF of an AMC, and its CMU clip id if known."""

    path: Path
    asf: Path | None = None
    cmu_clip: str = ""

    @property
    def name(self) -> str:
        return self.path.stem


@dataclass(frozen=True)
class ClipResult:
    name: str
    source: str
    output: Path | None  # None when the clip failed
    frames: int = 0
    seconds: float = 0.0  # wall time of the whole clip, read to write
    stages: dict[str, float] = field(default_factory=dict)  # seconds per stage
    metrics: dict[str, Any] = field(default_factory=dict)  # all of them, as in its metadata
    error: str = ""
    resumed: bool = False  # kept from an earlier run (--resume): its output was up to date
    # the figures beyond the quality gate ('name value > limit'): a failed clip, or one written
    # to the keep-failed folder
    beyond: tuple[str, ...] = ()
    cause: str = ""  # what in the input likely explains a failure (see `likely_cause`)

    @property
    def quality(self) -> Quality:
        return Quality.of(self.metrics)


Report = Callable[[ClipResult, int, int], None]  # a clip's result, the clips done, their total


def resolve_inputs(
    inputs: Iterable[str], fetch: Callable[[list[str]], list[tuple[Path, Path]]] | None = None
) -> list[ClipInput]:
    """The clips named by files, folders and CMU clip ids, in order, without duplicates.

    Args:
        inputs: .bvh or .amc files (an .amc's skeleton .asf beside it), folders (searched
            recursively for both) and CMU clip ids such as "02_01".
        fetch: downloads clip ids into the cache and returns their (.amc, .asf) paths
            (default: motionkit.mocap.fetch.fetch_clips).

    Returns:
        One ClipInput per clip: its file, skeleton file (or None) and name.

    Raises:
        RetargetError: a missing path, a folder without mocap files, a file that is not a
            .bvh or .amc, or a text that is neither a path nor a clip id.
    """
    found: list[ClipInput] = []
    clip_ids: list[str] = []
    for text in inputs:
        path = Path(text)
        if path.is_dir():
            files = sorted(p for p in path.rglob("*") if p.suffix.lower() in MOCAP_SUFFIXES)
            if not files:
                raise RetargetError(f"{path}: no .bvh or .amc files in this folder")
            found += [_file_input(p) for p in files]
        elif path.is_file():
            if path.suffix.lower() not in MOCAP_SUFFIXES:
                raise RetargetError(f"{path}: not a mocap file (expected .bvh or .amc)")
            found.append(_file_input(path))
        elif path.exists():
            raise RetargetError(f"{path}: not a regular file or a folder")
        elif re.fullmatch(r"\d{1,3}_\d{1,2}", text.strip()):
            clip_ids.append(text.strip())
        else:
            raise RetargetError(f"{text}: no such file or folder, and not a CMU clip id (02_01)")
    if clip_ids:
        if fetch is None:
            from motionkit.mocap.fetch import fetch_clips as fetch
        found += [ClipInput(amc, asf, amc.stem) for amc, asf in fetch(clip_ids)]
    unique: dict[Path, ClipInput] = {}
    for clip in found:
        unique.setdefault(clip.path.resolve(), clip)
    return list(unique.values())


def _file_input(path: Path) -> ClipInput:
    match = _CMU_NAME.search(path.stem)
    return ClipInput(path, None, match[1] if match else "")


def encode_clip(
    clip: ClipInput,
    config: RetargetConfig,
    robot: Robot,
    progress: Callable[[int, int], None] | None = None,
) -> tuple[ClipResult, bytes]:
    """Read and retarget one clip for `robot`: its result (no output yet) and the bytes of its
    MCAP file; errors become the result's `error` (and no bytes)."""
    from motionkit.dataset import encode
    from motionkit.mocap import load_mocap
    from motionkit.retarget.core import CMU_ACKNOWLEDGEMENT, CMU_LICENCE, retarget, span_frames

    began = clock.perf_counter()
    try:
        motion = load_mocap(clip.path, asf=clip.asf)
    except MotionkitError as exc:
        return ClipResult(clip.name, str(clip.path), None, error=str(exc)), b""
    read = clock.perf_counter()
    cmu = bool(clip.cmu_clip)
    source = Source(
        file=clip.path.name,
        clip=clip.cmu_clip or clip.name,
        licence=CMU_LICENCE if cmu else "",
        acknowledgement=CMU_ACKNOWLEDGEMENT if cmu else "",
    )
    span = config.trim.get(clip.name)
    frames = motion.frames
    if span is not None:  # the frames core.trimmed keeps
        first, last = span_frames(motion.rate, span)
        frames = last - first + 1
    total = frames * (config.balance.passes + 1)  # the balance filter solves again
    step = None if progress is None else (lambda t: progress(t + 1, total))
    try:
        trajectory, timings = retarget(
            motion.landmarks(), motion.rate, robot, config, source, step, span
        )
        solved = clock.perf_counter()
        data = encode(trajectory, robot)
        encoded = clock.perf_counter()
    except MotionkitError as exc:
        cause = likely_cause(clip, motion.format)
        error = f"{exc}; likely cause: {cause}" if cause else str(exc)
        return ClipResult(clip.name, str(clip.path), None, error=error, cause=cause), b""
    stages = {
        "read": read - began,
        "targets": timings.targets,
        "ik": timings.ik,
        "metrics": timings.metrics,
        "write": encoded - solved,
    }
    metrics = dict(trajectory.metadata.metrics)
    result = ClipResult(clip.name, str(clip.path), None, frames, encoded - began, stages, metrics)
    if result.quality.beyond(config.quality):
        result = replace(result, cause=likely_cause(clip, motion.format))
    return result, data


def likely_cause(clip: ClipInput, kind: str) -> str:
    """What in a clip's input likely explains its failure, as a phrase, or "": for ASF/AMC,
    joint angles that look like the other angle unit than the one they are read in
    (motionkit.mocap.asf_amc.angle_unit_hint)."""
    from motionkit.mocap.asf_amc import angle_unit_hint, find_asf

    if kind != "asf/amc":
        return ""
    try:
        asf = clip.asf if clip.asf is not None else find_asf(clip.path)
    except MotionkitError:
        return ""
    return angle_unit_hint(clip.path, asf)


def retarget_clip(
    clip: ClipInput,
    out: Path,
    config: RetargetConfig,
    robot: Robot | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> ClipResult:
    """Read, retarget and write one clip as OUT/<name>.mcap.

    Args:
        clip: the clip (`resolve_inputs`).
        out: the output folder.
        config: the retargeting config.
        robot: the robot to retarget onto (default iRonCub).
        progress: called with (frames done, frames in all) as the IK goes.

    Returns:
        The clip's result: its output path, frames, quality figures and stage times; or, for a
        clip that could not be read or retargeted or is beyond `config.quality`, its `error`
        (and nothing written).
    """
    try:
        inside(out, f"{clip.name}.mcap", RetargetError)
    except MotionkitError as exc:
        return ClipResult(clip.name, str(clip.path), None, error=str(exc))
    result, data = encode_clip(clip, config, robot or ironcub(), progress)
    return result if result.error else _gated(result, data, config.quality, out)


def _gated(
    result: ClipResult,
    data: bytes,
    clean: CleanWalk,
    out: Path,
    key: str = "",
    keep_failed: Path | None = None,
) -> ClipResult:
    """A clip within the quality gate written to OUT; one beyond it a failure (its figures
    kept in the result), or written to `keep_failed` instead where one is given."""
    beyond = tuple(result.quality.beyond(clean))
    if not beyond:
        return _write(result, out, data, key)
    if keep_failed is not None:
        return replace(_write(result, keep_failed, data), beyond=beyond)
    cause = f"; likely cause: {result.cause}" if result.cause else ""
    figures = ", ".join(beyond)
    error = f"beyond the clean figures: {figures}{cause} (--keep-failed DIR writes it there)"
    return replace(result, error=error, beyond=beyond)


def _write(result: ClipResult, out: Path, data: bytes, key: str = "") -> ClipResult:
    """`data` written as OUT/<name>.mcap (its task `key` recorded); the result with its output
    and the write in its times."""
    began = clock.perf_counter()
    write_files(out, {f"{result.name}.mcap": data}, key)
    seconds = clock.perf_counter() - began
    stages = result.stages | {"write": result.stages.get("write", 0.0) + seconds}
    path = Path(out) / f"{result.name}.mcap"
    return replace(result, output=path, seconds=result.seconds + seconds, stages=stages)


def clip_key(clip: ClipInput, config: RetargetConfig, robot: Robot) -> str:
    """The hash of everything a clip's output depends on (its input files, the config, the
    robot, the code and the IK libraries): an output recorded with it is up to date."""
    asf = file_digest(clip.asf) if clip.asf else None
    return digest(
        "retarget clip",
        clip.name,
        clip.cmu_clip,
        file_digest(clip.path),
        asf,
        replace(config, clips=()).to_dict(),
        robot.model_hash,
        code_digest(__name__),
        versions("placo", "pin"),
    )


def retarget_all(
    clips: list[ClipInput],
    out: Path,
    config: RetargetConfig,
    executor: Executor,
    robot: Robot,
    report: Report | None = None,
    *,
    resume: bool = False,
    frames: bool = False,
    keep_failed: Path | None = None,
) -> list[ClipResult]:
    """Retarget every clip into OUT on an executor.

    The workers return the clips and this process writes them.

    Args:
        clips: the clips, their names distinct (`check_names`).
        out: the output folder (claimed by the caller: `run_retarget`).
        config: the retargeting config.
        executor: where the clips run (motionkit.runtime.executors.open_executor).
        robot: the robot to retarget onto.
        report: receives (result, clips done, clips in all) as each clip ends.
        resume: keep the clips whose output is up to date (`clip_key`).
        frames: a clip retargeted in this process draws its frames done on stderr.
        keep_failed: a folder (claimed by the caller) for the clips beyond the quality gate
            (`config.quality`); without one they fail and are not written.

    Returns:
        Every clip's result, in input order (failed ones without output).
    """
    keys = [clip_key(clip, config, robot) for clip in clips]
    results: dict[int, ClipResult] = {}

    def finish(i: int, result: ClipResult) -> None:
        results[i] = result
        if report is not None:
            report(result, len(results), len(clips))

    todo = []
    for i, clip in enumerate(clips):
        kept = _kept(clip, out, keys[i]) if resume else None
        if kept is None:
            todo.append(i)
        else:
            finish(i, kept)
    shared = (config, robot, frames and executor.in_process)
    names = [clips[i].name for i in todo]
    for done in executor.run(_retarget_task, [clips[i] for i in todo], names, shared):
        i = todo[done.index]
        if done.value is None:
            finish(i, ClipResult(clips[i].name, str(clips[i].path), None, error=done.lost))
            continue
        result, data = done.value
        if not result.error:
            result = _gated(result, data, config.quality, out, keys[i], keep_failed)
        finish(i, result)
    return [results[i] for i in range(len(clips))]


def _retarget_task(
    clip: ClipInput, shared: tuple[RetargetConfig, Robot, bool]
) -> tuple[ClipResult, bytes]:
    """One clip in a worker (or here, with a frame progress line when the flag says)."""
    config, robot, bar = shared
    progress = _FrameBar(clip.name) if bar else None
    try:
        return encode_clip(clip, config, robot, progress)
    finally:
        if progress is not None:
            progress.close()


def _kept(clip: ClipInput, out: Path, key: str) -> ClipResult | None:
    """The result of a clip whose output in `out` is up to date (from its metadata), or None."""
    from motionkit.dataset import read_metadata

    name = f"{clip.name}.mcap"
    if not up_to_date(out, [name], key):
        return None
    try:
        metadata, record = read_metadata(Path(out) / name)
    except MotionkitError:
        return None  # unreadable: made again
    frames = int(record["frames"])
    return ClipResult(clip.name, str(clip.path), Path(out) / name, frames,
                      metrics=dict(metadata.metrics), resumed=True)  # fmt: skip


def check_names(clips: list[ClipInput]) -> None:
    """RetargetError unless there are clips and no two write the same file."""
    if not clips:
        raise RetargetError("nothing to retarget: give files, folders or CMU clip ids")
    names = [c.name for c in clips]
    clash = sorted({n for n in names if names.count(n) > 1})
    if clash:
        raise RetargetError(f"two inputs would write the same output file: {clash}")


class _FrameBar:
    """Frames done of one clip (motionkit.runtime.progress: a rewritten line on a terminal)."""

    def __init__(self, name: str) -> None:
        self.line = LineProgress(name)

    def __call__(self, done: int, total: int) -> None:
        self.line.show(f"IK frame {done}/{total}")

    def close(self) -> None:
        self.line.close(keep=False)  # the clip's summary line follows


def run_retarget(
    clips: list[ClipInput],
    out: Path,
    config: RetargetConfig,
    jobs: int = 1,
    robot: Robot | None = None,
    cluster: str | None = None,
    resume: bool = False,
    *,
    progress: Progress = silent,
    report: Report | None = None,
    frames: bool = False,
    keep_failed: Path | None = None,
) -> list[ClipResult]:
    """Retarget a batch of clips into OUT and write OUT/retarget_summary.json.

    Args:
        clips: the clips (`resolve_inputs`), their names distinct.
        out: the output folder; one holding files of those names that motionkit did not write
            is refused.
        config: the retargeting config.
        jobs: local worker processes.
        robot: the robot to retarget onto (default iRonCub).
        cluster: a Ray cluster address to run the clips on instead (an unreachable one writes
            nothing).
        resume: keep the clips whose outputs are up to date.
        progress: receives the lines of `motionkit retarget`: the batch's, each clip's as it
            comes (`clip_line`), the quality table.
        report: receives each clip's result instead of its `clip_line` (result, done, total).
        frames: see `retarget_all`.
        keep_failed: another folder, where the clips beyond the quality gate are written
            (with their figures in their metadata) instead of failing.

    Returns:
        Every clip's result, in input order (failed ones without output).

    Raises:
        RetargetError: clips of the same name, or an output folder that cannot be used.
    """
    check_names(clips)
    if keep_failed is not None and Path(keep_failed).absolute() == Path(out).absolute():
        raise RetargetError(f"--keep-failed {keep_failed}: give another folder than --out")
    robot = robot or ironcub()
    unused = sorted(set(config.trim) - {c.name for c in clips})
    if unused:
        progress(f"note: trim names no clip among the inputs: {', '.join(unused)}")
    names = [f"{c.name}.mcap" for c in clips] + [SUMMARY]
    report = report or (lambda result, done, total: progress(clip_line(result, done, total)))
    inline = jobs <= 1 or len(clips) == 1
    with open_executor(min(jobs, len(clips)), cluster, RetargetError, inline) as executor:
        progress(f"retargeting {len(clips)} clip(s) into {out} with {executor.where}")
        held = (
            nullcontext()
            if keep_failed is None
            else claimed_out(keep_failed, names[:-1], RetargetError)
        )
        with claimed_out(out, names, RetargetError), held:
            results = retarget_all(clips, out, config, executor, robot, report, resume=resume,
                                   frames=frames, keep_failed=keep_failed)  # fmt: skip
            if any(r.output is not None and not r.beyond for r in results):  # in OUT
                summary = {"config": config.to_dict(), "clips": [_result_json(r) for r in results]}
                write_text_atomic(out / SUMMARY, json.dumps(summary, indent=2))
    for line in summary_lines(results, config.quality):
        progress(line)
    return results


def clip_line(result: ClipResult, done: int, total: int) -> str:
    """The line of a clip as it comes (`done` of `total`): failed, kept or retargeted."""
    clip = f"[{done}/{total}] {result.name}"
    if result.output is None:
        return f"{clip}: failed: {result.error}"
    if result.resumed:
        return f"{clip}: up to date, kept -> {result.output}"
    if result.beyond:
        cause = f"; likely cause: {result.cause}" if result.cause else ""
        figures = ", ".join(result.beyond)
        return f"{clip}: beyond the clean figures ({figures}{cause}) -> {result.output}"
    rate = result.frames / result.seconds if result.seconds else 0.0
    return (
        f"{clip}: {result.frames} frames in {result.seconds:.2f} s ({rate:.0f} frames/s) "
        f"-> {result.output}"
    )


def summary_lines(results: list[ClipResult], clean: CleanWalk | None = None) -> list[str]:
    """The quality table of a batch (against `clean`), then what it kept (--resume), what it
    wrote to the keep-failed folder and what failed."""
    lines = quality_table(results, clean)
    kept = sum(r.resumed for r in results)
    if kept:
        lines.append(f"{kept} of {len(results)} clip(s) up to date and kept (--resume)")
    held = [r for r in results if r.beyond and r.output is not None]
    if held:
        folder = held[0].output.parent
        lines.append(f"{len(held)} clip(s) beyond the clean figures written to {folder}")
    failed = sum(r.output is None for r in results)
    if failed:
        lines.append(f"{failed} of {len(results)} clip(s) failed; nothing written for them")
    return lines


def quality_table(results: list[ClipResult], clean: CleanWalk | None = None) -> list[str]:
    """A line per clip of its quality figures, flagged where beyond those of a clean walk
    (`clean`, default the gate's defaults)."""
    clean = clean or CleanWalk()
    header = (
        f"{'clip':<18} {'frames':>6} {'slide p95':>9} {'source':>7} {'sink':>6} {'limits':>6} "
        f"{'feet':>6} {'knees':>6} {'clear':>7}  check"
    )
    lines = [f"\n{header}\n{'':<18} {'':>6} {'[cm/s]':>9} {'[cm/s]':>7} {'[mm]':>6} {'':>6} "
             f"{'[cm]':>6} {'[cm]':>6} {'[cm]':>7}"]  # fmt: skip
    for r in results:
        if not r.metrics:
            lines.append(f"{r.name:<18} failed: {r.error}")
            continue
        q = r.quality
        violations = q.joint_position_violations + q.joint_velocity_violations
        problems = q.beyond(clean)
        check = "ok" if not problems else "beyond: " + ", ".join(problems)
        check = f"FAILED, {check}" if r.output is None else check
        lines.append(
            f"{r.name:<18} {r.frames:>6} {100 * q.foot_slide_p95_m_s:>9.2f} "
            f"{100 * q.source_slide_p95_m_s:>7.1f} "
            f"{1000 * q.penetration_max_m:>6.2f} {violations:>6d} "
            f"{100 * q.feet_error_mean_m:>6.2f} "
            f"{100 * q.knees_error_mean_m:>6.2f} "
            f"{100 * q.closest_approach_m:>7.1f}  "
            f"{check}"
        )
    limits = ", ".join(f"{name} <= {limit}" for name, limit in asdict(clean).items())
    lines.append(f"(clean: {limits})")
    return lines


def _result_json(result: ClipResult) -> dict[str, Any]:
    return {
        "name": result.name,
        "source": result.source,
        "output": result.output.name if result.output and not result.beyond else None,
        "kept_failed": str(result.output) if result.output and result.beyond else None,
        "beyond": list(result.beyond),
        "frames": result.frames,
        "seconds": result.seconds,
        "stages_s": result.stages,
        "metrics": result.metrics,
        "error": result.error,
        "cause": result.cause,
        "resumed": result.resumed,
    }
