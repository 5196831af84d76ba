"""The viser browser viewer: clips, folders of clips, training runs, the robot alone.

    motionkit view datasets/walk            # or: motionkit view --robot
    from motionkit.viewer import ViewerApp, resolve_clips
    app = ViewerApp(robot, resolve_clips("walk.mcap"))   # served on 127.0.0.1 at app.url

resolve_clips gives a ClipInfo per checked clip; Playback is the timeline the app drives.

Without a browser (`motionkit render`), MuJoCo's offscreen renderer draws a clip into a GIF or an
MP4: render_clip(clip, out, robot, RenderConfig(fps=30)).

sources: PATH -> checked clips; playback: the timeline; posing: link poses per frame; meshes: the
robot's visuals (cached); scene: robot and overlays in viser; skeleton: a retargeted clip's human
beside the robot; app: the server and its page; render: a clip into a GIF or an MP4, drawn by
offscreen (MuJoCo, OpenGL) and written by animation (Pillow, imageio-ffmpeg).
Importing `motionkit.viewer.app` needs the [viewer] extra (viser); the rest needs only numpy
until it draws (mujoco, trimesh) or writes (Pillow).
`ViewerApp` is imported on first use (a ViewerError naming the extra without it).
"""

from motionkit.core.errors import ViewerError
from motionkit.core.extras import require
from motionkit.viewer.playback import Playback
from motionkit.viewer.render import RenderConfig, render_clip
from motionkit.viewer.sources import ClipInfo, resolve_clips

__all__ = ["ClipInfo", "Playback", "RenderConfig", "ViewerApp", "render_clip", "resolve_clips"]


def __getattr__(name: str) -> object:
    if name == "ViewerApp":  # imports viser only when asked for
        require("viewer", "motionkit.viewer.ViewerApp", ViewerError)
        from motionkit.viewer.app import ViewerApp

        return ViewerApp
    raise AttributeError(f"module 'motionkit.viewer' has no attribute {name!r}")
