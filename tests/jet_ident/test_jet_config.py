"""The config: defaults, the shipped recipe, TOML errors, the resolved-config round trip."""

from pathlib import Path

import pytest

from motionkit import recipes
from motionkit.errors import JetIdentError
from motionkit.jet_ident.config import JetIdentConfig, TrainConfig

RECIPE = recipes.find("jet_ident", "p250")


def test_recipe_loads() -> None:
    config = JetIdentConfig.from_toml(RECIPE)
    assert config == JetIdentConfig()  # the recipe spells out the defaults
    assert config.model.hidden == 32 and config.train.max_steps == 3000
    assert config.bench.train_seeds == (1, 2, 3, 4, 5)
    assert config.bench.heldout_seeds == (101, 102, 103, 104)
    assert not set(config.bench.heldout_seeds) & set(config.bench.train_seeds)


def test_to_toml_round_trip(tmp_path: Path) -> None:
    config = JetIdentConfig.from_dict({"train": {"window": 120}, "bench": {"ambient_c": [10, 30]}})
    assert config.bench.ambient_c == (10.0, 30.0) and config.train.window == 120
    (tmp_path / "c.toml").write_text(config.to_toml())
    assert JetIdentConfig.from_toml(tmp_path / "c.toml") == config


@pytest.mark.parametrize(
    ("data", "message"),
    [
        ({"trian": {}}, r"unknown keys \['trian'\]"),
        ({"train": {"windw": 3}}, r"\[train\]: unknown keys \['windw'\]"),
        ({"train": {"window": "long"}}, "'window' should be int"),
        ({"train": {"window": 2.5}}, "'window' should be int"),
        ({"model": {"hidden": True}}, "'hidden' should be int"),
        ({"train": {"window": 0}}, r"\[train\]: 'window' should be finite and >= 1, got 0"),
        ({"train": {"validation_fraction": 1.0}}, "validation_fraction"),
        ({"bench": {"ambient_c": [30.0, 10.0]}}, "ambient_c"),
        ({"bench": 3}, "should be a table"),
    ],
)
def test_bad_values_name_the_key(data: dict, message: str) -> None:
    with pytest.raises(JetIdentError, match=message):
        JetIdentConfig.from_dict(data, "r.toml")


def test_bad_file(tmp_path: Path) -> None:
    (tmp_path / "bad.toml").write_text("[train\n")
    with pytest.raises(JetIdentError, match="not valid TOML"):
        JetIdentConfig.from_toml(tmp_path / "bad.toml")
    assert TrainConfig().warmup < TrainConfig().window
