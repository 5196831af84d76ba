"""BVH reader: channel orders, End Sites, units, Y-up, T-pose, rate, ASF/AMC agreement, errors."""

import time
from pathlib import Path

import numpy as np
import pytest
from mocap_synth import arms_down, mini_bvh, synth_files

from motionkit.mocap import MocapError, load_mocap
from motionkit.mocap.skeleton import Y_UP_TO_Z_UP, axis_rotation
from motionkit.mocap.writers import write_bvh


@pytest.fixture(scope="module")
def synth(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    return synth_files(tmp_path_factory.mktemp("synth"))


A = Y_UP_TO_Z_UP
QUARTER = np.pi / 2


def _write(tmp_path: Path, text: str, name: str = "clip.bvh") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def test_reads_skeleton_end_sites_and_rate(tmp_path: Path) -> None:
    clip = load_mocap(_write(tmp_path, mini_bvh(arms_down(4)), "12_34_walk.bvh"))
    assert clip.name == "12_34" and clip.format == "bvh" and clip.frames == 4
    assert clip.rate == 120.0  # Frame Time 0.0083333
    assert clip.duration == pytest.approx(3 / 120)
    names = clip.skeleton.names
    assert names[:3] == ("Hips", "LeftUpLeg", "LeftLeg")
    end = names.index("Head_End")
    assert clip.skeleton.parents[end] == names.index("Head")
    np.testing.assert_allclose(clip.skeleton.offsets[end], [0, 0, 0.2])  # Y-up (0, .2, 0)
    np.testing.assert_allclose(clip.rotations[:, end], np.broadcast_to(np.eye(3), (4, 3, 3)))
    pos = clip.joint_positions()
    np.testing.assert_allclose(clip.landmarks()["head"], pos[:, end])
    assert clip.landmark_map["head"] == "Head_End" and clip.landmark_map["l_toe"] == "LeftToeBase"
    np.testing.assert_allclose(pos[:, 0], [[0, -0.01 * f, 0.9] for f in range(4)], atol=1e-12)


def test_y_up_file_comes_out_z_up(tmp_path: Path) -> None:
    clip = load_mocap(_write(tmp_path, mini_bvh(arms_down(3))), units="m")
    marks = clip.landmarks()
    np.testing.assert_allclose(marks["head"][0] - marks["pelvis"][0], [0, 0, 0.8], atol=1e-9)
    np.testing.assert_allclose(marks["l_hip"][0] - marks["pelvis"][0], [0.1, 0, -0.05], atol=1e-9)
    toe = marks["l_toe"][0] - marks["l_ankle"][0]  # Y-up (0, -0.06, 0.12): forward is -y
    np.testing.assert_allclose(toe, [0, -0.12, -0.06], atol=1e-9)


@pytest.mark.parametrize(
    ("order", "expected"),
    [("ZXY", [0, 0.42, 0]), ("XZY", [0.42, 0, 0]), ("YXZ", [-0.42, 0, 0]), ("ZYX", [0.42, 0, 0])],
)
def test_channel_order(tmp_path: Path, order: str, expected: list[float]) -> None:
    """Values "90 90 0" in channel order: ZXY = Rz Rx, XZY = Rx Rz... applied to the Y-up knee
    offset (0, -0.42, 0)."""
    frames = [{"LeftUpLeg": (90.0, 90.0, 0.0)}, {"LeftUpLeg": (89.0, 90.0, 0.0)}]
    clip = load_mocap(
        _write(tmp_path, mini_bvh(frames, order={"LeftUpLeg": order})), keep_tpose=True
    )
    marks = clip.landmarks()
    np.testing.assert_allclose(marks["l_knee"][0] - marks["l_hip"][0], expected, atol=1e-9)
    r1, r2 = (axis_rotation(a.lower(), QUARTER) for a in order[:2])
    np.testing.assert_allclose(clip.rotations[0, 1], A @ r1 @ r2 @ A.T, atol=1e-12)


def test_units_auto_explicit_and_scaled_files_agree(tmp_path: Path) -> None:
    motion = arms_down(5)
    metres = load_mocap(_write(tmp_path, mini_bvh(motion), "m.bvh"))
    assert metres.units_scale == 1.0
    for unit, scale in (("cm", 0.01), ("inch", 0.0254), ("cmu", 0.0254 / 0.45)):
        clip = load_mocap(_write(tmp_path, mini_bvh(motion, scale=scale), f"{unit}.bvh"))
        assert clip.units_scale == pytest.approx(scale)
        for key, value in clip.landmarks().items():
            np.testing.assert_allclose(value, metres.landmarks()[key], atol=1e-5)
    forced = load_mocap(tmp_path / "cm.bvh", units="m")
    assert forced.units_scale == 1.0
    hip_ankle = forced.landmarks()["l_hip"] - forced.landmarks()["l_ankle"]
    assert np.linalg.norm(hip_ankle[0]) == pytest.approx(84.0, rel=0.02)
    assert load_mocap(tmp_path / "cm.bvh", units=0.01).units_scale == 0.01
    with pytest.raises(MocapError, match="unknown units 'furlong'"):
        load_mocap(tmp_path / "cm.bvh", units="furlong")


def test_tpose_frame_is_dropped(tmp_path: Path) -> None:
    frames = [{"root": (0.0, 0.9, 0.0)}, *arms_down(5, start=1)]  # frame 0: zeros, arms out
    path = _write(tmp_path, mini_bvh(frames))
    clip = load_mocap(path)
    kept = load_mocap(path, keep_tpose=True)
    assert clip.tpose_dropped and clip.frames == 5
    assert not kept.tpose_dropped and kept.frames == 6
    np.testing.assert_allclose(clip.root_translation, kept.root_translation[1:])
    np.testing.assert_allclose(clip.joint_positions(), kept.joint_positions()[1:])
    # A take that starts and stays in a T-pose, or starts walking, keeps frame 0.
    still = load_mocap(_write(tmp_path, mini_bvh([{}] * 4), "still.bvh"))
    walking = load_mocap(_write(tmp_path, mini_bvh(arms_down(6)), "walk.bvh"))
    assert (still.frames, still.tpose_dropped) == (4, False)
    assert (walking.frames, walking.tpose_dropped) == (6, False)


def test_position_channels_on_a_joint(tmp_path: Path) -> None:
    text = mini_bvh(arms_down(3))
    text = text.replace(
        "JOINT Neck\n\t\t\t{\n\t\t\t\tOFFSET 0.000000000 0.150000000 0.000000000\n"
        "\t\t\t\tCHANNELS 3",
        "JOINT Neck\n\t\t\t{\n\t\t\t\tOFFSET 0.000000000 0.150000000 0.000000000\n"
        "\t\t\t\tCHANNELS 4 Yposition",
    )
    lines = text.splitlines()
    start = lines.index("Frame Time: 0.0083333") + 1
    column = 6 + 3 * 10  # root 6 + 10 joints (with rotations) before Neck
    for f, n in enumerate(range(start, start + 3)):
        values = lines[n].split()
        lines[n] = " ".join([*values[:column], f"{0.15 + 0.1 * f}", *values[column:]])
    clip = load_mocap(_write(tmp_path, "\n".join(lines) + "\n"), units="m")
    assert clip.translations is not None
    neck = clip.landmarks()["neck"] - clip.landmarks()["chest"]
    np.testing.assert_allclose(neck[:, 2], [0.15, 0.25, 0.35], atol=1e-9)
    # constant values equal to the offset fold back into the skeleton
    lines = text.splitlines()
    for n in range(start, start + 3):
        values = lines[n].split()
        lines[n] = " ".join([*values[:column], "0.15", *values[column:]])
    folded = load_mocap(_write(tmp_path, "\n".join(lines) + "\n", "folded.bvh"), units="m")
    assert folded.translations is None
    np.testing.assert_allclose(folded.skeleton.offsets[folded.skeleton.index("Neck")], [0, 0, 0.15])


def test_bvh_and_asf_amc_of_one_motion_agree(synth: dict[str, Path]) -> None:
    bvh = load_mocap(synth["bvh"])
    amc = load_mocap(synth["amc"])
    assert bvh.frames == amc.frames == 6 and not bvh.tpose_dropped
    assert bvh.units_scale == pytest.approx(amc.units_scale)  # auto-detected: CMU units
    a, b = bvh.landmarks(), amc.landmarks()
    for key in a:
        assert np.abs(a[key] - b[key]).max() < 1e-6, key
    knee_travel = np.ptp(a["l_knee"], axis=0).max()
    assert knee_travel > 0.1  # the legs do move


def test_writer_round_trip(tmp_path: Path, synth: dict[str, Path]) -> None:
    clip = load_mocap(synth["amc"])
    for order, units in (("ZYX", "cm"), ("XZY", "m")):
        back = load_mocap(write_bvh(tmp_path / "out.bvh", clip, order=order, units=units))
        assert back.units_scale == pytest.approx({"cm": 0.01, "m": 1.0}[units])
        assert back.rate == clip.rate and back.frames == clip.frames
        for key, value in clip.landmarks().items():
            np.testing.assert_allclose(back.landmarks()[key], value, atol=1e-5)


def test_crlf_and_blank_lines(tmp_path: Path) -> None:
    text = mini_bvh(arms_down(3))
    reference = load_mocap(_write(tmp_path, text, "lf.bvh"))
    path = tmp_path / "crlf.bvh"
    path.write_bytes(text.replace("\n", "\r\n").encode() + b"\r\n\r\n")
    clip = load_mocap(path)
    np.testing.assert_allclose(clip.joint_positions(), reference.joint_positions())


def test_rate_argument_overrides_frame_time(tmp_path: Path) -> None:
    path = _write(tmp_path, mini_bvh(arms_down(3), frame_time="0.04"))
    assert load_mocap(path).rate == 25.0
    assert load_mocap(path, rate=30.0).rate == 30.0


def test_lowercase_underscore_names(tmp_path: Path) -> None:
    names = {"LeftUpLeg": "left_up_leg", "RightForeArm": "right_fore_arm", "Hips": "hips"}
    clip = load_mocap(_write(tmp_path, mini_bvh(arms_down(3), names=names)))
    assert clip.landmark_map["l_hip"] == "left_up_leg"
    assert clip.landmark_map["r_elbow"] == "right_fore_arm"
    assert clip.landmark_map["pelvis"] == "hips"


def test_reads_fast(tmp_path: Path) -> None:
    """6000 frames x 60 channels (50 s at 120 Hz): parse, rotations, landmarks."""
    text = mini_bvh(arms_down(6000))
    path = _write(tmp_path, text)
    start = time.perf_counter()
    clip = load_mocap(path)
    clip.landmarks()
    assert clip.frames == 6000
    assert time.perf_counter() - start < 2.0


# --- malformed files: each names the file and line ---------------------------------------------


def _motion_start(text: str) -> int:
    """Line number (1-based) of the first motion line."""
    return text.splitlines().index("Frame Time: 0.0083333") + 2


@pytest.fixture
def good() -> str:
    return mini_bvh(arms_down(4))


def _fails(tmp_path: Path, text: str, pattern: str) -> None:
    with pytest.raises(MocapError, match=pattern) as info:
        load_mocap(_write(tmp_path, text, "bad.bvh"))
    message = str(info.value)
    assert "bad.bvh" in message and "\n" not in message


def test_wrong_number_of_values(tmp_path: Path, good: str) -> None:
    lines = good.splitlines()
    n = _motion_start(good) + 2
    lines[n - 1] = " ".join(lines[n - 1].split()[:-3])
    _fails(tmp_path, "\n".join(lines), rf"line {n}: 57 values, expected 60")


def test_truncated_motion(tmp_path: Path, good: str) -> None:
    lines = good.splitlines()
    _fails(tmp_path, "\n".join(lines[:-2]) + "\n", r"truncated: motion ends after 2 frames")
    cut = "\n".join(lines)[:-40]  # cut inside the last line
    _fails(tmp_path, cut, rf"line {len(lines)}: \d+ values, expected 60 \(file truncated\?\)")
    _fails(tmp_path, good.split("MOTION")[0], "no MOTION section")


def test_extra_motion_lines(tmp_path: Path, good: str) -> None:
    lines = good.splitlines()
    text = "\n".join([*lines, lines[-1]]) + "\n"
    _fails(tmp_path, text, rf"line {len(lines) + 1}: more motion lines than 'Frames: 4'")


def test_unreadable_number(tmp_path: Path, good: str) -> None:
    lines = good.splitlines()
    n = _motion_start(good) + 1
    values = lines[n - 1].split()
    values[7] = "1.2.3"
    lines[n - 1] = " ".join(values)
    _fails(tmp_path, "\n".join(lines), rf"line {n}: value 8 '1.2.3' is not a number")


def test_unknown_channel(tmp_path: Path, good: str) -> None:
    text = good.replace("Zrotation Yrotation Xrotation", "Zrotation Wrotation Xrotation", 3)
    _fails(tmp_path, text, r"line 5: unknown channel 'Wrotation' of joint 'Hips'")


def test_malformed_hierarchy(tmp_path: Path, good: str) -> None:
    lines = good.splitlines()
    no_brace = "\n".join(lines[:6] + lines[7:])  # LeftUpLeg's "{"
    _fails(tmp_path, no_brace, r"line 7: expected '\{', got 'OFFSET'")
    no_offset = good.replace("\t\tOFFSET 0.000000000 -0.420000000 0.000000000\n", "", 1)
    _fails(tmp_path, no_offset, r"line 10: joint 'LeftLeg' has no OFFSET")
    bad_offset = good.replace("OFFSET 0.000000000 -0.420000000", "OFFSET 0.000000000 abc", 1)
    _fails(tmp_path, bad_offset, r"line 12: expected an OFFSET value, got 'abc'")
    unclosed = good.replace("}\nMOTION", "MOTION")
    _fails(tmp_path, unclosed, r"HIERARCHY ends early: expected '\}' closing joint 'Hips'")
    _fails(tmp_path, good.replace("Frames: 4", "Frames: four"), r"expected 'Frames: <number>'")
    _fails(tmp_path, good.replace("HIERARCHY", "HIERARCHIE"), r"line 1: expected 'HIERARCHY'")
    _fails(tmp_path, good.replace("JOINT Spine", "BONE Spine"), r"unexpected 'BONE'")
