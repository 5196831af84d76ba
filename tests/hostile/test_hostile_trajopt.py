"""Hostile recipes through `motionkit trajopt`: verbatim IPOPT options that IPOPT refuses are
named with the recipe in one line before any work, with no traceback and no output."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from hostile_support import refused

pytest.importorskip("casadi")

OPTIONS = {
    "unknown option": ("not_an_ipopt_option = 3", "not_an_ipopt_option = 3: IPOPT has no such"),
    "wrong type": ('acceptable_tol = "tight"', "acceptable_tol = 'tight': a value of the wrong"),
    "invalid setting": ('mu_strategy = "bogus"', "mu_strategy = 'bogus': not a setting IPOPT"),
}


@pytest.mark.parametrize("case", OPTIONS)
def test_an_option_ipopt_refuses_is_named_with_the_recipe(
    case: str, tmp_path: Path, capsys
) -> None:
    line, message = OPTIONS[case]
    recipe = tmp_path / "recipe.toml"
    recipe.write_text(f"[solver.options]\nmax_iter = 100\n{line}\n")
    out = tmp_path / "out"
    argv = ["trajopt", "--scenario", "takeoff", "--config", str(recipe), "--out", str(out)]
    refused(argv, capsys, 2, re.escape(f"{recipe}: [solver.options] {message}"))
    assert not out.exists()
