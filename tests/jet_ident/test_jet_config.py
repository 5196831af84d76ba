"""The config: defaults, the shipped recipe, TOML errors, the resolved-config round trip."""

from pathlib import Path

import pytest

from motionkit import recipes
from motionkit.core.errors import JetIdentError
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
    data = {
        "train": {"window": 120},
        "bench": {"ambient_c": [10, 30], "plant": "spool", "spool": {"fuel_lag_s": 0.1}},
        "model": {"priors": ["first_order"]},
    }
    config = JetIdentConfig.from_dict(data)
    assert config.bench.ambient_c == (10.0, 30.0) and config.train.window == 120
    assert config.bench.spool.fuel_lag_s == 0.1 and config.bench.spool.max_thrust_n == 230.0
    assert config.model.priors == ("first_order",)
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
        ({"bench": {"plant": "p300"}}, "'plant' should be one of 'p250', 'rate_form', 'spool'"),
        (
            {"bench": {"rate_form": {"coefficients": [1.0] * 9}}},
            r"\[bench.rate_form\]: 'coefficients' should be 10 numbers \(K_T, K_TT",
        ),
        ({"bench": {"p250": {"coeffs": [1.0, 2.0]}}}, r"\[bench.p250\]: 'coeffs' should be 13"),
        ({"bench": {"p250": {"scales": [1, 0, 1, 1]}}}, "positive thrust and throttle scales"),
        ({"bench": {"spool": {"idle_speed": 1.0}}}, "'idle_speed' should be finite and in"),
        ({"bench": {"spool": {"accel_limit": [0.5, 0.0]}}}, "'accel_limit'"),
        ({"model": {"priors": ["grey"]}}, "'priors' should be a list of second_order"),
        ({"model": {"priors": []}}, "'priors' should be non-empty"),
        ({"train": {"validation_blocks": 0}}, "'validation_blocks'"),
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
