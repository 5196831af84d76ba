"""`validate_clip`: a clean clip passes every check; each defect fails the check that names it."""

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from motionkit.dataset import write
from motionkit.dataset.synthetic import synthetic_trajectory
from motionkit.dataset.validate import validate_clip
from motionkit.robot import ironcub


@pytest.fixture(scope="module")
def robot():
    return ironcub()


@pytest.fixture(scope="module")
def clean(robot):
    return synthetic_trajectory(robot, 2.0, 120.0, thrust=60.0, kind="flight")


def failures(path: Path, robot) -> dict[str, str]:
    return {c.name: c.detail for c in validate_clip(path, robot) if not c.ok and not c.warning}


def edited(trajectory, name: str, change) -> object:
    values = np.array(getattr(trajectory, name), copy=True)
    change(values)
    return replace(trajectory, **{name: values})


def test_clean_clip_passes_every_check(tmp_path: Path, robot, clean) -> None:
    checks = validate_clip(write(tmp_path / "c.mcap", clean, robot), robot)
    assert len(checks) == 13 and all(c.ok for c in checks[:-1]), [c for c in checks if not c.ok]
    assert checks[-1].warning and checks[-1].name.startswith("physics")  # a random motion


def test_each_defect_fails_its_check(tmp_path: Path, robot, clean) -> None:
    hip = robot.joint_names.index("l_hip_pitch")
    upper = robot.limits.upper[hip]

    def backwards(t):
        t[10] = t[8]

    cases = {
        "time": (edited(clean, "time", backwards), "not strictly increasing at frame 10"),
        "finite values": (
            edited(clean, "joint_velocities", lambda v: v.__setitem__((5, 2), np.nan)),
            "joint_velocities is not finite at frame 5",
        ),
        "unit quaternions": (
            edited(clean, "base_orientation", lambda q: q.__setitem__(7, q[7] * 1.01)),
            "at frame 7",
        ),
        "joint velocities = d/dt joint positions": (
            edited(
                clean,
                "joint_velocities",
                lambda v: v.__setitem__((slice(None), hip), 2 * v[:, hip]),
            ),
            "worst l_hip_pitch",
        ),
        "base linear velocity = d/dt base position": (
            edited(
                clean,
                "base_linear_velocity",
                lambda v: v.__setitem__((slice(None), 1), v[:, 1] + 0.5),
            ),
            "worst y",
        ),
        "base angular velocity = from d/dt orientation": (
            edited(
                clean, "base_angular_velocity", lambda v: v.__setitem__((slice(None), 2), -v[:, 2])
            ),
            "worst z",
        ),
        "joint position limits": (
            edited(
                clean, "joint_positions", lambda q: q.__setitem__((slice(50, 53), hip), upper + 0.1)
            ),
            "3 frames beyond; worst l_hip_pitch by 0.1",
        ),
        "thrust within 0..T_max": (
            edited(clean, "thrust", lambda t: t.__setitem__((4, 1), 300.0)),
            "worst chest_right by 50",
        ),
    }
    for name, (trajectory, detail) in cases.items():
        found = failures(write(tmp_path / "bad.mcap", trajectory, robot), robot)
        assert name in found, (name, found)
        assert detail in found[name], (name, found[name])


def test_unreadable_clip_and_another_robot(tmp_path: Path, robot, clean, toy_robot) -> None:
    path = write(tmp_path / "c.mcap", clean, robot)
    found = failures(path, toy_robot)
    assert "missing ['l_ankle', 'l_hip'" in found["joint names of toy"]
    path.write_bytes(path.read_bytes()[:-20])
    checks = validate_clip(path, robot)
    assert len(checks) == 1 and not checks[0].ok and "truncated" in checks[0].detail


def test_simulated_clips_may_press_into_their_soft_joint_limits(
    tmp_path: Path, robot, clean
) -> None:
    """MuJoCo's joint limits are soft: a rollout's limb overshoots its stop by about 0.01 rad,
    which passes; 0.05 rad fails, and so does 0.012 rad in a clip that was not simulated."""
    hip = robot.joint_names.index("l_hip_pitch")
    upper = robot.limits.upper[hip]
    rollout = replace(clean.metadata, kind="rollout", generator="rollout")

    def pressed(excess: float, metadata) -> dict[str, str]:
        trajectory = edited(
            clean, "joint_positions", lambda q: q.__setitem__((slice(50, 53), hip), upper + excess)
        )
        path = write(tmp_path / "pressed.mcap", replace(trajectory, metadata=metadata), robot)
        return failures(path, robot)

    soft = "joint position limits (soft in simulation)"
    assert soft not in pressed(0.012, rollout)
    assert "3 frames beyond; worst l_hip_pitch by 0.05" in pressed(0.05, rollout)[soft]
    assert "joint position limits" in pressed(0.012, clean.metadata)
    # the simulator has no joint velocity limit: beyond one is a warning in a rollout alone
    fast = edited(clean, "joint_velocities", lambda v: v.__setitem__((slice(5, 8), hip), 50.0))
    checks = {c.name: c for c in validate_clip(write(tmp_path / "fast.mcap", fast, robot), robot)}
    assert not checks["joint velocity limits"].ok and not checks["joint velocity limits"].warning
    simulated = replace(fast, metadata=rollout)
    checks = validate_clip(write(tmp_path / "fast.mcap", simulated, robot), robot)
    warned = {c.name: c for c in checks}["joint velocity limits (not simulated)"]
    assert warned.warning and not warned.ok and "3 frames beyond" in warned.detail
