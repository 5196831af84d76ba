"""The training curves: the running mean by hand, CSV cells read as numbers, the PNG drawn
from a run's CSVs (also by `motionkit train curves`), and a clear error without them."""

import math
from pathlib import Path

import numpy as np
import pytest

from motionkit.cli import main
from motionkit.core.errors import TrainError
from motionkit.train.curves import PANELS, draw_curves, read_table, running_mean

PNG = b"\x89PNG\r\n\x1a\n"


def test_running_mean_skips_missing_values() -> None:
    values = np.array([1.0, 3.0, np.nan, 5.0, 7.0])
    # windows of 2: [1], [1, 3], [3, nan], [nan, 5], [5, 7]
    np.testing.assert_allclose(running_mean(values, 2), [1.0, 2.0, 3.0, 5.0, 6.0])
    assert math.isnan(running_mean(np.array([np.nan, 2.0]), 1)[0])
    np.testing.assert_allclose(running_mean(values[:2], 10), [1.0, 2.0])


def write_run(folder: Path, iterations: int = 30) -> None:
    columns = ["iteration", "env_steps", *(c for cs in PANELS.values() for c in cs)]
    rows = [",".join(columns)]
    for i in range(1, iterations + 1):
        cells = [str(i), str(8192 * i)] + [f"{0.01 * i:.3f}"] * (len(columns) - 2)
        cells[3] = ""  # an empty cell (an undefined figure) reads as NaN
        rows.append(",".join(cells))
    (folder / "train.csv").write_text("\n".join(rows) + "\n")
    (folder / "eval.csv").write_text("iteration,eval_approach_speed\n10,0.2\n30,0.4\n")


def test_tables_read_as_floats(tmp_path: Path) -> None:
    write_run(tmp_path)
    table = read_table(tmp_path / "train.csv")
    assert table["env_steps"][-1] == 8192 * 30
    assert np.isnan(table[list(table)[3]]).all()
    assert read_table(tmp_path / "absent.csv") == {}
    evaluation = read_table(tmp_path / "eval.csv")
    np.testing.assert_array_equal(evaluation["eval_approach_speed"], [0.2, 0.4])


def test_curves_are_drawn_by_the_library_and_the_command(tmp_path: Path, capsys) -> None:
    write_run(tmp_path)
    assert draw_curves(tmp_path) == tmp_path / "curves.png"
    assert (tmp_path / "curves.png").read_bytes()[:8] == PNG
    other = tmp_path / "other.png"
    assert main(["train", "curves", str(tmp_path), "--out", str(other)]) == 0
    assert other.read_bytes()[:8] == PNG and str(other) in capsys.readouterr().out


def test_a_course_run_gets_a_panel_of_levels_per_kind(tmp_path: Path) -> None:
    """Nine panels fill 3 rows; a run with terrain_level_KIND columns draws a fourth row
    (13 x 12 inches at 90 dpi instead of 13 x 9)."""
    write_run(tmp_path)
    flat_height = int.from_bytes(draw_curves(tmp_path).read_bytes()[20:24], "big")
    with (tmp_path / "train.csv").open() as stream:
        lines = stream.read().splitlines()
    rows = [lines[0] + ",terrain_level_rough,terrain_level_pits"]
    rows += [f"{line},{0.1 * k:.1f},{0.05 * k:.2f}" for k, line in enumerate(lines[1:])]
    (tmp_path / "train.csv").write_text("\n".join(rows) + "\n")
    height = int.from_bytes(draw_curves(tmp_path).read_bytes()[20:24], "big")
    assert (flat_height, height) == (9 * 90, 12 * 90)


def test_a_folder_without_a_training_log_is_refused(tmp_path: Path) -> None:
    with pytest.raises(TrainError, match=r"no train\.csv"):
        draw_curves(tmp_path)
    assert list(tmp_path.iterdir()) == []


def test_stage_switches_are_read_where_the_stage_changes() -> None:
    from motionkit.train.curves import _stage_switches

    train = {"env_steps": np.array([1e6, 2e6, 3e6, 4e6]), "stage": np.array([0, 0, 1, 2])}
    np.testing.assert_array_equal(_stage_switches(train), [3.0, 4.0])
    assert len(_stage_switches({"env_steps": np.array([1e6])})) == 0
