"""The compiled-function cache: a cached library is loaded without rebuilding the derivatives,
and its functions give the values of the uncompiled ones."""

from __future__ import annotations

import platform
from pathlib import Path

import casadi as cs
import numpy as np
import pytest

from motionkit.trajopt import compiled


def _derive(function: cs.Function) -> list[cs.Function]:
    _derive.calls += 1  # type: ignore[attr-defined]
    x = cs.SX.sym("x", 2)
    return [cs.Function(f"{function.name()}_jac", [x], [cs.jacobian(function(x), x)])]


@pytest.fixture
def base(tmp_path, monkeypatch) -> cs.Function:
    """(x0^2, x0 x1), compiled into an empty cache folder; _derive's call count reset."""
    if compiled.compiler() is None:
        pytest.skip("no C compiler")
    monkeypatch.setattr(compiled, "cache_dir", lambda: tmp_path)
    _derive.calls = 0  # type: ignore[attr-defined]
    x = cs.SX.sym("x", 2)
    return cs.Function("square", [x], [cs.vertcat(x[0] ** 2, x[0] * x[1])])


def test_cached_library_loads_without_deriving(base, tmp_path) -> None:
    first = compiled.compile_groups([base], _derive)[0]
    assert _derive.calls == 1  # type: ignore[attr-defined]
    again = compiled.compile_groups([base], _derive)[0]
    assert _derive.calls == 1  # type: ignore[attr-defined]
    point = np.array([3.0, -2.0])
    for group in (first, again):
        assert [f.name() for f in group] == ["square", "square_jac"]
        np.testing.assert_allclose(np.array(group[0](point)).ravel(), [9.0, -6.0])
        np.testing.assert_allclose(np.array(group[1](point)), [[6.0, 0.0], [-2.0, 3.0]])
    # a different expression graph is a different library
    x = cs.SX.sym("x", 2)
    other = cs.Function("square", [x], [cs.vertcat(x[0] ** 2, x[0] + x[1])])
    compiled.compile_groups([other], _derive)
    assert _derive.calls == 2  # type: ignore[attr-defined]
    assert len(list((tmp_path / "trajopt_compiled").glob("square_*.so"))) == 2


def test_native_library_is_keyed_by_cpu(base, tmp_path, monkeypatch) -> None:
    """A library built with -march=native is not reused on another CPU (a shared cache folder):
    another CPU identity builds another library; without -march=native the CPU is not in the
    key."""

    def libraries() -> int:
        return len(list((tmp_path / "trajopt_compiled").glob("square_*.so")))

    monkeypatch.setenv("MOTIONKIT_TRAJOPT_COMPILE", "-O0 -march=native")
    for cpu, count in (("cpu A", 1), ("cpu A", 1), ("cpu B", 2)):
        monkeypatch.setattr(compiled, "cpu_identity", lambda cpu=cpu: cpu)
        group = compiled.compile_groups([base], _derive)[0]
        np.testing.assert_allclose(np.array(group[0]([3.0, -2.0])).ravel(), [9.0, -6.0])
        assert libraries() == count
    monkeypatch.setenv("MOTIONKIT_TRAJOPT_COMPILE", "-O0")
    for cpu, count in (("cpu A", 3), ("cpu B", 3)):
        monkeypatch.setattr(compiled, "cpu_identity", lambda cpu=cpu: cpu)
        compiled.compile_groups([base], _derive)
        assert libraries() == count
    assert _derive.calls == 3  # type: ignore[attr-defined]


def test_cpu_identity_names_this_machine() -> None:
    identity = compiled.cpu_identity()
    assert platform.machine() in identity
    if Path("/proc/cpuinfo").exists():
        assert "flags" in identity or "model name" in identity
