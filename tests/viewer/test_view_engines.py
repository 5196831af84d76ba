"""The viewer shows the engines' lag of a clip with a throttle channel: per jet two bars at the
current frame (throttle, thrust per T_max) and a time plot of both; a clip without a throttle
shows neither."""

from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from viewer_support import free_port

pytest.importorskip("viser")

from motionkit.dataset import write
from motionkit.dataset.synthetic import synthetic_trajectory
from motionkit.robot import ironcub
from motionkit.viewer.app import ViewerApp
from motionkit.viewer.engines import engine_shares
from motionkit.viewer.sources import resolve_clips

RATE = 60.0


def lagging_flight(robot) -> object:
    """2 s at 60 Hz: every jet's throttle steps from 20 % to 70 % at 1 s; its thrust follows
    from 50 N toward 150 N, 0.1 s late, with a 0.5 s time constant."""
    flight = synthetic_trajectory(robot, 2.0, RATE, thrust=50.0, kind="flight", seed=4)
    time = flight.time
    throttle = np.where(time < 1.0, 20.0, 70.0)
    late = np.clip(time - 1.1, 0.0, None)
    thrust = 50.0 + 100.0 * (1.0 - np.exp(-late / 0.5))
    jets = len(robot.spec.jets)
    return replace(
        flight, throttle=np.tile(throttle[:, None], (1, jets)).astype(np.float32),
        thrust=np.tile(thrust[:, None], (1, jets)).astype(np.float32),
    )  # fmt: skip


@pytest.fixture(scope="module")
def viewer(tmp_path_factory: pytest.TempPathFactory) -> Iterator[ViewerApp]:
    robot = ironcub()
    root: Path = tmp_path_factory.mktemp("engines")
    write(root / "a_lag.mcap", lagging_flight(robot), robot)
    write(root / "b_walk.mcap", synthetic_trajectory(robot, 1.0, rate=RATE), robot)
    clips = sorted(resolve_clips(root), key=lambda c: c.name)  # the clip with a throttle first
    app = ViewerApp(robot, clips, port=free_port())
    yield app
    app.close()


def test_two_bars_per_jet_at_the_current_frame(viewer: ViewerApp) -> None:
    bars = viewer.engines
    assert bars is not None and len(bars.throttle) == len(bars.thrust) == 4
    viewer.set_time(0.5)  # before the step: 20 %, 50 N = 20 % of T_max (250 N)
    assert [b.value for b in bars.throttle] == pytest.approx([20.0] * 4)
    assert [b.value for b in bars.thrust] == pytest.approx([20.0] * 4)
    assert bars.labels[0].content == r"**chest\_left**: throttle 20 %, thrust 50 N (20 % of T_max)"
    frame = viewer.set_time(1.5)  # after it: 70 % commanded, the thrust still on its way
    expected = 50.0 + 100.0 * (1.0 - np.exp(-(viewer.motion.time[frame] - 1.1) / 0.5))
    assert [b.value for b in bars.throttle] == pytest.approx([70.0] * 4)
    assert [b.value for b in bars.thrust] == pytest.approx([100 * expected / 250.0] * 4, abs=1e-3)
    # the thrust bar behind: below 150 N (60 % of T_max), where the thrust is going
    assert bars.thrust[0].value < 60.0 < bars.throttle[0].value


def test_a_lag_plot_per_jet(viewer: ViewerApp) -> None:
    motion = viewer.motion
    assert len(viewer.lag_plots) == 4
    time, throttle, thrust = viewer.lag_plots[2].data
    rows = np.searchsorted(motion.time, time)
    np.testing.assert_allclose(throttle, motion.throttle[rows, 2] / 100.0, rtol=1e-6)
    np.testing.assert_allclose(thrust, motion.thrust[rows, 2] / 250.0, rtol=1e-6)
    # the thrust's share is still near its start 0.1 s after the throttle stepped
    step = np.searchsorted(time, 1.0)
    assert throttle[step] == pytest.approx(0.7) and thrust[step + 5] < 0.21


def test_a_clip_without_throttle_has_neither(viewer: ViewerApp) -> None:
    viewer.select_clip(1)
    try:
        assert viewer.motion.throttle is None and engine_shares(viewer.motion, viewer.t_max) is None
        assert viewer.engines is None and viewer.lag_plots == []
    finally:
        viewer.select_clip(0)
    assert viewer.engines is not None and len(viewer.lag_plots) == 4
