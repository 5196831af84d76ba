"""Pictures into an animated GIF (Pillow) or an MP4 (imageio-ffmpeg), written whole or not at all.

`animation_writer(out, fps, size)` checks the file name, the folder and the encoder before any
picture is drawn, and returns the function that writes them.
"""

from __future__ import annotations

import contextlib
import importlib
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

import numpy as np

from motionkit.core.errors import ViewerError
from motionkit.files.outputs import atomic_output, check_writable

FORMATS = (".gif", ".mp4")
GIF_MAX_FPS = 50.0  # GIF delays are whole hundredths of a second; browsers slow shorter ones

Writer = Callable[[Iterable[np.ndarray], int], None]  # (pictures, how many) -> None


def animation_writer(out: Path, fps: float, size: tuple[int, int]) -> Writer:
    """The function that writes `count` pictures (height, width, 3) uint8 of `size` (width,
    height) into `out` at `fps`; a ViewerError now for a name that is not .gif or .mp4, a
    folder, an unwritable place, a rate or size the format cannot take, or a missing encoder."""
    suffix = out.suffix.lower()
    if suffix not in FORMATS:
        raise ViewerError(f"--out {out}: expected a .gif or .mp4 file name")
    if out.is_dir():
        raise ViewerError(f"--out {out}: is a folder; give the .gif or .mp4 file to write")
    check_writable(out.parent, ViewerError)
    if suffix == ".gif":
        if fps > GIF_MAX_FPS:
            raise ViewerError(
                f"--fps {fps:g}: a GIF shows at most {GIF_MAX_FPS:g} frames per second (its "
                "delays are whole hundredths of a second); write an .mp4 or lower --fps"
            )
        _require("PIL", "writing a GIF", "pip install pillow")
        return lambda pictures, count: write_gif(out, pictures, fps, count)
    if size[0] % 2 or size[1] % 2:
        raise ViewerError(f"an MP4 needs an even width and height, got {size[0]}x{size[1]}")
    ffmpeg_executable()
    return lambda pictures, count: write_mp4(out, pictures, fps)


def _require(module: str, what: str, install: str) -> None:
    try:
        importlib.import_module(module)
    except ImportError as exc:
        raise ViewerError(f"{what} needs {module}: {install}") from exc


def ffmpeg_executable() -> str:
    """The ffmpeg of imageio-ffmpeg, or a ViewerError naming what to install."""
    try:
        import imageio_ffmpeg

        return imageio_ffmpeg.get_ffmpeg_exe()
    except (ImportError, RuntimeError) as exc:
        raise ViewerError(
            "writing an MP4 needs an ffmpeg encoder: pip install imageio-ffmpeg (or write a .gif)"
        ) from exc


def gif_delays(fps: float, count: int) -> list[int]:
    """Per-picture delays [ms] in whole hundredths of a second whose running sum stays within
    5 ms of count / fps (30 fps: 30, 40, 30, 30, 40, 30, ...)."""
    ticks = np.round(np.arange(count + 1) * 100.0 / fps)
    return [int(10 * d) for d in np.diff(ticks)]


def write_gif(path: Path, pictures: Iterable[np.ndarray], fps: float, count: int) -> None:
    """An animated GIF of `count` pictures looping forever, each with its own 256-colour
    palette (fast octree: small bright details such as a flame or a waypoint keep their colour,
    which median cut merges into the greys around them)."""
    from PIL import Image

    octree = Image.Quantize.FASTOCTREE
    frames = (Image.fromarray(p).quantize(256, method=octree) for p in pictures)
    first = next(frames, None)
    if first is None:
        raise ViewerError(f"{path}: no picture to write")
    delays = gif_delays(fps, count)
    with atomic_output(path) as stream:
        first.save(
            stream,
            format="GIF",
            save_all=True,
            append_images=frames,
            loop=0,
            duration=delays if count > 1 else delays[0],
        )


def write_mp4(path: Path, pictures: Iterable[np.ndarray], fps: float) -> None:
    """An H.264 MP4 (yuv420p) of the pictures."""
    with atomic_output(path) as stream:
        stream.close()  # ffmpeg writes the temporary file itself
        writer = None
        try:
            for picture in pictures:
                if writer is None:
                    writer = _ffmpeg_writer(stream.name, picture.shape, fps)
                _encode(path, writer, np.ascontiguousarray(picture))
        except BaseException:
            if writer is not None:
                with contextlib.suppress(Exception):
                    writer.close()
            raise
        if writer is None:
            raise ViewerError(f"{path}: no picture to write")
        _encode(path, writer, None)


def _ffmpeg_writer(name: str, shape: tuple[int, ...], fps: float) -> Any:
    """imageio-ffmpeg's writer of pictures of `shape` into file `name`, started."""
    import imageio_ffmpeg

    writer = imageio_ffmpeg.write_frames(
        name,
        (shape[1], shape[0]),
        fps=fps,
        macro_block_size=2,
        ffmpeg_log_level="error",
        output_params=["-f", "mp4", "-movflags", "+faststart"],
    )
    writer.send(None)
    return writer


def _encode(path: Path, writer: Any, picture: np.ndarray | None) -> None:
    """Hand ffmpeg a picture, or close it (None); a ViewerError when ffmpeg fails."""
    try:
        if picture is None:
            writer.close()
        else:
            writer.send(picture)
    except (OSError, RuntimeError) as exc:
        reason = " ".join(str(exc).split())[:300]
        raise ViewerError(f"{path}: ffmpeg could not write the MP4: {reason}") from exc
