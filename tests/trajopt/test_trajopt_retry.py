"""A homotopy step that IPOPT does not solve is retried once before the solve fails: the cold
step from where it stopped (warm-started), a later step from the previous step's solution in
steps of eps at most 10x apart; the progress lines say so. IPOPT's own runs on a small take-off
are wrapped so that chosen calls report a failure."""

from __future__ import annotations

from collections.abc import Collection
from dataclasses import replace
from typing import Any

import numpy as np
import pytest

from motionkit.core.errors import TrajoptError
from motionkit.robot.model import ironcub
from motionkit.trajopt.config import TrajoptConfig
from motionkit.trajopt.solve import Prepared, finer_schedule

OUT_OF_ITERATIONS = "Maximum_Iterations_Exceeded"


def test_finer_schedule_steps_at_most_tenfold() -> None:
    assert finer_schedule(1e-2, 1e-6) == pytest.approx([1e-3, 1e-4, 1e-5, 1e-6], rel=1e-9)
    assert finer_schedule(1e-4, 2e-5) == pytest.approx([np.sqrt(2e-9), 2e-5], rel=1e-9)
    step = (1e-2 / 3e-5) ** (1 / 3)  # 333x in three steps of 6.9x
    assert finer_schedule(1e-2, 3e-5) == pytest.approx([1e-2 / step, 1e-2 / step**2, 3e-5])


class Failing:
    """An IPOPT solver whose calls numbered in `fail` (from 0, over every wrapped solver)
    report running out of iterations; it records the start of every call."""

    def __init__(self, name: str, solver: Any, fail: Collection[int], calls: list) -> None:
        self.name, self.solver, self.fail, self.calls = name, solver, set(fail), calls
        self.failed = False

    def __call__(self, **args: Any) -> dict[str, Any]:
        self.failed = len(self.calls) in self.fail
        self.calls.append((self.name, args))
        return self.solver(**args)

    def stats(self) -> dict[str, Any]:
        stats = dict(self.solver.stats())
        return stats | {"return_status": OUT_OF_ITERATIONS} if self.failed else stats


@pytest.fixture(scope="module")
def takeoff() -> Prepared:
    pytest.importorskip("casadi")
    config = TrajoptConfig().with_scenario(knots=10, target=(0.0, 0.0, 0.9))
    config = replace(config, contacts=replace(config.contacts, eps=(1e-2, 1e-6)))
    return Prepared(ironcub(), replace(config, solver=replace(config.solver, print_level=0)))


def wrapped(prepared: Prepared, fail: Collection[int]) -> tuple[Prepared, list]:
    calls: list[tuple[str, dict[str, Any]]] = []
    copy = Prepared.__new__(Prepared)
    copy.__dict__ |= prepared.__dict__
    copy.cold = Failing("cold", prepared.cold, fail, calls)
    copy.warm = Failing("warm", prepared.warm, fail, calls)
    return copy, calls


@pytest.mark.slow
def test_cold_step_is_retried_from_where_it_stopped(takeoff: Prepared) -> None:
    prepared, calls = wrapped(takeoff, fail={0})
    lines: list[str] = []
    solution = prepared.solve(lines.append)
    assert [name for name, _ in calls] == ["cold", "warm", "warm"]
    assert [step.eps for step in solution.steps] == [1e-2, 1e-2, 1e-6]
    assert solution.steps[0].status == OUT_OF_ITERATIONS
    assert [bool(step.retry) for step in solution.steps] == [False, True, False]
    assert solution.retries == 1 and solution.status == "Solve_Succeeded"
    # the retry starts where the failed call ended, with its multipliers
    first = calls[0][1]
    assert "lam_g0" not in first and "lam_g0" in calls[1][1]
    assert not np.array_equal(np.asarray(calls[1][1]["x0"]).ravel(), first["x0"])
    assert lines[1] == (
        f"homotopy eps=0.01 unsolved ({OUT_OF_ITERATIONS}): retrying from where it stopped, "
        "warm-started"
    )
    assert lines[2].endswith(" (retry)") and lines[2].startswith("homotopy eps=0.01: Solve_")


@pytest.mark.slow
def test_later_step_is_retried_in_smaller_steps(takeoff: Prepared) -> None:
    prepared, calls = wrapped(takeoff, fail={1})
    lines: list[str] = []
    solution = prepared.solve(lines.append)
    eps = [step.eps for step in solution.steps]
    assert eps == pytest.approx([1e-2, 1e-6, 1e-3, 1e-4, 1e-5, 1e-6], rel=1e-9)
    assert [bool(step.retry) for step in solution.steps] == [False] * 2 + [True] * 4
    assert solution.retries == 4 and solution.status == "Solve_Succeeded"
    # the retry starts from the eps = 1e-2 solution, as the failed step did
    np.testing.assert_array_equal(np.asarray(calls[2][1]["x0"]), np.asarray(calls[1][1]["x0"]))
    assert lines[2] == (
        f"homotopy eps=1e-06 unsolved ({OUT_OF_ITERATIONS}): retrying from the solution at "
        "eps=0.01 through eps=0.001, 0.0001, 1e-05, 1e-06"
    )
    assert solution.knots["corners"][:, 2::3].min() > -1e-6


@pytest.mark.slow
def test_a_step_that_fails_again_ends_the_solve(takeoff: Prepared) -> None:
    prepared, calls = wrapped(takeoff, fail={0, 1})
    lines: list[str] = []
    with pytest.raises(TrajoptError) as error:
        prepared.solve(lines.append)
    message = str(error.value)
    assert message.startswith(
        f"scenario 'takeoff' is infeasible or unsolved: IPOPT status {OUT_OF_ITERATIONS} at "
        "eps=0.01 after "
    )
    assert "of them retrying); largest constraint violation" in message and "\n" not in message
    assert len(calls) == 2 and len(lines) == 3  # no later step after the failed retry
