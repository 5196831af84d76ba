"""A tiny run of the terrain scenario (one iteration on the MuJoCo backend): the mean level per
kind in train.csv, its evaluation clip with its terrain; `play --terrain` on a held-out course,
`train evaluate --terrain` and `--per-tile`; a policy of flat ground refused on a terrain."""

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from motionkit.cli import main
from motionkit.dataset import read
from motionkit.train.curves import read_table

slow = pytest.mark.slow  # trains an iteration, compiles the task (minutes on 2 cores)
KINDS = ("flat", "pits")


@pytest.fixture(scope="module")
def terrain_run(tiny_config, robot, tmp_path_factory: pytest.TempPathFactory) -> Path:
    from motionkit.train.runner import train

    out = tmp_path_factory.mktemp("terrain_run")
    env = replace(
        tiny_config.env,
        scenario="terrain",
        terrain_levels=2,
        terrain_kinds=KINDS,
        max_start_level=1,
        air_probability=0.0,
    )
    run = replace(tiny_config.run, iterations=1, tensorboard=False, eval_every=1)
    train(replace(tiny_config, env=env, run=run), out, robot, progress=lambda _: None)
    return out


@slow
def test_a_terrain_run_logs_levels_and_records_its_terrain(terrain_run: Path) -> None:
    from motionkit.train.env import courses

    train = read_table(terrain_run / "train.csv")
    for kind in KINDS:
        assert 0.0 <= train[f"terrain_level_{kind}"][0] <= 1.0  # levels 0 and 1
    assert 0.0 <= train["route_success_share"][0] <= 1.0
    clip = read(terrain_run / "rollouts" / "iter_1.mcap")
    terrain = clip.metadata.config["terrain"]
    assert terrain["kind"] in KINDS and terrain["level"] in (0, 1)
    layout = courses.CourseLayout.from_dict(terrain["course"])
    assert layout == courses.CourseLayout(2, KINDS, 8.0, 0)
    centre = courses.tile_centre(layout, terrain["level"], KINDS.index(terrain["kind"]))
    np.testing.assert_allclose(clip.base_position[0, :2], centre, atol=0.05)
    heights = np.array(terrain["heights"])
    low = np.array(terrain["origin"])
    high = low + np.array(heights.shape[::-1]) * terrain["cell"]
    assert (low <= clip.base_position[:, :2].min(0)).all()  # the grid covers the path
    assert (high >= clip.base_position[:, :2].max(0)).all()


@slow
def test_play_on_a_held_out_course(terrain_run: Path, tmp_path: Path, capsys) -> None:
    from motionkit.train.env import courses, tiles

    out = tmp_path / "plays"
    args = ["--terrain", "pits", "--random-route", "2", "--seed", "3", "--seconds", "0.5"]
    assert main(["play", "--policy", str(terrain_run), "--out", str(out), *args]) == 0
    assert "waypoint 1 (" in capsys.readouterr().out
    clip = read(out / "play.mcap")
    config = clip.metadata.config
    assert config["terrain"]["kind"] == "pits" and config["terrain"]["level"] == 1  # hardest
    assert config["terrain"]["course"]["seed"] == courses.HELD_OUT + 3 and config["seed"] == 3
    centre = np.array(courses.tile_centre(courses.CourseLayout(2, KINDS, 8.0, 0), 1, 1))
    np.testing.assert_allclose(clip.base_position[0, :2], centre, atol=0.05)
    # the route runs across the tile: ground waypoints inside the moat or beyond it
    route = np.array(config["waypoints"])[:, 1:]
    ring = np.abs(route[:, :2] - centre).max(axis=1)
    outer = 1.0 + tiles.pit_width(1.0)
    assert ((ring <= 1.0) | (ring >= outer)).all() and (ring < 4.0).all()
    # given waypoints are relative to the tile's centre
    again = tmp_path / "given"
    given = ["--terrain", "flat:0", "--waypoints", "0.5,0,0.6", "--seconds", "0.2"]
    assert main(["play", "--policy", str(terrain_run), "--out", str(again), *given]) == 0
    route = np.array(read(again / "play.mcap").metadata.config["waypoints"])[:, 1:]
    flat = np.array(courses.tile_centre(courses.CourseLayout(2, KINDS, 8.0, 0), 0, 0))
    np.testing.assert_allclose(route[0], [flat[0] + 0.5, flat[1], 0.6], atol=1e-6)


@slow
def test_evaluate_on_a_tile_and_per_tile(terrain_run: Path, capsys) -> None:
    assert main(["train", "evaluate", str(terrain_run), "--terrain", "pits:0"]) == 0
    lines = dict(line.split(" ", 1) for line in capsys.readouterr().out.splitlines())
    assert 0.0 <= float(lines["route_success_share"]) <= 1.0 and "episodes" in lines
    assert main(["train", "evaluate", str(terrain_run), "--per-tile", "--robots", "4"]) == 0
    table = capsys.readouterr().out.splitlines()
    assert table[0].startswith("| kind | level | waypoints | success | falls |")
    rows = [line.split(" | ")[:2] for line in table[2:]]
    assert rows == [["| flat", "0"], ["| flat", "1"], ["| pits", "0"], ["| pits", "1"]]
    assert main(["train", "evaluate", str(terrain_run), "--terrain", "lava"]) == 2
    assert "no kind 'lava'" in capsys.readouterr().err


def test_a_flat_policy_is_refused_on_a_terrain(tmp_path: Path, capsys) -> None:
    assert main(["play", "--terrain", "pits", "--out", str(tmp_path / "plays")]) == 2
    err = capsys.readouterr().err
    assert "trained on flat ground and sees no height map" in err and err.count("\n") == 1
    assert not (tmp_path / "plays").exists()
