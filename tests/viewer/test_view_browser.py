"""The viewer in a real browser: headless Chromium renders the page; screenshots show the robot
where the camera sees it, and moving the timeline through the Python API changes the picture."""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator

import numpy as np
import pytest
from viewer_support import Browser, find_chromium, free_port

pytest.importorskip("viser")

from motionkit.dataset import write
from motionkit.dataset.synthetic import synthetic_trajectory
from motionkit.robot import ironcub
from motionkit.viewer.app import CAMERA_FOV, CAMERA_OFFSET, ViewerApp
from motionkit.viewer.sources import resolve_clips

CHROMIUM = find_chromium()
pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(CHROMIUM is None, reason="no chromium on PATH (apt-get install chromium)"),
]
WIDTH, HEIGHT = 1280, 760
PANEL = 420  # px: the control panel on the right; the notification top left
NOTICE = (340, 170)
CHANGED = 40  # a pixel differs when a channel differs by more than this


def project(points: np.ndarray, eye: np.ndarray, target: np.ndarray, size: tuple[int, int]):
    """Pixel (column, row) of world points seen by a pinhole camera at eye looking at target
    (+z up, vertical field of view CAMERA_FOV), in an image of size (height, width)."""
    height, width = size
    forward = (target - eye) / np.linalg.norm(target - eye)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    relative = points - eye
    depth = relative @ forward
    focal = 0.5 * height / np.tan(0.5 * CAMERA_FOV)
    column = 0.5 * width + focal * (relative @ right) / depth
    row = 0.5 * height - focal * (relative @ up) / depth
    return column, row


def viewport_mask(size: tuple[int, int]) -> np.ndarray:
    """The pixels of the 3D view that no panel or notification covers."""
    mask = np.ones(size, bool)
    mask[:, size[1] - PANEL :] = False
    mask[: NOTICE[1], : NOTICE[0]] = False
    return mask


def changed(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.abs(a.astype(int) - b.astype(int)).max(axis=2) > CHANGED


def wait_for(browser: Browser, done: Callable[[np.ndarray], bool], seconds: float) -> np.ndarray:
    """Screenshots until `done` holds for two in a row (the page has settled)."""
    deadline = time.monotonic() + seconds
    previous = None
    while True:
        shot = browser.screenshot()
        if done(shot) and previous is not None and not changed(shot, previous).any():
            return shot
        if time.monotonic() > deadline:
            pytest.fail(f"the page did not reach the expected picture within {seconds} s")
        previous = shot if done(shot) else None
        time.sleep(0.3)


@pytest.fixture(scope="module")
def app(tmp_path_factory: pytest.TempPathFactory) -> Iterator[ViewerApp]:
    robot = ironcub()
    path = tmp_path_factory.mktemp("browser") / "walk.mcap"
    write(path, synthetic_trajectory(robot, 4.0, thrust=150.0), robot)
    viewer = ViewerApp(robot, resolve_clips(path), port=free_port())
    viewer.follow.value = False  # the camera stays where the test computes it
    yield viewer
    viewer.close()


def test_screenshots_show_the_robot_and_the_timeline(app: ViewerApp) -> None:
    assert CHROMIUM is not None
    links = app.scene.mesh_links
    target = np.asarray(app.motion.base_position[0], float)  # the initial camera's target
    eye = target + CAMERA_OFFSET

    app.scene.set_visible(False)
    browser = Browser(CHROMIUM, app.url, WIDTH, HEIGHT)
    try:
        # the empty scene: the floor grid drawn (many non-white pixels), settled
        empty = wait_for(browser, lambda shot: (shot.min(axis=2) < 200).mean() > 0.02, 30)
        size = empty.shape[:2]
        mask = viewport_mask(size)

        app.scene.set_visible(True)
        app.set_time(0.0)
        first = np.array([app.current_pose()[app.scene.poser.links[i]][:3, 3] for i in links])
        standing = wait_for(browser, lambda shot: changed(shot, empty)[mask].sum() > 2000, 40)

        # the changed pixels lie where the robot's links project (with room for mesh extent,
        # shadow and overlays), and fill a good part of that box
        column, row = project(first, eye, target, size)
        margin = 60
        box = np.zeros(size, bool)
        box[
            max(int(row.min()) - margin, 0) : int(row.max()) + margin,
            max(int(column.min()) - margin, 0) : int(column.max()) + margin,
        ] = True
        assert mask[box].all(), "the robot should project into the uncovered view"
        robot_pixels = changed(standing, empty) & mask
        inside = (robot_pixels & box).sum() / robot_pixels.sum()
        assert inside > 0.95, f"only {inside:.0%} of the changed pixels are where the robot is"
        assert (robot_pixels & box).sum() > 0.05 * box.sum()

        # moving the timeline changes the pose shown, and the picture where the robot is
        frame = app.set_time(1.0)
        assert frame == 120 and app.frame == 120
        later = np.array([app.current_pose()[app.scene.poser.links[i]][:3, 3] for i in links])
        assert np.abs(later - first).max() > 0.1
        moved = wait_for(browser, lambda shot: changed(shot, standing)[mask].sum() > 2000, 40)
        column2, row2 = project(later, eye, target, size)
        assert (changed(moved, empty) & mask).sum() > 2000  # the robot is still in view
        assert column2.min() > 0 and row2.min() > 0 and column2.max() < size[1] - PANEL
    finally:
        browser.close()
