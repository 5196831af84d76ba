"""CMU clip download against a small HTTP server on loopback serving synthetic ASF/AMC files."""

from __future__ import annotations

import os
import socket
import sys
import threading
from collections.abc import Iterator
from dataclasses import dataclass, field
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

import pytest

from motionkit.core.errors import MotionkitError
from motionkit.mocap import fetch
from motionkit.mocap.fetch import ClipId, FetchError, clip_cache_dir, fetch_clips, parse_clip_id

ASF = b"""# two-bone test skeleton
:version 1.10
:name test
:units
  mass 1.0
  length 0.45
  angle deg
:root
  order TX TY TZ RX RY RZ
  axis XYZ
  position 0 0 0
  orientation 0 0 0
:bonedata
  begin
    id 1
    name lfemur
    direction 0 -1 0
    length 7
    axis 0 0 20 XYZ
    dof rx ry rz
    limits (-160.0 20.0)
           (-70.0 70.0)
           (-60.0 70.0)
  end
  begin
    id 2
    name ltibia
    direction 0 -1 0
    length 7.5
    axis 0 0 20 XYZ
    dof rx
    limits (-10.0 170.0)
  end
:hierarchy
  begin
    root lfemur
    lfemur ltibia
  end
"""


def amc(frames: int = 3) -> bytes:
    lines = ["#!OML:ASF test.asf", ":FULLY-SPECIFIED", ":DEGREES"]
    for k in range(1, frames + 1):
        lines += [
            str(k),
            f"root 0 {17 + k * 0.1:.1f} 0 0 0 0",
            f"lfemur {k} 0 0",
            f"ltibia {2 * k}",
        ]
    return ("\r\n".join(lines) + "\r\n").encode()


HTML = b"<!DOCTYPE html>\n<html><body>Motion not found</body></html>\n"


@dataclass
class Server:
    base_url: str
    files: dict[str, bytes]  # path -> body served with 200
    requests: list[str] = field(default_factory=list)
    html_paths: set[str] = field(default_factory=set)  # served as text/html with 200
    short_paths: set[str] = field(default_factory=set)  # body cut to half of Content-Length
    slow_paths: set[str] = field(default_factory=set)  # answered only after the test ends
    release: threading.Event = field(default_factory=threading.Event)


@pytest.fixture
def server() -> Iterator[Server]:
    state = Server("", {})

    class Handler(BaseHTTPRequestHandler):
        def do_GET(self) -> None:
            state.requests.append(self.path)
            if self.path in state.slow_paths:
                state.release.wait(5)
                return
            body = state.files.get(self.path)
            if body is None:
                self.send_error(404)
                return
            html = self.path in state.html_paths
            self.send_response(200)
            self.send_header("Content-Type", "text/html" if html else "application/octet-stream")
            self.send_header("Content-Length", str(len(body)))
            self.end_headers()
            cut = len(body) // 2 if self.path in state.short_paths else len(body)
            self.wfile.write(body[:cut])

        def log_message(self, format: str, *args: object) -> None:  # keep pytest output clean
            pass

    httpd = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
    state.base_url = f"http://127.0.0.1:{httpd.server_address[1]}"
    thread = threading.Thread(target=httpd.serve_forever, args=(0.01,), daemon=True)
    thread.start()
    yield state
    state.release.set()
    httpd.shutdown()
    httpd.server_close()


def files_in(folder: Path) -> list[str]:
    """Every file below `folder` (hidden temporaries included), relative, sorted."""
    found = []
    for parent, _, names in os.walk(folder):
        found += [str(Path(parent, n).relative_to(folder)) for n in names]
    return sorted(found)


def test_parse_clip_id() -> None:
    assert parse_clip_id("02_01") == ClipId(2, 1)
    assert parse_clip_id("2_1") == ClipId(2, 1)
    assert parse_clip_id(" 143_05 ") == ClipId(143, 5)
    assert str(parse_clip_id("2_1")) == "02_01"
    assert str(parse_clip_id("143_5")) == "143_05"
    assert parse_clip_id("143_5").subject_code == "143"


@pytest.mark.parametrize(
    "text", ["", "02", "02-01", "02_01.amc", "a_01", "0_1", "02_0", "1234_1", "02_123"]
)
def test_parse_clip_id_rejects(text: str) -> None:
    with pytest.raises(FetchError, match="bad CMU clip id") as caught:
        parse_clip_id(text)
    assert isinstance(caught.value, MotionkitError)


def test_cache_dir_follows_motionkit_cache(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setenv("MOTIONKIT_CACHE", str(tmp_path))
    assert clip_cache_dir() == tmp_path / "mocap" / "cmu"


def test_downloads_once_and_reuses_the_cache(
    server: Server, monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    monkeypatch.setenv("MOTIONKIT_CACHE", str(tmp_path))
    server.files = {
        "/subjects/02/02.asf": ASF,
        "/subjects/02/02_01.amc": amc(3),
        "/subjects/02/02_02.amc": amc(2),
    }
    paths = fetch_clips(["02_01", "2_2"], base_url=server.base_url, progress=False)

    folder = tmp_path / "mocap" / "cmu" / "02"
    assert paths == [
        (folder / "02_01.amc", folder / "02.asf"),
        (folder / "02_02.amc", folder / "02.asf"),
    ]
    for amc_path, asf_path in paths:
        assert asf_path.read_bytes() == ASF
        assert amc_path.read_bytes() == server.files[f"/subjects/02/{amc_path.name}"]
    assert server.requests.count("/subjects/02/02.asf") == 1  # one skeleton for two trials
    assert len(server.requests) == 3
    assert files_in(folder) == ["02.asf", "02_01.amc", "02_02.amc"]

    assert fetch_clips(["02_01", "02_02"], base_url=server.base_url, progress=False) == paths
    assert len(server.requests) == 3  # all from the cache
    assert fetch_clips("02_01", base_url=server.base_url, progress=False) == paths[:1]


def test_invalid_cached_file_is_downloaded_again(server: Server, tmp_path: Path) -> None:
    server.files = {"/subjects/07/07.asf": ASF, "/subjects/07/07_03.amc": amc()}
    (tmp_path / "07").mkdir()
    (tmp_path / "07" / "07.asf").write_bytes(b"truncated")
    ((amc_path, asf_path),) = fetch_clips(
        ["7_3"], cache=tmp_path, base_url=server.base_url, progress=False
    )
    assert asf_path.read_bytes() == ASF and amc_path.read_bytes() == amc()
    assert sorted(server.requests) == ["/subjects/07/07.asf", "/subjects/07/07_03.amc"]


def test_missing_clip_raises_and_writes_nothing(server: Server, tmp_path: Path) -> None:
    server.files = {"/subjects/02/02.asf": ASF}
    with pytest.raises(FetchError, match=r"clip 02_09: http://127\.0\.0\.1:\d+/subjects/02/02_09"):
        fetch_clips(["02_09"], cache=tmp_path, base_url=server.base_url, progress=False)
    assert files_in(tmp_path) == []
    assert list(tmp_path.iterdir()) == []  # not even an empty subject folder


def test_missing_skeleton_raises(server: Server, tmp_path: Path) -> None:
    server.files = {"/subjects/05/05_01.amc": amc()}
    with pytest.raises(FetchError, match=r"clip 05_01: .*/subjects/05/05\.asf: HTTP 404"):
        fetch_clips(["05_01"], cache=tmp_path, base_url=server.base_url, progress=False)
    assert files_in(tmp_path) == []  # a motion is kept only with the skeleton it parses with


@pytest.mark.parametrize("content_type", ["html", "octet"])
def test_html_page_with_200_raises(server: Server, tmp_path: Path, content_type: str) -> None:
    server.files = {"/subjects/02/02.asf": ASF, "/subjects/02/02_04.amc": HTML}
    if content_type == "html":
        server.html_paths.add("/subjects/02/02_04.amc")
    with pytest.raises(FetchError, match=r"clip 02_04: .*02_04\.amc: got an HTML page"):
        fetch_clips(["02_04"], cache=tmp_path, base_url=server.base_url, progress=False)
    assert files_in(tmp_path) == []


def test_wrong_content_raises(server: Server, tmp_path: Path) -> None:
    server.files = {"/subjects/02/02.asf": amc(), "/subjects/02/02_01.amc": ASF}
    with pytest.raises(FetchError, match=r"clip 02_01: .*02_01\.amc: not an AMC motion"):
        fetch_clips(["02_01"], cache=tmp_path, base_url=server.base_url, progress=False)
    server.files["/subjects/02/02_01.amc"] = amc()
    with pytest.raises(FetchError, match=r"02\.asf: not an ASF skeleton: no :bonedata or :hier"):
        fetch_clips(["02_01"], cache=tmp_path, base_url=server.base_url, progress=False)
    assert files_in(tmp_path) == []


def test_short_body_raises(server: Server, tmp_path: Path) -> None:
    body = amc(50)
    server.files = {"/subjects/02/02.asf": ASF, "/subjects/02/02_01.amc": body}
    server.short_paths.add("/subjects/02/02_01.amc")
    with pytest.raises(FetchError, match=f"clip 02_01: .*: .* {len(body) // 2}.*{len(body)} bytes"):
        fetch_clips(["02_01"], cache=tmp_path, base_url=server.base_url, progress=False)
    assert files_in(tmp_path) == []


def test_connection_refused_names_the_url(tmp_path: Path) -> None:
    with socket.socket() as sock:  # a port that was free a moment ago and has no listener
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
    url = f"http://127.0.0.1:{port}/subjects/02/02_01.amc"
    with pytest.raises(FetchError, match=f"clip 02_01: cannot reach {url}"):
        fetch_clips(["02_01"], cache=tmp_path, base_url=f"http://127.0.0.1:{port}", progress=False)
    assert list(tmp_path.iterdir()) == []


def test_timeout_raises(server: Server, tmp_path: Path) -> None:
    server.slow_paths.add("/subjects/02/02_01.amc")
    with pytest.raises(
        FetchError, match=r"clip 02_01: cannot reach .*02_01\.amc: no answer within 0\.2 s"
    ):
        fetch_clips(
            ["02_01"], cache=tmp_path, base_url=server.base_url, progress=False, timeout=0.2
        )
    assert list(tmp_path.iterdir()) == []


def test_interrupt_leaves_nothing(
    server: Server, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    server.files = {"/subjects/02/02.asf": ASF, "/subjects/02/02_01.amc": amc(2000)}

    def interrupt(self: object, n: int) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(fetch._LineBar, "update", interrupt)
    monkeypatch.setitem(sys.modules, "tqdm", None)  # use the built-in bar
    with pytest.raises(KeyboardInterrupt):
        fetch_clips(["02_01"], cache=tmp_path, base_url=server.base_url, progress=True)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("with_tqdm", [True, False])
def test_progress_on_stderr(
    server: Server,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    with_tqdm: bool,
) -> None:
    if not with_tqdm:
        monkeypatch.setitem(sys.modules, "tqdm", None)
    server.files = {"/subjects/02/02.asf": ASF, "/subjects/02/02_01.amc": amc()}
    fetch_clips(["02_01"], cache=tmp_path, base_url=server.base_url, progress=True)
    captured = capsys.readouterr()
    assert captured.out == ""
    assert "02_01.amc" in captured.err and "02.asf" in captured.err
    assert "100%" in captured.err
    if not with_tqdm:
        size = len(amc()) / 1024
        assert f"02_01.amc: {size:.1f}/{size:.1f} KiB (100%)\n" in captured.err
