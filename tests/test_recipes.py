"""Built-in recipes found by name, `motionkit recipes`, and the offline mocap sample."""

import tomllib
from pathlib import Path

import pytest

from motionkit import recipes
from motionkit.cli import main
from motionkit.retarget.batch import resolve_inputs


def test_find_by_name_path_or_suffix(tmp_path: Path) -> None:
    library = recipes.ROOT / "trajopt" / "library.toml"
    assert recipes.find("trajopt", "library") == library
    assert recipes.find("trajopt", "library.toml") == library
    own = tmp_path / "library.toml"
    own.write_text("")
    assert recipes.find("trajopt", own) == own  # a file wins over the built-in name
    with pytest.raises(recipes.RecipeError, match=r"nope: no such file, nor a built-in train"):
        recipes.find("train", "nope")
    with pytest.raises(recipes.RecipeError, match="no stage 'robot'"):
        recipes.builtin("robot")
    # a path that is not a file is not looked up by its last part
    with pytest.raises(recipes.RecipeError):
        recipes.find("trajopt", str(tmp_path / "missing" / "library"))


def test_every_stage_has_its_recipes() -> None:
    names = {stage: {r.name for r in recipes.builtin(stage)} for stage in recipes.STAGES}
    assert names["pipeline"] == {"tiny_cpu"}
    assert {"walk_to_fly", "takeoff", "landing", "library"} <= names["trajopt"]
    assert {"tiny_cpu", "paper_gpu"} <= names["train"]
    assert names["jet_ident"] == {"p250"} and names["retarget"] == {"cmu_walk", "sample_walks"}
    for stage in recipes.STAGES:
        for recipe in recipes.builtin(stage):
            assert recipe.summary and len(recipe.summary) <= 72, recipe.path
            tomllib.loads(recipe.path.read_text())


def test_recipes_command_lists_and_shows(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["recipes"]) == 0
    listing = capsys.readouterr().out
    for stage in recipes.STAGES:
        assert f"{stage}:" in listing
    assert "walk_to_fly" in listing and "sample_walks" in listing
    assert main(["recipes", "trajopt", "--show", "takeoff"]) == 0
    assert capsys.readouterr().out == recipes.find("trajopt", "takeoff").read_text()
    assert main(["recipes", "--show", "tiny_cpu"]) == 2  # in train and in pipeline
    assert "several stages" in capsys.readouterr().err


def test_unknown_recipe_is_a_usage_error(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit:
        main(["trajopt", "--scenario", "takeoff", "--config", "nope", "--out", "o"])
    assert exit.value.code == 2
    assert "nope: no such file, nor a built-in trajopt recipe (" in capsys.readouterr().err


def test_offline_sample_has_three_cmu_clips() -> None:
    clips = resolve_inputs([str(recipes.sample_mocap())])
    assert sorted(c.name for c in clips) == ["02_01", "11_01", "35_01"]
    assert sorted(c.path.suffix for c in clips) == [".amc", ".amc", ".bvh"]
    notice = (recipes.sample_mocap() / "README.md").read_text()
    assert "mocap.cs.cmu.edu" in notice and "NSF EIA-0196217" in notice
