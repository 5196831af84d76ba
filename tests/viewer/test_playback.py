"""The timeline: frame at a time, seeking, advancing with speed, loop and stop (hand-computed)."""

import numpy as np
import pytest

from motionkit.viewer.playback import Playback


@pytest.fixture
def playback() -> Playback:
    return Playback(np.arange(11) * 0.1)  # 11 frames, 0.0 to 1.0 s at 10 Hz


def test_frame_at_is_the_last_frame_not_after_t(playback: Playback) -> None:
    assert playback.frame_at(-5.0) == 0
    assert playback.frame_at(0.0) == 0
    assert playback.frame_at(0.099) == 0
    assert playback.frame_at(0.1) == 1
    assert playback.frame_at(0.55) == 5
    assert playback.frame_at(1.0) == 10
    assert playback.frame_at(7.0) == 10


def test_seek_clamps_to_the_clip(playback: Playback) -> None:
    assert playback.seek(0.37) == 3 and playback.now == pytest.approx(0.37)
    assert playback.seek(-1.0) == 0 and playback.now == 0.0
    assert playback.seek(3.0) == 10 and playback.now == 1.0


def test_advance_only_while_playing(playback: Playback) -> None:
    assert playback.advance(0.5) == 0 and playback.now == 0.0
    playback.playing = True
    assert playback.advance(0.25) == 2 and playback.now == pytest.approx(0.25)


def test_speed_scales_wall_time(playback: Playback) -> None:
    playback.playing, playback.speed = True, 2.0
    assert playback.advance(0.2) == 4  # 0.4 s of clip in 0.2 s
    playback.speed = 0.5
    assert playback.advance(0.2) == 5 and playback.now == pytest.approx(0.5)


def test_loop_wraps_and_no_loop_stops(playback: Playback) -> None:
    playback.playing = True
    playback.seek(0.9)
    assert playback.advance(0.35) == 2 and playback.now == pytest.approx(0.25)  # 1.25 -> 0.25
    assert playback.playing
    playback.loop = False
    playback.seek(0.9)
    assert playback.advance(0.35) == 10 and playback.now == 1.0
    assert not playback.playing


def test_backwards_loop(playback: Playback) -> None:
    playback.playing, playback.speed = True, -1.0
    playback.seek(0.1)
    assert playback.advance(0.3) == 8 and playback.now == pytest.approx(0.8)  # -0.2 -> 0.8
    playback.loop = False
    assert playback.advance(2.0) == 0 and not playback.playing


def test_real_time_over_many_ticks() -> None:
    """120 Hz clip, 60 ticks of 1/60 s at speed 1: one second of clip, frame 120."""
    playback = Playback(np.arange(1200) / 120.0, loop=False)
    playback.playing = True
    for _ in range(60):
        frame = playback.advance(1 / 60)
    assert frame == 120 and playback.now == pytest.approx(1.0)


def test_single_frame_and_bad_time() -> None:
    single = Playback(np.array([2.0]))
    single.playing = True
    assert single.advance(1.0) == 0 and single.now == 2.0 and single.duration == 0.0
    with pytest.raises(ValueError, match="at least one frame"):
        Playback(np.array([]))
