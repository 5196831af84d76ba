"""The viewer with hostile clip texts: every text a clip carries reaches the page (viser Markdown,
which renders raw HTML) escaped, shown as typed; a taken port is announced, not silently moved."""

from __future__ import annotations

import re
import socket
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

import pytest
from conftest import TOY_SPEC, toy_biped_urdf
from hostile_support import free_port, tampered

from motionkit.cli import main
from motionkit.core.errors import RobotModelError
from motionkit.dataset import Source, write
from motionkit.dataset.synthetic import synthetic_trajectory
from motionkit.robot import ironcub, load_robot

viser = pytest.importorskip("viser")

from motionkit.viewer.app import ViewerApp  # noqa: E402
from motionkit.viewer.sources import resolve_clips  # noqa: E402

IMG = "<img src=x onerror=alert(1)>"
SVG = "<svg onload=alert(1)>"
SOURCE = Source(
    file="[click](javascript:alert(1))",
    clip="<script>alert(1)</script>",
    licence=IMG,
    acknowledgement="<iframe src=//evil>",
)
METRICS = {"<b>bold</b>": "<i>x</i>", "a|b": 1.5, "![beacon](/etc/hostname)": "**loud**"}
RAW_HTML = re.compile(r"<\s*/?\s*(img|script|svg|b|i|iframe)\b", re.IGNORECASE)


def markdown_sent(server: viser.ViserServer) -> list[str]:
    """Every Markdown text the server holds for its clients (creations and updates)."""
    texts = []
    for message in server._websock_server.get_message_buffer().message_from_id.values():
        props = getattr(message, "props", None)
        if props is not None and hasattr(props, "_markdown"):
            texts.append(props._markdown)
        if "_markdown" in getattr(message, "updates", {}):
            texts.append(message.updates["_markdown"])
    return texts


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A clip whose file name, robot name, source and metrics are HTML and Markdown, and a
    second clip (to be damaged)."""
    robot = ironcub()
    root = tmp_path_factory.mktemp("html")
    walk = synthetic_trajectory(robot, 1.0, seed=6)
    meta = replace(walk.metadata, source=SOURCE, metrics=METRICS)
    tampered(root / f"{IMG}.mcap", robot, replace(walk, metadata=meta), robot="<svg onload=x>")
    write(root / f"{SVG}.mcap", walk, robot)
    return root


@pytest.fixture(scope="module")
def app(folder: Path) -> Iterator[ViewerApp]:
    clips = sorted(resolve_clips(folder), key=lambda c: c.name)  # the hostile one first
    viewer = ViewerApp(ironcub(), clips, port=free_port())
    yield viewer
    viewer.close()


def test_clip_texts_reach_the_page_escaped(app: ViewerApp) -> None:
    content = app.info.content
    assert app.clips[0].metadata.source.licence == IMG  # the clip does carry the HTML
    assert "licence: &lt;img src=x onerror=alert\\(1\\)&gt;" in content
    assert (
        "source: &lt;script&gt;alert\\(1\\)&lt;/script&gt; \\(\\[click\\]\\(javascript:alert"
        in content
    )
    assert "**&lt;img src=x onerror=alert\\(1\\)&gt;** — walk" in content
    assert "| &lt;b&gt;bold&lt;/b&gt; | &lt;i&gt;x&lt;/i&gt; |" in content
    assert "| a\\|b | 1.5 |" in content  # a | in a name stays in its table cell
    assert "| \\!\\[beacon\\]\\(/etc/hostname\\) | \\*\\*loud\\*\\* |" in content
    assert "made for &lt;svg onload=x&gt; model" in content  # the other-robot warning
    sent = markdown_sent(app.server)
    assert content in sent  # what the page gets is the escaped text...
    assert not [text for text in sent if RAW_HTML.search(text)]  # ...and no raw tag anywhere
    assert not [text for text in sent if "data:image" in text]  # no local image embedded


def test_failure_message_on_the_page_is_escaped(app: ViewerApp, folder: Path) -> None:
    second = folder / f"{SVG}.mcap"
    data = bytearray(second.read_bytes())
    data[len(data) // 3] ^= 0xFF  # damaged after the start
    second.write_bytes(bytes(data))
    shown = app.motion
    app.pick(SVG)
    assert app.motion is shown  # still the first clip
    content = app.info.content
    assert content.startswith("**cannot show &lt;svg onload=alert\\(1\\)&gt;**: ")
    assert "&lt;svg onload=alert\\(1\\)&gt;.mcap: CRC mismatch" in content
    assert content in markdown_sent(app.server) and not RAW_HTML.search(content)


def test_a_robot_name_with_html_never_reaches_the_page(tmp_path: Path) -> None:
    """The robot's name is shown on its page, so only plain names are accepted (the spec)."""
    (tmp_path / "toy.urdf").write_text(toy_biped_urdf())
    (tmp_path / "toy.toml").write_text(TOY_SPEC.replace('name = "toy"', f'name = "{IMG}"'))
    with pytest.raises(RobotModelError, match=r"toy\.toml: 'name' should be 1-64 letters"):
        load_robot(tmp_path / "toy.urdf", tmp_path / "toy.toml")


def test_a_taken_port_is_announced(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture
) -> None:
    robot = ironcub()
    clip = write(tmp_path / "walk.mcap", synthetic_trajectory(robot, 0.5), robot)
    monkeypatch.setattr(ViewerApp, "wait", lambda self: None)  # return at once
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        assert main(["view", str(clip), "--port", str(port)]) == 0
    out = capsys.readouterr().out
    moved = re.search(rf"motionkit view: port {port} is in use; serving on port (\d+) instead", out)
    assert moved, out
    assert f"at http://127.0.0.1:{moved[1]} " in out and int(moved[1]) != port
