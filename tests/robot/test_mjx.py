"""The MJCF export runs in MJX: put_model, and a jitted step of a batch of 8 worlds on the CPU."""

import numpy as np
import pytest

from motionkit.robot import ironcub

jax = pytest.importorskip("jax")
mujoco = pytest.importorskip("mujoco")
mjx = pytest.importorskip("mujoco.mjx")


@pytest.mark.slow
def test_batch_of_8_worlds_steps_without_nan() -> None:
    model = mujoco.MjModel.from_xml_path(str(ironcub().mjcf_path()))
    mx = mjx.put_model(model)
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("stand").id)
    stand = mjx.put_data(model, data)
    rng = np.random.default_rng(0)
    noise = jax.numpy.asarray(rng.normal(scale=0.02, size=(8, model.nq)))
    batch = jax.vmap(lambda dq: stand.replace(qpos=stand.qpos.at[7:].add(dq[7:])))(noise)
    batch = batch.replace(ctrl=jax.numpy.tile(stand.ctrl.at[23:].set(100.0), (8, 1)))

    @jax.jit
    def ten_steps(d):
        return jax.lax.fori_loop(0, 10, lambda _, x: jax.vmap(mjx.step, (None, 0))(mx, x), d)

    batch = ten_steps(batch)
    qpos = np.asarray(batch.qpos)
    assert qpos.shape == (8, model.nq)
    assert np.all(np.isfinite(qpos)) and np.all(np.isfinite(np.asarray(batch.qvel)))
    # Same first world in MuJoCo (C) and MJX agree after 10 steps of 2 ms.
    data.qpos[7:] += np.asarray(noise[0, 7:])
    data.ctrl[23:] = 100.0
    for _ in range(10):
        mujoco.mj_step(model, data)
    np.testing.assert_allclose(qpos[0], data.qpos, atol=2e-3)
