"""One XLA CPU worker where jaxlib deadlocks on batched LAPACK calls, and only there."""

import os
import subprocess
import sys
import textwrap

import pytest

from motionkit.runtime import jaxcpu


@pytest.mark.parametrize(
    ("jaxlib", "env", "expected"),
    [
        ((0, 10), {}, "1"),
        ((0, 11), {}, "1"),
        ((0, 9), {}, None),  # before the batched split
        ((0, 12), {}, None),
        (None, {}, None),  # no jaxlib
        ((0, 10), {"PJRT_NPROC": "4"}, "4"),  # the user's own setting
        ((0, 10), {"JAX_PLATFORMS": "cuda"}, None),
        ((0, 10), {"JAX_PLATFORMS": "cpu"}, "1"),
    ],
)
def test_set_only_for_affected_cpu_installs(
    monkeypatch: pytest.MonkeyPatch, jaxlib, env: dict, expected: str | None
) -> None:
    monkeypatch.delenv("PJRT_NPROC", raising=False)
    monkeypatch.delenv("JAX_PLATFORMS", raising=False)
    for key, value in env.items():
        monkeypatch.setenv(key, value)
    monkeypatch.setattr(jaxcpu, "_jaxlib", lambda: jaxlib)
    jaxcpu.avoid_lapack_deadlock()
    assert os.environ.get("PJRT_NPROC") == expected


@pytest.mark.slow
def test_independent_batched_choleskys_finish() -> None:
    """Two independent batched Cholesky factorizations per step, as in MJX's step: with the
    affected jaxlib and more than one worker this hangs; after `import motionkit` it runs."""
    pytest.importorskip("jax")
    code = textwrap.dedent(
        """
        import motionkit, jax, jax.numpy as jnp
        a = jax.random.normal(jax.random.key(0), (1024, 29, 29))
        spd = a @ jnp.swapaxes(a, 1, 2) + 29 * jnp.eye(29)

        def body(i, carry):
            x, y = carry
            return (jnp.linalg.cholesky(x + 1e-3 * i)[:, 0, 0].sum() * 0 + x,
                    jnp.linalg.cholesky(y + 2e-3 * i)[:, 0, 0].sum() * 0 + y)

        x, y = jax.jit(lambda s: jax.lax.fori_loop(0, 50, body, (s, s + jnp.eye(29))))(spd)
        print(float(x[0, 0, 0]), float(y[0, 0, 0]))
        """
    )
    env = {k: v for k, v in os.environ.items() if k != "PJRT_NPROC"}
    done = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0, done.stderr[-2000:]
    first, second = map(float, done.stdout.split())
    assert second == pytest.approx(first + 1.0)
