"""The flight library: trajopt/library.toml parses into the expected solves (without solving),
its flights keep to 0.8 m/s, bad entries get one-line errors naming the entry, and a small
library runs through the command line (failures reported per clip, nothing written for them)."""

from __future__ import annotations

import argparse
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

from motionkit import recipes
from motionkit.cli import add_robot_source
from motionkit.core.errors import TrajoptError
from motionkit.trajopt.command import add_commands
from motionkit.trajopt.library import clip_name, read_library

RECIPES = recipes.ROOT / "trajopt"
LIBRARY = RECIPES / "library.toml"


def cli(*argv: str) -> int:
    parser = argparse.ArgumentParser()
    add_commands(parser.add_subparsers(), add_robot_source)
    args = parser.parse_args(["trajopt", *argv])
    return args.handler(args) or 0


def test_clip_names() -> None:
    assert clip_name("takeoff", (0.0, 0.0, 1.25)) == "takeoff_+0p00_+0p00_+1p25"
    assert clip_name("flight_2m", (-1.414, 1.414, 0.8)) == "flight_2m_-1p41_+1p41_+0p80"


def test_library_parses_into_its_solves() -> None:
    solves = read_library(LIBRARY)
    per_entry = Counter(solve.entry for solve in solves)
    assert per_entry == {
        "takeoff": 4, "takeoff_high": 4,
        "landing_0p8": 1, "landing_1p0": 2, "landing_1p2": 2, "landing_1p5": 2,
        "flight_1m": 8, "flight_2m": 8, "flight_climb": 3, "flight_descend": 3,
        "walk_to_fly_right": 1, "walk_to_fly_left": 1, "jump": 3, "jump_high": 1,
    }  # fmt: skip
    by_name = {solve.name: solve for solve in solves}
    assert len(by_name) == len(solves) == 43
    takeoffs = [s for s in solves if s.entry.startswith("takeoff")]
    heights = [s.config.scenario.target[2] for s in takeoffs]
    assert heights == pytest.approx([0.8, 0.9, 1.0, 1.1, 1.2, 1.3, 1.4, 1.5])
    assert all(s.config.scenario.name == "takeoff" for s in takeoffs)
    assert [s.config.scenario.knots for s in takeoffs] == [20] * 4 + [24] * 4
    assert takeoffs[0].name == "takeoff_+0p00_+0p00_+0p80"
    # the recipe's tables are kept, the entry's keys replace single fields of them
    flight = by_name["flight_2m_-1p41_+1p41_+1p50"].config
    assert flight.scenario.name == "flight_to_waypoint" and flight.scenario.knots == 40
    assert flight.scenario.start_position == (0.0, 0.0, 1.0)
    assert flight.scenario.target == (-1.414, 1.414, 1.5)
    assert (flight.solver.dt_min, flight.solver.dt_max) == (0.07, 0.1)
    left = by_name["walk_to_fly_left_-1p00_+0p00_+1p00"].config
    assert left.scenario.step_foot == "left" and left.scenario.knots == 60
    assert left.contacts.eps == (1e-2, 1e-3, 1e-4, 1e-5, 1e-6)  # the default: steps of 10x
    assert left.solver.cold_mu_oracle == "loqo"  # walk_to_fly.toml's
    jump = by_name["jump_high_-0p50_+0p00_+0p00"].config
    assert jump.scenario.apex_clearance == 0.2 and jump.solver.max_iter == 1000  # jet_jump.toml's
    assert {s.config.solver.max_iter for s in solves if s.entry.startswith("take")} == {500}
    assert all(s.config.solver.print_level == 0 for s in solves)  # quiet by default
    landings = {s.config.scenario.start_position[2] for s in solves if s.entry.startswith("land")}
    assert landings == {0.8, 1.0, 1.2, 1.5}


def test_library_flights_keep_to_0p8_m_per_s() -> None:
    """Even the shortest motion a flight may take, (knots - 1) dt_min, is slow enough."""
    flights = [s for s in read_library(LIBRARY) if s.config.scenario.name == "flight_to_waypoint"]
    assert len(flights) == 22
    for solve in flights:
        scenario, solver = solve.config.scenario, solve.config.solver
        distance = np.linalg.norm(np.subtract(scenario.target, scenario.start_position)[:2])
        fastest = distance / ((scenario.knots - 1) * solver.dt_min)
        assert fastest <= 0.8, solve.name


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "library.toml"
    path.write_text(text)
    for recipe in ("takeoff", "walk_to_fly"):
        (tmp_path / f"{recipe}.toml").write_text((RECIPES / f"{recipe}.toml").read_text())
    return path


GOOD = '[[entries]]\nname = "up"\nrecipe = "takeoff"\n'


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (GOOD, "entry 'up': give either 'targets' (a list of [x, y, z]) or 'grid'"),
        (
            GOOD + "targets = [[0, 0, 1]]\ngrid = [[0], [0], [1]]\n",
            "entry 'up': give either 'targets' (a list of [x, y, z]) or 'grid'",
        ),
        (
            '[[entries]]\nname = "hop"\nscenario = { name = "hop" }\ntargets = [[0, 0, 1]]\n',
            "entry 'hop': [scenario]: 'name' should be one of 'takeoff', 'walk_to_fly'",
        ),
        (
            '[[entries]]\nname = "hop"\nrecipe = "hop"\ntargets = [[0, 0, 1]]\n',
            "entry 'hop': recipe 'hop' not found (no file",
        ),
        (GOOD + "targets = [[0, 0, nan]]\n", "entry 'up': 'targets' should be finite, got"),
        (
            GOOD + "scenario = { start_position = [0, 0, inf] }\ntargets = [[0, 0, 1]]\n",
            "entry 'up': [scenario]: 'start_position' should be finite, got (0.0, 0.0, inf)",
        ),
        (
            GOOD + "targets = [[0, 1]]\n",
            "entry 'up': 'targets' should be [[float, float, float], ...]",
        ),
        (GOOD + "grid = [[0], [0]]\n", "entry 'up': 'grid' should be [[float, ...], [float, ...],"),
        (GOOD + "grid = [[0], [], [1]]\n", "entry 'up': 'grid' should be three non-empty lists"),
        (GOOD + "targets = []\n", "entry 'up': give either 'targets'"),
        (GOOD + "target = [[0, 0, 1]]\n", "entry 'up': unknown keys ['target']"),
        (
            GOOD + "targets = [[0, 0, 1]]\nsolver = { dt_min = -1.0 }\n",
            "entry 'up': [solver]: 'dt_min' should be finite and > 0, got -1.0",
        ),
        (
            GOOD + "targets = [[0, 0, 1]]\nreplay = { position_kp = -1.0 }\n",
            "entry 'up': [replay]: 'position_kp' should be finite and >= 0",
        ),
        (GOOD + "targets = [[0, 0, 1], [0, 0, 1]]\n", "entry 'up': clip 'up_+0p00_+0p00_+1p00' is"),
        ('[[entries]]\nrecipe = "takeoff"\n', "entries[0]: missing 'name'"),
        ('[[entries]]\nname = "a b"\n', "entry 'a b': 'name' should be a word"),
        ("entries = [1]\n", "entries[0]: should be a table, got 1"),
        ("entry = 1\n", "unknown keys ['entry']; a library has [[entries]] only"),
        ("", "expected a non-empty list of [[entries]] tables"),
    ],
)
def test_bad_library_entries_are_named(tmp_path: Path, text: str, message: str) -> None:
    path = write(tmp_path, text)
    with pytest.raises(TrajoptError) as error:
        read_library(path)
    assert str(error.value).startswith(str(path)) and message in str(error.value)
    assert "\n" not in str(error.value)


def test_library_takes_no_scenario_options(tmp_path: Path) -> None:
    path = write(tmp_path, GOOD + "targets = [[0, 0, 1]]\n")
    with pytest.raises(TrajoptError, match=r"drop \['--scenario', '--height'\]"):
        cli("--library", str(path), "--out", str(tmp_path), "--scenario", "takeoff",
            "--height", "1.0")  # fmt: skip
    with pytest.raises(TrajoptError, match="--scenario is required"):
        cli("--out", str(tmp_path))


@pytest.mark.slow
def test_library_runs_and_reports_failures_per_clip(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Two small take-offs and one that cannot be solved: exit 1, the two written, the third
    reported and not written, and the summary's airborne figures the clips' own."""
    path = write(
        tmp_path,
        GOOD
        + "scenario = { knots = 14 }\ngrid = [[0.0], [0.0], [0.8, 1.0]]\n"
        + '[[entries]]\nname = "moon"\nrecipe = "takeoff"\nscenario = { knots = 10 }\n'
        + "solver = { max_iter = 60 }\ntargets = [[0.0, 0.0, 40.0]]\n",
    )
    out = tmp_path / "out"
    code = cli("--library", str(path), "--out", str(out), "--jobs", "2", "--no-replay")
    assert code == 1
    printed = capsys.readouterr().out
    assert "moon_+0p00_+0p00_+40p00: FAILED:" in printed and "IPOPT status" in printed
    assert "2 of 3 clips solved" in printed and "failed: moon_+0p00_+0p00_+40p00" in printed
    assert sorted(p.name for p in out.glob("*.mcap")) == [
        "up_+0p00_+0p00_+0p80.mcap",
        "up_+0p00_+0p00_+1p00.mcap",
    ]
    airborne = 0.0
    for name in ("up_+0p00_+0p00_+0p80", "up_+0p00_+0p00_+1p00"):
        knots = np.load(out / f"{name}.knots.npz")
        flying = knots["corners"][:, 2::3].min(axis=1) > 0.05
        seconds = float(knots["dt"]) * np.sum(flying[:-1] & flying[1:])
        assert 0.2 < seconds < float(knots["time"][-1])  # it flies, but not from the start
        row = next(line for line in printed.splitlines() if line.startswith(name + " "))
        assert float(row.split()[1]) == pytest.approx(seconds, abs=0.005)
        airborne += seconds
    assert f"airborne {airborne:.1f} s in all" in printed


@pytest.mark.slow
def test_every_library_clip_solves_with_margin(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Every clip of the built-in library solves, passes its checks and tracks in the
    stabilised replay, each homotopy step within half of IPOPT's iteration limit and none
    retried: IPOPT's path, and so its iteration count, depends on the CPU's rounding, and the
    margin is what keeps the library solving on other machines. The derivatives are compiled
    as users compile them (not at the tests' -O0). About 10 minutes on two cores;
    `benchmarks/bench_trajopt.py --library library` prints the same figures as a table."""
    pytest.importorskip("casadi")
    import json

    from motionkit.robot.model import ironcub
    from motionkit.trajopt.runner import solve_library

    monkeypatch.delenv("MOTIONKIT_TRAJOPT_COMPILE", raising=False)
    outcomes = solve_library(LIBRARY, tmp_path, ironcub(), jobs=2, quiet=True, resume=False)
    assert len(outcomes) == 43
    short = [f"{o.name}: {o.text}" for o in outcomes if not o.solved]
    table = ["clip, iterations a step, limit of a step, stabilised base error [m]"]
    for outcome in filter(lambda o: o.solved, outcomes):
        written = json.loads((tmp_path / f"{outcome.name}.config.json").read_text())
        metrics, homotopy = written["metrics"], written["metrics"]["homotopy"]
        assert metrics["passed"] and metrics["stabilised_base_error_max_m"] <= 0.1
        steps = [step["iterations"] for step in homotopy]
        table.append(f"{outcome.name}, {steps}, {metrics['max_iter']}, "
                     f"{metrics['stabilised_base_error_max_m']:.3f}")  # fmt: skip
        planned = [step["eps"] for step in homotopy] == written["config"]["contacts"]["eps"]
        if not planned or metrics["retries"] or max(steps) > metrics["max_iter"] / 2:
            short.append(f"{outcome.name}: {steps} iterations a step, limit {metrics['max_iter']}")
    print("\n".join(table))  # with -s: the figures of docs/trajopt.md's table
    assert not short, "\n".join(short)
