"""Boundary conditions are imposed once: at the knots a scenario pins (the start, the end, a
step's landing), the equality constraints and the bounds that hold there have linearly
independent gradients. A condition imposed twice (a fixed standing pose whose corners are also
bounded by the floor, four corners of a rigid sole all set to z = 0) made the multipliers
non-unique, and IPOPT let them grow to 1e4-1e5 and crawled."""

from __future__ import annotations

import numpy as np
import pytest

from motionkit import recipes
from motionkit.robot.model import ironcub
from motionkit.trajopt.config import TrajoptConfig
from motionkit.trajopt.scenarios import sole_support
from motionkit.trajopt.solve import Prepared

RECIPES = recipes.ROOT / "trajopt"


def test_sole_support_is_the_largest_triangle() -> None:
    # a 0.2 x 0.1 rectangle and a point inside it: three rectangle corners, never the inner one
    points = np.array([[0.0, 0.2, 0.2, 0.0, 0.1], [0.0, 0.0, 0.1, 0.1, 0.05], np.zeros(5)])
    support = sole_support(points)
    assert len(support) == 3 and 4 not in support
    assert sole_support(points[:, :2]) == [0, 1]  # fewer than four: all of them


@pytest.fixture(scope="module")
def prepared() -> dict[str, Prepared]:
    pytest.importorskip("casadi")
    robot, made = ironcub(), {}
    for recipe in ("takeoff", "landing", "walk_to_fly", "jet_jump"):
        config = TrajoptConfig.from_toml(RECIPES / f"{recipe}.toml").with_scenario(knots=12)
        made[recipe] = Prepared(robot, config)
    return made


def pinned_rows(prepared: Prepared, knots: list[int]) -> np.ndarray:
    """The gradients (rows over every variable) at the initial guess of the equality
    constraints of `knots` and of the intervals between them, and of the bounds of their
    variables that hold there: fixed ones and those the guess sits on."""
    problem = prepared.problem
    lay, n = problem.layout, problem.knots
    lbx, ubx = problem.variable_bounds()
    lbg, ubg = problem.constraint_bounds()
    x0 = np.clip(np.r_[prepared.guess.ravel(order="F"), prepared.dt_guess], lbx, ubx)
    _, derivatives = problem.nlp()
    params = problem.functions.parameters(1e-2)
    jacobian = derivatives["jac_g"](x0, params)[1].full()
    knot_size = problem.functions.knot.size1_out(0)
    interval_size = problem.functions.interval.size1_out(0)
    rows = [k * knot_size + np.arange(knot_size) for k in knots]
    rows += [
        n * knot_size + k * interval_size + np.arange(interval_size)
        for k in knots
        if k + 1 in knots
    ]
    rows = np.concatenate(rows)
    equalities = rows[lbg[rows] == ubg[rows]]
    columns = np.concatenate([k * lay.size + np.arange(lay.size) for k in knots])
    held = columns[(x0[columns] <= lbx[columns]) | (x0[columns] >= ubx[columns])]
    return np.vstack([jacobian[equalities], np.eye(len(x0))[held]])


@pytest.mark.slow
@pytest.mark.parametrize(
    ("recipe", "knots"),
    [
        ("takeoff", [0, 1]),  # standing, at rest
        ("landing", [10, 11]),  # standing at rest at the end
        ("walk_to_fly", [3]),  # the step's landing (knot fraction 0.3 of 11)
        ("jet_jump", [0, 1, 10, 11]),
    ],
)
def test_conditions_at_pinned_knots_are_independent(
    prepared: dict[str, Prepared], recipe: str, knots: list[int]
) -> None:
    rows = pinned_rows(prepared[recipe], knots)
    singular = np.linalg.svd(rows, compute_uv=False)
    assert rows.shape[0] > 40 * len(knots)  # the ties, and the bounds that hold there
    assert singular.min() > 1e-6 * singular.max(), (rows.shape, singular.min())
