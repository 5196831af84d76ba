"""Writes stay inside their folder: a robot spec's name must be a plain one, names from user
input cannot lead out of --out or the cache, and `mocap fetch` asks for HTTPS, bounds what it
downloads and keeps a clip only when its files parse."""

from __future__ import annotations

import email.message
import urllib.error
import urllib.request
from pathlib import Path

import pytest
from test_fetch import ASF, Server, amc, files_in
from test_fetch import server as server  # the loopback server fixture

from motionkit.cli import main
from motionkit.core.errors import MotionkitError, RobotModelError
from motionkit.files.outputs import inside
from motionkit.mocap import fetch
from motionkit.mocap.fetch import FetchError, fetch_clips
from motionkit.robot import cache_dir, load_robot


@pytest.mark.parametrize("name", ["../../x", "/tmp/x", "a/b", ".hidden", "", "x" * 65, "a b"])
def test_spec_name_must_be_plain(
    name: str,
    toy_robot_files: tuple[Path, Path],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    urdf, spec = toy_robot_files
    spec.write_text(spec.read_text().replace('name = "toy"', f"name = {name!r}", 1))
    with pytest.raises(RobotModelError, match=r"toy\.toml: 'name' should be 1-64 letters"):
        load_robot(urdf, spec)
    out = tmp_path / "export"
    argv = ["robot", "export", "--urdf", str(urdf), "--spec", str(spec), "--format", "urdf"]
    assert main([*argv, "--out", str(out)]) == 2
    assert "'name' should be" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["toy.toml", "toy.urdf"]  # no export


def test_plain_spec_names_are_kept(toy_robot_files: tuple[Path, Path]) -> None:
    urdf, spec = toy_robot_files
    spec.write_text(spec.read_text().replace('name = "toy"', 'name = "toy-2.v_1"', 1))
    robot = load_robot(urdf, spec)
    assert robot.name == "toy-2.v_1"
    assert robot.urdf_path().parent.parent == cache_dir() / "robots"


def test_inside_refuses_paths_out_of_the_folder(tmp_path: Path) -> None:
    folder = tmp_path / "out"
    folder.mkdir()
    (folder / "link").symlink_to(tmp_path)
    assert inside(folder, "a.mcap", MotionkitError) == folder / "a.mcap"
    assert inside(folder, "sub/a.mcap", MotionkitError) == folder / "sub" / "a.mcap"
    for name in ("../a.mcap", "/etc/a.mcap", "sub/../../a.mcap", "link/a.mcap"):
        with pytest.raises(MotionkitError, match="would be written outside"):
            inside(folder, name, MotionkitError)


def test_trajopt_name_cannot_leave_out(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    pytest.importorskip("casadi")

    def no_solve(*args: object, **kwargs: object) -> None:
        raise AssertionError("solved")

    monkeypatch.setattr("motionkit.trajopt.solve.solve", no_solve)
    out = tmp_path / "out"
    argv = ["trajopt", "--scenario", "takeoff", "--out", str(out), "--name", "../escaped"]
    assert main(argv) == 2
    assert "'../escaped.mcap': would be written outside" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_fetch_asks_for_https_and_refuses_a_downgrade() -> None:
    assert fetch.CMU_BASE_URL == "https://mocap.cs.cmu.edu"
    handler = fetch._NoDowngrade()
    headers = email.message.Message()
    secure = urllib.request.Request("https://mocap.cs.cmu.edu/subjects/02/02_01.amc")
    moved = handler.redirect_request(secure, None, 301, "Moved", headers, "https://a.org/02_01.amc")
    assert moved is not None and moved.full_url == "https://a.org/02_01.amc"
    with pytest.raises(urllib.error.HTTPError, match="redirect to plain HTTP refused"):
        handler.redirect_request(secure, None, 302, "Found", headers, "http://a.org/02_01.amc")


def test_fetch_bounds_the_size(
    server: Server, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    server.files = {"/subjects/02/02.asf": ASF, "/subjects/02/02_01.amc": amc(50)}
    monkeypatch.setitem(fetch.MAX_BYTES, ".amc", 1000)
    with pytest.raises(FetchError, match=r"02_01\.amc: \d+ bytes announced, more than the 1000"):
        fetch_clips(["02_01"], cache=tmp_path, base_url=server.base_url, progress=False)
    assert files_in(tmp_path) == []


def test_fetch_keeps_a_clip_only_when_it_parses(server: Server, tmp_path: Path) -> None:
    stranger = amc(3).replace(b"ltibia", b"rtibia")  # plausible AMC, a bone its ASF lacks
    server.files = {"/subjects/02/02.asf": ASF, "/subjects/02/02_01.amc": stranger}
    with pytest.raises(FetchError, match=r"do not parse as an ASF/AMC clip: .*'rtibia' is not"):
        fetch_clips(["02_01"], cache=tmp_path, base_url=server.base_url, progress=False)
    assert files_in(tmp_path) == []
    server.files["/subjects/02/02_01.amc"] = amc(3)
    ((motion, skeleton),) = fetch_clips(
        ["02_01"], cache=tmp_path, base_url=server.base_url, progress=False
    )
    assert (motion.read_bytes(), skeleton.read_bytes()) == (amc(3), ASF)
    assert files_in(tmp_path) == ["02/02.asf", "02/02_01.amc"]
