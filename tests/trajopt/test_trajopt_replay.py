"""The MuJoCo replays: thrust allocation (hand-computed wrenches), the [replay] gains' validation,
and the stabilised replay of the take-off and landing recipes against the open-loop one."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from motionkit import recipes
from motionkit.core.errors import TrajoptError
from motionkit.robot.model import ironcub
from motionkit.trajopt.checks import motion_figures
from motionkit.trajopt.config import Replay, TrajoptConfig
from motionkit.trajopt.replay import Simulation, allocate, reference, replay, stabilised_replay
from motionkit.trajopt.runner import summary_line
from motionkit.trajopt.solve import Solution, solve

RECIPES = recipes.ROOT / "trajopt"

# Four jets pushing straight up from the corners of a 0.2 m x 0.4 m rectangle around the origin.
UP = np.tile([[0.0], [0.0], [1.0]], 4)
CORNERS = np.array([[0.1, 0.1, -0.1, -0.1], [0.2, -0.2, 0.2, -0.2], [0.0, 0.0, 0.0, 0.0]])


def wrench_of(directions: np.ndarray, positions: np.ndarray, thrusts: np.ndarray) -> np.ndarray:
    force = directions @ thrusts
    moment = sum(np.cross(positions[:, j], directions[:, j]) * t for j, t in enumerate(thrusts))
    return np.concatenate([force, moment])


def test_allocation_shares_a_vertical_force_equally() -> None:
    thrusts = allocate(UP, CORNERS, np.zeros(3), np.array([0.0, 0.0, 100.0, 0.0, 0.0, 0.0]))
    np.testing.assert_allclose(thrusts, [25.0, 25.0, 25.0, 25.0], atol=1e-9)


def test_allocation_of_a_moment_about_the_centre() -> None:
    # moment of jet j about the origin: (x, y, 0) x (0, 0, T) = (y T, -x T, 0), so a roll moment
    # of 10 N m with no net force is +-10 y / sum(y^2) = +-12.5 N (y = +-0.2 m, sum 0.16 m^2);
    # about a centre 0.1 m along y the levers are 0.1 and -0.3 m: the same thrusts give the same
    # moment plus -0.1 m x the (zero) net force, so the answer does not change.
    roll = np.array([0.0, 0.0, 0.0, 10.0, 0.0, 0.0])
    expected = [12.5, -12.5, 12.5, -12.5]
    np.testing.assert_allclose(allocate(UP, CORNERS, np.zeros(3), roll), expected, atol=1e-9)
    centre = np.array([0.0, 0.1, 0.0])
    np.testing.assert_allclose(allocate(UP, CORNERS, centre, roll), expected, atol=1e-9)
    # 100 N up about that centre takes a pitch-free, roll-free split: y levers 0.1 / -0.3 m,
    # so T_left : T_right = 3 : 1 on each side (sum 100 N, sum of y T = 0): 37.5 and 12.5 N
    lift = np.array([0.0, 0.0, 100.0, 0.0, 0.0, 0.0])
    np.testing.assert_allclose(allocate(UP, CORNERS, centre, lift), [37.5, 12.5, 37.5, 12.5])


def test_allocation_weights_the_residuals() -> None:
    """Two upright jets 0.2 m either side along y reach 100 N with 5 N m of roll exactly
    (T1 + T2 = 100, 0.2 (T1 - T2) = 5: 62.5 and 37.5 N), whatever the weights. One jet at
    y = 0.2 m asked for 100 N and no roll cannot: it minimises (T - 100)^2 + (w 0.2 T)^2, so
    T = 100 / (1 + 0.04 w^2): 96.15 N for w = 1, 50 N for w = 5."""
    two, sides = UP[:, :2], np.array([[0.0, 0.0], [0.2, -0.2], [0.0, 0.0]])
    request = np.array([0.0, 0.0, 100.0, 5.0, 0.0, 0.0])
    for weights in (None, np.array([1.0, 1.0, 1.0, 10.0, 1.0, 3.0])):
        thrusts = allocate(two, sides, np.zeros(3), request, weights)
        np.testing.assert_allclose(thrusts, [62.5, 37.5], atol=1e-9)
    one, side = UP[:, :1], np.array([[0.0], [0.2], [0.0]])
    lift = np.array([0.0, 0.0, 100.0, 0.0, 0.0, 0.0])
    assert allocate(one, side, np.zeros(3), lift)[0] == pytest.approx(100 / 1.04)
    roll_weighted = np.array([1.0, 1.0, 1.0, 5.0, 1.0, 1.0])
    assert allocate(one, side, np.zeros(3), lift, roll_weighted)[0] == pytest.approx(50.0)


def test_allocation_is_least_squares_where_the_jets_cannot_push() -> None:
    # upright jets make no sideways force: a request of 30 N along x and 100 N up gets the
    # 100 N only, the best the jets can do
    request = np.array([30.0, 0.0, 100.0, 0.0, 0.0, 0.0])
    thrusts = allocate(UP, CORNERS, np.zeros(3), request)
    np.testing.assert_allclose(thrusts, [25.0] * 4, atol=1e-9)
    np.testing.assert_allclose(wrench_of(UP, CORNERS, thrusts), [0, 0, 100, 0, 0, 0], atol=1e-9)


def simulation(quat: list[float], joints: float) -> Simulation:
    """iRonCub at rest with its base at 0.6 m, turned by `quat`, every joint at `joints`."""
    robot = ironcub()
    n = len(robot.joint_names)
    knots = {
        "base_position": np.array([[0.0, 0.0, 0.6]]),
        "base_quaternion": np.array([quat]) / np.linalg.norm(quat),
        "joints": np.full((1, n), joints),
        "base_velocity": np.zeros((1, 3)),
        "base_angular_velocity": np.zeros((1, 3)),
        "joint_velocities": np.zeros((1, n)),
    }
    return Simulation(SimpleNamespace(knots=knots), robot)  # type: ignore[arg-type]


def test_allocation_recovers_the_thrusts_of_the_robots_jets() -> None:
    """Four jets, tilted and offset, span a 4-D set of wrenches: the wrench of any thrusts is
    matched by those thrusts alone."""
    sim = simulation([1.0, 0.0, 0.0, 0.0], 0.0)
    directions, positions = sim.jets()
    assert np.linalg.norm(directions, axis=0) == pytest.approx([1.0] * 4)
    assert np.all(directions[2] > 0.9)  # upright robot, jets pushing (mostly) up
    centre, _ = sim.centroid()
    thrusts = np.array([60.0, 80.0, 150.0, 140.0])
    wrench = wrench_of(directions, positions - centre[:, None], thrusts)
    np.testing.assert_allclose(allocate(directions, positions, centre, wrench), thrusts)


def test_centroid_inertia_is_mujocos() -> None:
    """The rotational inertia about the CoM is MuJoCo's: the free joint's rotational block of
    the mass matrix (about the base origin, base axes), moved to the CoM by the parallel-axis
    rule, I_c = I_o - m (|r|^2 E - r r^T), and turned to world axes."""
    import mujoco

    sim = simulation([0.9, 0.1, 0.3, 0.2], 0.2)
    centre, inertia = sim.centroid()
    matrix = np.zeros((sim.model.nv, sim.model.nv))
    mujoco.mj_fullM(sim.model, sim.data, matrix)
    base = sim.data.xmat[1].reshape(3, 3)
    r = base.T @ (centre - sim.data.qpos[:3])
    about_com = matrix[3:6, 3:6] - sim.mass * (r @ r * np.eye(3) - np.outer(r, r))
    np.testing.assert_allclose(inertia, base @ about_com @ base.T, atol=1e-12)
    assert sim.mass == pytest.approx(ironcub().total_mass)


@pytest.mark.parametrize(
    ("table", "message"),
    [
        ("position_kp = -1.0", "[replay]: 'position_kp' should be finite and >= 0, got -1.0"),
        ("orientation_kd = -40.0", "[replay]: 'orientation_kd' should be finite and >= 0"),
        ("orientation_kp = inf", "[replay]: 'orientation_kp' should be finite and >= 0, got inf"),
        ("max_base_error = 0.0", "[replay]: 'max_base_error' should be finite and > 0"),
        ("yaw_weight = 0.0", "[replay]: 'yaw_weight' should be finite and > 0, got 0.0"),
        ("kp = 1.0", "[replay]: unknown keys ['kp']"),
        ("position_kd = 'high'", "[replay]: 'position_kd' should be float"),
    ],
)
def test_replay_gains_are_validated(tmp_path: Path, table: str, message: str) -> None:
    recipe = tmp_path / "bad.toml"
    recipe.write_text((RECIPES / "takeoff.toml").read_text() + f"\n[replay]\n{table}\n")
    with pytest.raises(TrajoptError) as error:
        TrajoptConfig.from_toml(recipe)
    assert str(recipe) in str(error.value) and message in str(error.value)
    assert "\n" not in str(error.value)


def test_replay_gains_load_from_a_recipe(tmp_path: Path) -> None:
    recipe = tmp_path / "soft.toml"
    recipe.write_text("[replay]\nposition_kp = 9\nposition_kd = 6.0\n")
    config = TrajoptConfig.from_toml(recipe)
    assert config.replay == replace(Replay(), position_kp=9.0, position_kd=6.0)
    assert config.to_dict()["replay"]["orientation_kp"] == Replay().orientation_kp


def test_motion_figures_count_airborne_intervals() -> None:
    """Knots 2, 3, 4 have every corner above 5 cm: intervals 2-3 and 3-4 fly, 0.2 s at dt 0.1;
    the CoM moves 0.5 m sideways in 0.4 s: 1.25 m/s."""
    lowest = np.array([0.0, 0.02, 0.06, 0.1, 0.07])
    corners = np.zeros((5, 24))
    corners[:, 2::3] = lowest[:, None] + np.linspace(0.0, 0.01, 8)
    com = np.column_stack([np.linspace(0, 0.3, 5), np.linspace(0, 0.4, 5), np.ones(5)])
    solution = SimpleNamespace(knots={"corners": corners, "com": com}, dt=0.1)
    figures = motion_figures(solution)  # type: ignore[arg-type]
    assert figures["airborne_s"] == pytest.approx(0.2)
    assert figures["horizontal_speed_mps"] == pytest.approx(1.25)


def test_summary_line_shows_both_replays() -> None:
    metrics = {
        "status": "Solve_Succeeded", "iterations": 148, "solve_s": 5.61, "build_s": 0.7,
        "variables": 2681, "constraints": 2720, "target_error_m": 2e-6,
        "complementarity_violation_nm": 5.5e-5, "residual_dynamics": 1e-8,
        "replay_base_error_max_m": 0.5432, "stabilised_base_error_max_m": 0.0512,
    }  # fmt: skip
    line = summary_line("takeoff", metrics)
    assert line.startswith("takeoff: Solve_Succeeded, 148 iterations, 5.6 s (+0.7 s build)")
    assert line.endswith("replay base error max 0.543 m open loop, 0.051 m stabilised")


@pytest.fixture(scope="module")
def solutions() -> dict[str, Solution]:
    robot = ironcub()
    solved = {}
    for recipe in ("takeoff", "landing"):
        config = TrajoptConfig.from_toml(RECIPES / f"{recipe}.toml")
        solved[recipe] = solve(robot, replace(config, solver=replace(config.solver, print_level=0)))
    return solved


@pytest.mark.slow
@pytest.mark.parametrize("recipe", ["takeoff", "landing"])
def test_stabilised_replay_tracks_the_recipe(solutions: dict[str, Solution], recipe: str) -> None:
    robot = ironcub()
    solution = solutions[recipe]
    open_loop = replay(solution, robot)
    stabilised = stabilised_replay(solution, robot)
    assert stabilised["stabilised_tracked"]
    assert stabilised["stabilised_base_error_max_m"] <= 0.10
    assert stabilised["stabilised_base_error_max_m"] < open_loop["replay_base_error_max_m"]
    assert stabilised["stabilised_base_error_final_m"] < 0.05
    assert stabilised["stabilised_orientation_error_max_rad"] < 0.12
    assert stabilised["stabilised_base_error_rms_m"] < open_loop["replay_base_error_rms_m"]
    errors = stabilised["stabilised_base_error_per_knot_m"]
    assert len(errors) == len(solution.time) and errors[0] == 0.0
    assert max(errors) == pytest.approx(stabilised["stabilised_base_error_max_m"], abs=1e-5)


@pytest.mark.slow
def test_stabilised_replay_with_zero_gains_is_the_open_loop_one(
    solutions: dict[str, Solution],
) -> None:
    robot = ironcub()
    solution = solutions["landing"]
    off = Replay(0.0, 0.0, 0.0, 0.0, max_base_error=0.1)
    stabilised = stabilised_replay(solution, robot, off)
    open_loop = replay(solution, robot)
    assert (
        stabilised["stabilised_base_error_per_knot_m"]
        == (open_loop["replay_base_error_per_knot_m"])
    )
    assert not stabilised["stabilised_tracked"]  # open loop, the landing drifts by metres


@pytest.mark.slow
def test_reference_follows_the_knots(solutions: dict[str, Solution]) -> None:
    """At the first step of every interval the reference is the knot; the feedback share is
    1 - (planned contact force) / (m g): 0.16 or so at the start of a take-off, 1 in the air."""
    robot = ironcub()
    solution = solutions["takeoff"]
    knots = solution.knots
    ref = reference(solution, robot.total_mass, 0.002)
    first = np.flatnonzero(np.diff(ref.knot, prepend=-1))
    np.testing.assert_allclose(ref.position[first], knots["base_position"][:-1], atol=1e-9)
    np.testing.assert_allclose(ref.joints[first], knots["joints"][:-1], atol=1e-12)
    np.testing.assert_array_equal(ref.thrust[first], knots["thrust"][:-1])
    weight = robot.total_mass * 9.80665
    share = 1 - knots["forces"][0, 2::3].sum() / weight
    assert ref.airborne[0] == pytest.approx(share) and 0.05 < share < 0.3
    assert ref.airborne[-1] == pytest.approx(1.0, abs=1e-4)  # IPOPT leaves ~1 mN on a corner
