"""Small solved problems (take-off, landing), their checks, outputs (the planned contact forces
included), CLI and the infeasible path."""

from __future__ import annotations

import argparse
import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from motionkit import recipes
from motionkit.cli import add_robot_source
from motionkit.dataset import Trajectory, corner_names, read
from motionkit.dataset.validate import validate_clip
from motionkit.robot import THRUST_AXIS
from motionkit.robot.geometry import to_rotation
from motionkit.robot.kinematics import frame_poses
from motionkit.robot.model import ironcub
from motionkit.trajopt.checks import check_solution
from motionkit.trajopt.command import add_commands
from motionkit.trajopt.config import TrajoptConfig
from motionkit.trajopt.kinematics import GRAVITY
from motionkit.trajopt.replay import replay
from motionkit.trajopt.solve import solve

RECIPES = recipes.ROOT / "trajopt"
pytestmark = pytest.mark.slow


def small(recipe: str, knots: int = 16) -> TrajoptConfig:
    config = TrajoptConfig.from_toml(RECIPES / f"{recipe}.toml").with_scenario(knots=knots)
    return replace(config, solver=replace(config.solver, print_level=0))


def cli(*argv: str) -> int:
    parser = argparse.ArgumentParser()
    add_commands(parser.add_subparsers(), add_robot_source)
    args = parser.parse_args(["trajopt", *argv])
    return args.handler(args) or 0


def test_recipes_load() -> None:
    recipes = [path for path in RECIPES.glob("*.toml") if path.stem != "library"]
    names = {path.stem for path in recipes}
    assert names == {"takeoff", "walk_to_fly", "flight_to_waypoint", "landing", "jet_jump"}
    for path in recipes:
        assert TrajoptConfig.from_toml(path).scenario.name == path.stem


@pytest.mark.parametrize("recipe", ["takeoff", "landing"])
def test_small_problem_solves_and_passes_checks(recipe: str) -> None:
    robot = ironcub()
    solution = solve(robot, small(recipe))
    checks = check_solution(solution, robot)
    assert checks["passed"], checks
    assert checks["target_error_m"] < 0.01
    assert checks["complementarity_violation_nm"] < 1e-4
    assert checks["max_force_off_ground_n"] < 0.5
    assert checks["residual_dynamics"] < 1e-5
    knots = solution.knots
    corners_z = knots["corners"][:, 2::3]
    if recipe == "takeoff":  # on the floor at first, all corners off it at the end
        assert knots["forces"][0, 2::3].sum() > 300.0
        assert corners_z[-1].min() > 0.05
    else:  # in the air at first, every corner on the floor at the end
        assert corners_z[0].min() > 0.05
        assert np.abs(corners_z[-1]).max() < 1e-6
    assert knots["thrust"].max() <= 250.0 + 1e-6 and knots["thrust"].min() >= -1e-6
    # Open-loop replay in MuJoCo: within 10 cm over the first third of the motion,
    # drifting afterwards (a flying robot without feedback); the bound is loose on purpose.
    errors = replay(solution, robot)["replay_base_error_per_knot_m"]
    assert max(errors[: len(errors) // 3]) < 0.1
    assert max(errors) < 2.5


def test_cli_writes_clip_with_metrics(tmp_path: Path) -> None:
    recipe = tmp_path / "takeoff.toml"
    recipe.write_text((RECIPES / "takeoff.toml").read_text())  # N = 20: see the validation below
    code = cli(
        "--scenario", "takeoff", "--config", str(recipe), "--out", str(tmp_path / "out"),
        "--height", "0.9", "--quiet", "--name", "hop",
    )  # fmt: skip
    assert code == 0
    clip = read(tmp_path / "out" / "hop.mcap")
    assert clip.metadata.kind == "takeoff" and clip.metadata.generator == "trajopt"
    metrics = clip.metadata.metrics
    assert metrics["passed"] and metrics["target_error_m"] < 0.01
    assert "replay_base_error_max_m" in metrics and metrics["stabilised_tracked"]
    assert metrics["stabilised_base_error_max_m"] < metrics["replay_base_error_max_m"]
    assert 0.3 < metrics["airborne_s"] < metrics["duration_s"]
    assert clip.contacts[0].all() and not clip.contacts[-1].any()
    assert clip.rate == pytest.approx(50.0)
    knots = np.load(tmp_path / "out" / "hop.knots.npz")
    assert knots["com"][-1] == pytest.approx([0.0, 0.0, 0.9], abs=0.01)
    resolved = json.loads((tmp_path / "out" / "hop.config.json").read_text())
    assert resolved["config"]["scenario"]["target"] == [0.0, 0.0, 0.9]
    check_contact_forces(clip, knots)
    # the clip is a valid dataset clip: velocities agree with the derivatives of the positions
    # (at the recipe's N = 20; a coarser plan's kinks, sampled at 50 Hz, can exceed the bound)
    checks = validate_clip(tmp_path / "out" / "hop.mcap", ironcub())
    failed = [c for c in checks if not c.ok and not c.warning]
    assert not failed, failed
    # the plan's forces explain its motion at the knots (pinocchio's momentum, its own steps:
    # one from each knot but the last)
    physics = metrics["physics"]
    assert physics["forces_from"] == "clip" and physics["frames"] == len(knots["time"]) - 1
    assert physics["residual_force_max_bw"] < 0.01 and physics["torque_within_share"] == 1.0
    assert "residual_force_p95_bw" in metrics["physics_clip"]
    # ... and never beyond the knots around it (shape-preserving): limits hold between knots
    k = np.clip(np.searchsorted(knots["time"], clip.time, "right") - 1, 0, len(knots["time"]) - 2)
    around = np.stack([knots["joints"][k], knots["joints"][k + 1]])
    assert np.all(clip.joint_positions >= around.min(axis=0) - 1e-5)
    assert np.all(clip.joint_positions <= around.max(axis=0) + 1e-5)


def check_contact_forces(clip: Trajectory, knots: dict[str, np.ndarray]) -> None:
    """The clip's planned contact forces are the knots' (corner order, resampled linearly one
    knot interval late, where explicit Euler steps apply them to the positions), and while
    standing they carry the weight less the thrust: by the explicit-Euler CoM dynamics,
    sum f_z(k) = m (g + (v_z(k+1) - v_z(k)) / dt) - sum_j T_j(k) d_jz(k), d_j the thrust
    direction of jet j (its THRUST_AXIS in the world)."""
    robot = ironcub()
    assert clip.corner_names == corner_names(robot) and clip.contact_forces.shape[1:] == (8, 3)
    time, forces = knots["time"], knots["forces"].reshape(len(knots["time"]), 8, 3)
    np.testing.assert_array_equal(clip.contact_forces[0], forces[0].astype(np.float32))
    assert np.abs(clip.contact_forces[-1]).max() < 0.5  # hovering: no force off the ground

    jets = [jet.frame for jet in robot.spec.jets]
    local = frame_poses(robot.model, robot.joint_names, knots["joints"], jets)[..., :3, :3]
    base = to_rotation(knots["base_quaternion"]).as_matrix()
    directions = np.einsum("kij,knjl,l->kni", base, local, THRUST_AXIS)
    thrust_z = np.einsum("kn,kn->k", knots["thrust"], directions[..., 2])
    acceleration = np.diff(knots["com_velocity"][:, 2]) / float(knots["dt"])
    weight = robot.total_mass * (GRAVITY + acceleration) - thrust_z[:-1]  # knots 0..N-2
    standing = np.flatnonzero(forces[:, :, 2].sum(axis=1) > 1.0)
    assert len(standing) >= 3 and standing[-1] < len(time) - 1
    assert np.array_equal(standing, np.arange(len(standing)))  # one phase, from the start
    assert weight[0] == pytest.approx(robot.total_mass * GRAVITY - 4 * 16.0, rel=0.05)  # idle
    late = np.maximum(clip.time - float(knots["dt"]), 0.0)
    frames = late <= time[standing[-1]]  # every frame between standing knots
    expected = np.interp(late[frames], time[standing], weight[standing])
    written = clip.contact_forces[frames, :, 2].astype(float).sum(axis=1)
    np.testing.assert_allclose(written, expected, atol=0.05)  # IPOPT's tolerance, float32


def test_infeasible_request_reports_and_writes_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    recipe = tmp_path / "high.toml"
    recipe.write_text(
        (RECIPES / "takeoff.toml").read_text().replace("knots = 20", "knots = 10")
        + "\n[solver]\nmax_iter = 60\n"
    )
    out = tmp_path / "out"
    code = cli(
        "--scenario", "takeoff", "--config", str(recipe), "--out", str(out),
        "--height", "40.0", "--quiet", "--no-replay",
    )  # fmt: skip
    assert code == 1
    error = capsys.readouterr().err
    assert "IPOPT status" in error and "largest constraint violation" in error
    assert not out.exists() or not any(out.iterdir())


def test_grid_solves_each_target_in_worker_processes(tmp_path: Path) -> None:
    recipe = tmp_path / "takeoff.toml"
    recipe.write_text((RECIPES / "takeoff.toml").read_text().replace("knots = 20", "knots = 14"))
    out = tmp_path / "library"
    code = cli(
        "--scenario", "takeoff", "--config", str(recipe), "--out", str(out),
        "--grid", "0", "0", "0.8,1.0", "--jobs", "2", "--quiet", "--no-replay",
    )  # fmt: skip
    assert code == 0
    clips = sorted(out.glob("*.mcap"))
    assert [clip.name for clip in clips] == [
        "takeoff_+0p00_+0p00_+0p80.mcap",
        "takeoff_+0p00_+0p00_+1p00.mcap",
    ]
    for clip, height in zip(clips, (0.8, 1.0), strict=True):
        knots = np.load(clip.with_suffix("").with_suffix(".knots.npz"))
        assert knots["com"][-1] == pytest.approx([0.0, 0.0, height], abs=0.01)
