"""The real CMU clips of the offline sample: 02_01 (BVH conversion) and 11_01 (ASF/AMC).

They are different takes of different subjects, so the checks compare anatomy and statistics.
"""

from pathlib import Path

import numpy as np
import pytest

from motionkit.mocap import LANDMARKS, MocapClip, load_mocap
from motionkit.recipes import sample_mocap


@pytest.fixture(scope="module")
def cmu_dir() -> Path:
    """The package's sample: the 02_01 BVH and the 11 ASF + 11_01 AMC."""
    return sample_mocap()


@pytest.fixture(scope="module")
def bvh(cmu_dir: Path) -> MocapClip:
    return load_mocap(cmu_dir / "02_01.bvh")


@pytest.fixture(scope="module")
def amc(cmu_dir: Path) -> MocapClip:
    return load_mocap(cmu_dir / "11_01.amc")


def test_headers(bvh: MocapClip, amc: MocapClip, cmu_dir: Path) -> None:
    assert (bvh.name, bvh.format, bvh.rate) == ("02_01", "bvh", 120.0)
    assert (amc.name, amc.format, amc.rate) == ("11_01", "asf/amc", 120.0)
    assert bvh.units_scale == pytest.approx(0.0254 / 0.45)  # detected from the legs
    assert amc.units_scale == pytest.approx(0.0254 / 0.45)  # ASF :units length 0.45
    declared = int((cmu_dir / "02_01.bvh").read_text().split("Frames:")[1].split()[0])
    assert bvh.tpose_dropped and bvh.frames == declared - 1
    assert not amc.tpose_dropped and amc.frames > 500
    assert load_mocap(cmu_dir / "02_01.bvh", keep_tpose=True).frames == declared
    assert bvh.landmark_map["l_hip"] == "LeftUpLeg" and amc.landmark_map["l_hip"] == "lfemur"


@pytest.mark.parametrize("which", ["bvh", "amc"])
def test_plausible_walking_anatomy(which: str, request: pytest.FixtureRequest) -> None:
    clip: MocapClip = request.getfixturevalue(which)
    marks = clip.landmarks()
    assert tuple(marks) == LANDMARKS
    assert all(v.shape == (clip.frames, 3) and np.isfinite(v).all() for v in marks.values())
    for s in "lr":
        thigh = np.linalg.norm(marks[f"{s}_knee"] - marks[f"{s}_hip"], axis=1)
        shin = np.linalg.norm(marks[f"{s}_ankle"] - marks[f"{s}_knee"], axis=1)
        assert 0.75 < (thigh + shin).mean() < 0.95
        reach = np.linalg.norm(marks[f"{s}_ankle"] - marks[f"{s}_hip"], axis=1).max()
        assert 0.75 < reach < 0.95
        assert marks[f"{s}_toe"][:, 2].min() == pytest.approx(0.03, abs=0.04)  # on the floor
    feet = np.min([marks[k][:, 2] for k in ("l_toe", "r_toe", "l_ankle", "r_ankle")], axis=0)
    assert np.mean(feet - feet.min() < 0.05) > 0.75  # a foot on the ground most of the time
    height = marks["head"][:, 2] - marks["pelvis"][:, 2]
    assert 0.4 < height.min() and height.max() < 0.8
    assert 0.85 < marks["pelvis"][:, 2].mean() < 1.1
    travel = marks["pelvis"][-1, :2] - marks["pelvis"][0, :2]
    assert np.linalg.norm(travel) > 1.0
    # facing: toes ahead of ankles and knees ahead of the hip-ankle line, along the travel
    forward = travel / np.linalg.norm(travel)
    for s in "lr":
        foot = (marks[f"{s}_toe"] - marks[f"{s}_ankle"])[:, :2] @ forward
        knee = (marks[f"{s}_knee"] - (marks[f"{s}_hip"] + marks[f"{s}_ankle"]) / 2)[:, :2]
        assert foot.mean() > 0.05 and (knee @ forward).mean() > 0.05
    left = np.cross([0.0, 0.0, 1.0], [*forward, 0.0])[:2]
    assert ((marks["l_shoulder"] - marks["r_shoulder"])[:, :2] @ left).mean() > 0.25
    assert ((marks["l_hip"] - marks["r_hip"])[:, :2] @ left).mean() > 0.1


def test_the_two_subjects_are_alike(bvh: MocapClip, amc: MocapClip) -> None:
    a, b = bvh.landmarks(), amc.landmarks()

    def leg(m: dict[str, np.ndarray]) -> float:
        return float(np.linalg.norm(m["l_knee"] - m["l_hip"], axis=1).mean())

    assert leg(a) == pytest.approx(leg(b), rel=0.1)
    assert a["pelvis"][:, 2].mean() == pytest.approx(b["pelvis"][:, 2].mean(), abs=0.05)
    shoulders = [np.linalg.norm(m["l_shoulder"] - m["r_shoulder"], axis=1).mean() for m in (a, b)]
    assert shoulders[0] == pytest.approx(shoulders[1], rel=0.15)
    steps = [np.linalg.norm(np.diff(m["pelvis"], axis=0), axis=1).max() for m in (a, b)]
    assert max(steps) < 5.0 / 120  # no jumps: under 5 m/s between frames
