"""Real CMU walks made into takes that start, stop, turn, change pace, hop and jump
(tests/retarget/takes.py): the helpers by hand, then every take through `motionkit retarget`
with the defaults: exit 0, feet planted (no slide, no sinking), contacts where the take stands
and none in its flights. And the retargeting of an AMC whose angles are radians while its
files declare degrees: a failure that names the cause."""

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from mocap_synth import amc_in_radians
from takes import TAKES, cut, held, hopped, make_take, retimed, turned, write_take

from motionkit.cli import main
from motionkit.dataset import read
from motionkit.mocap import MocapClip, load_mocap
from motionkit.recipes import sample_mocap


@pytest.fixture(scope="module")
def walk() -> MocapClip:
    """The sample's 02_01 (343 frames at 120 Hz)."""
    return load_mocap(sample_mocap() / "02_01.bvh")


def _hips(clip: MocapClip) -> np.ndarray:
    marks = clip.landmarks()
    return marks["l_hip"] - marks["r_hip"]


# --- the helpers, by hand --------------------------------------------------------------------


def test_held_repeats_the_first_and_last_frames(walk: MocapClip) -> None:
    take = held(walk, before=0.5, after=0.25)  # 60 and 30 frames at 120 Hz
    assert take.frames == walk.frames + 90
    np.testing.assert_array_equal(take.rotations[:61], np.repeat(walk.rotations[:1], 61, 0))
    np.testing.assert_array_equal(take.rotations[60:-30], walk.rotations)
    np.testing.assert_array_equal(take.root_translation[-31:], [walk.root_translation[-1]] * 31)
    assert cut(walk, 1.0, 2.0).frames == 121


def test_retimed_samples_the_take_at_its_new_pace(walk: MocapClip) -> None:
    """Twice as fast: frame n is frame 2 n (342 / 2 + 1 = 172 frames). Half as fast: frame
    2 n + 1 lies half way, the root at the mean of two frames and each joint turned half of
    the way between them; and back at full pace the take is the same again."""
    fast = retimed(walk, 2.0)
    assert fast.frames == 172
    np.testing.assert_allclose(fast.root_translation, walk.root_translation[::2], atol=1e-12)
    np.testing.assert_allclose(fast.rotations, walk.rotations[::2], atol=1e-12)
    slow = retimed(walk, 0.5)
    assert slow.frames == 2 * walk.frames - 1
    middle = 0.5 * (walk.root_translation[:-1] + walk.root_translation[1:])
    np.testing.assert_allclose(slow.root_translation[1::2], middle, atol=1e-12)
    between = np.einsum("tjki,tjkl->tjil", walk.rotations[:-1], walk.rotations[1:])
    halves = np.einsum("tjki,tjkl->tjil", walk.rotations[:-1], slow.rotations[1::2])
    whole = np.arccos(np.clip((np.trace(between, axis1=2, axis2=3) - 1) / 2, -1, 1))
    half = np.arccos(np.clip((np.trace(halves, axis1=2, axis2=3) - 1) / 2, -1, 1))
    np.testing.assert_allclose(half, whole / 2, atol=1e-6)
    again = retimed(slow, 2.0)
    np.testing.assert_allclose(again.root_translation, walk.root_translation, atol=1e-12)
    np.testing.assert_allclose(again.rotations, walk.rotations, atol=1e-12)


def test_turned_pivots_on_the_stance_foot(walk: MocapClip) -> None:
    """Turned 90 degrees: the body at the last frame faces 90 degrees to the left of the
    walk's, its hips turned exactly so; from frame to frame the foot it turns about moves as
    it did in the walk (by as much: a still foot stays still), its height unchanged."""
    take = turned(walk, np.pi / 2)
    before, after = _hips(walk)[-1], _hips(take)[-1]
    np.testing.assert_allclose(after, [-before[1], before[0], before[2]], atol=1e-12)
    marks, moved_marks = walk.landmarks(), take.landmarks()
    feet = [0.5 * (marks[f"{s}_ankle"] + marks[f"{s}_toe"]) for s in "lr"]
    turned_feet = [0.5 * (moved_marks[f"{s}_ankle"] + moved_marks[f"{s}_toe"]) for s in "lr"]
    speed = np.stack([np.linalg.norm(np.gradient(f[:, :2], axis=0), axis=1) for f in feet], 1)
    pivot = (speed[:, 0] > speed[:, 1]).astype(int)
    for t in range(1, walk.frames):
        k = pivot[t]
        step = np.linalg.norm(feet[k][t] - feet[k][t - 1])
        assert np.linalg.norm(turned_feet[k][t] - turned_feet[k][t - 1]) == pytest.approx(
            step, abs=1e-12
        )
    np.testing.assert_allclose(moved_marks["head"][:, 2], marks["head"][:, 2], atol=1e-12)
    standing = turned(held(walk, before=0.5), np.pi / 2)  # both feet still: no turn there
    np.testing.assert_allclose(standing.root_translation[:60], walk.root_translation[[0] * 60])


def test_hopped_flies_a_ballistic_arc(walk: MocapClip) -> None:
    """A 0.3 s hop from 0.4 s, 0.2 m forward: at 0.55 s (frame 66) the body is up
    g 0.3^2 / 8 = 0.1103625 m and 0.1 m along its heading (perpendicular to its hips); after
    the landing (0.7 s) it is back down, 0.2 m on."""
    take = hopped(held(walk, before=1.0), at=0.4, flight=0.3, forward=0.2)
    base = held(walk, before=1.0).root_translation
    lift = take.root_translation - base
    assert lift[66, 2] == pytest.approx(9.81 * 0.3**2 / 8, abs=1e-12)
    assert np.linalg.norm(lift[66, :2]) == pytest.approx(0.1, abs=1e-12)
    np.testing.assert_allclose(np.linalg.norm(lift[85:, :2], axis=1), 0.2, atol=1e-12)
    np.testing.assert_allclose(lift[85:, 2], 0.0, atol=1e-12)
    assert abs(lift[66, :2] @ _hips(walk)[0][:2]) < 1e-12  # along the heading
    assert not lift[:48].any()


def test_a_take_reads_back_from_its_bvh(tmp_path: Path) -> None:
    take = make_take("walk_stop_jump")
    back = load_mocap(write_take(tmp_path, "walk_stop_jump"))
    assert back.name == "walk_stop_jump" and back.frames == take.frames
    for name, value in take.landmarks().items():
        np.testing.assert_allclose(back.landmarks()[name], value, atol=1e-4)  # 1e-6 cm, deg


# --- retargeted with the defaults ------------------------------------------------------------


@pytest.fixture(scope="module")
def retargeted(tmp_path_factory: pytest.TempPathFactory) -> tuple[int, Path, dict]:
    """Every take as a BVH file through `motionkit retarget FOLDER --out OUT` (defaults)."""
    pytest.importorskip("placo")
    folder = tmp_path_factory.mktemp("takes")
    (folder / "in").mkdir()
    for name in TAKES:
        write_take(folder / "in", name)
    out = folder / "out"
    status = main(["retarget", str(folder / "in"), "--out", str(out)])
    summary = json.loads((out / "retarget_summary.json").read_text())
    return status, out, {c["name"]: c for c in summary["clips"]}


@pytest.mark.slow
def test_takes_retarget_cleanly(retargeted: tuple[int, Path, dict]) -> None:
    """Exit 0, every take within the gate; a planted foot holds still (slides of 1e-13 m/s
    measured: rounding) and stands on the floor, not in it; every frame converged (in 33 PlaCo
    steps at most, of the 100 allowed)."""
    status, _, clips = retargeted
    assert status == 0 and sorted(clips) == sorted(TAKES)
    for name, clip in clips.items():
        m = clip["metrics"]
        assert clip["output"] == f"{name}.mcap" and not clip["error"], name
        assert m["foot_slide_p95_m_s"] < 1e-6 and m["penetration_max_m"] <= 1e-4, name
        assert m["joint_position_violations"] == 0 and m["joint_velocity_violations"] == 0, name
        assert m["feet_error_mean_m"] <= 0.01 and m["ik_unconverged_frames"] == 0, name


@pytest.mark.slow
def test_take_contacts_follow_standing_and_flight(retargeted: tuple[int, Path, dict]) -> None:
    """Both feet down while a take stands still (held frames) and both up in the middle of a
    hop's flight (0.4-0.7 s, 3.5-3.85 s)."""
    _, out, _ = retargeted
    hop, jump = read(out / "hop_then_walk.mcap"), read(out / "walk_stop_jump.mcap")
    assert hop.contacts[:42].all() and hop.contacts[108:138, 0].all()  # 0-0.35 s, 0.9-1.15 s
    assert not hop.contacts[round(0.45 * 120) : round(0.65 * 120)].any()
    assert not jump.contacts[round(3.55 * 120) : round(3.8 * 120)].any()
    assert jump.contacts[round(4.0 * 120) :].all()
    start = read(out / "start_turn_stop.mcap")
    assert start.contacts[-round(0.9 * 120) :].all()  # stopped: both feet down


# --- radians read as degrees ------------------------------------------------------------------


def test_radians_under_degrees_fail_naming_the_cause(tmp_path: Path, capsys) -> None:
    """The sample 11_01 in radians, its heading past pi, its files declaring degrees: the
    whole take (its root travels 3.1 m) is refused when read; its first second (standing) is
    read, and when it fails the gate (here a recipe that allows no foot error at all) the
    failure names the likely cause. Exit 1 and nothing written either way."""
    pytest.importorskip("placo")
    amc, asf = sample_mocap() / "11_01.amc", sample_mocap() / "11.asf"
    (tmp_path / "walk").mkdir()
    (tmp_path / "stand").mkdir()
    for folder, frames in (("walk", None), ("stand", 120)):
        shutil.copy(asf, tmp_path / folder / "11.asf")
        amc_in_radians(amc, asf, tmp_path / folder / "11_01.amc", 2 * np.pi, frames)
    out = tmp_path / "out"
    assert main(["retarget", str(tmp_path / "walk"), "--out", str(out)]) == 1
    err = capsys.readouterr().err
    assert "11_01: failed:" in err and "while the root travels 3.1 m: radians, it seems" in err
    assert not out.exists()
    recipe = tmp_path / "strict.toml"
    recipe.write_text("[quality]\nfeet_error_mean_m = 0.0\n")
    argv = ["retarget", str(tmp_path / "stand"), "--out", str(out), "--config", str(recipe)]
    assert main([*argv, "--no-balance"]) == 1
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith("[1/1] 11_01: failed: beyond the clean figures: feet_error_mean_m")
    assert (
        "; likely cause: 11_01.amc's angles look like radians read as degrees: its joint "
        "angles stay within +-2 pi (largest 1.435)" in line
    )
    assert line.endswith("(--keep-failed DIR writes it there)") and not out.exists()
