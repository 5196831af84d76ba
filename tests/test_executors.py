"""The executors without Ray: local processes yield every result, run a task whose worker died
once more and report it lost after a second death; --cluster addresses are checked, a
--cluster without the [cluster] extra names it, and a refused Ray handshake is tried again
and leaves no half-made connection. Task keys in an output folder's manifest."""

from __future__ import annotations

import argparse
import json
import operator
import os
import sys
from pathlib import Path

import pytest

from motionkit.cli import cluster_address, main
from motionkit.core.errors import RetargetError
from motionkit.files.outputs import (
    MANIFEST,
    Manifest,
    claim_out,
    record_names,
    up_to_date,
    write_files,
)
from motionkit.runtime.executors import InProcess, Processes, open_executor
from motionkit.runtime.executors import _ray_session as ray_session

FAULTS = Path(__file__).resolve().parent / "faults"  # sitecustomize.py: kills tasks on request


def run(executor, items: list[int], names: list[str]) -> dict[int, object]:
    return {d.index: d.value if d.value is not None else d.lost
            for d in executor.run(operator.add, items, names, 100)}  # fmt: skip


def test_in_process_and_processes_give_every_result() -> None:
    assert run(InProcess(), [1, 2, 3], ["a", "b", "c"]) == {0: 101, 1: 102, 2: 103}
    assert run(Processes(2), [1, 2, 3], ["a", "b", "c"]) == {0: 101, 1: 102, 2: 103}


def test_a_dead_local_worker_loses_only_its_task(tmp_path: Path, monkeypatch) -> None:
    """The workers start with tests/faults on their path, whose start-up hook kills tasks."""
    monkeypatch.setenv(
        "PYTHONPATH", os.pathsep.join([str(FAULTS), os.environ.get("PYTHONPATH", "")])
    )
    monkeypatch.setenv("MOTIONKIT_TEST_KILL", f"{tmp_path},b,1")
    assert run(Processes(2), [1, 2, 3], ["a", "b", "c"]) == {0: 101, 1: 102, 2: 103}
    assert [p.name for p in tmp_path.iterdir()] == ["b.1"]
    monkeypatch.setenv("MOTIONKIT_TEST_KILL", f"{tmp_path},c,3")  # dies on both attempts
    results = run(Processes(2), [1, 2, 3], ["a", "b", "c"])
    assert results == {0: 101, 1: 102, 2: "its worker process died (2 attempts)"}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["b.1", "c.1", "c.2"]


@pytest.mark.parametrize("text", ["auto", "10.0.0.5:6379", "ray://head.lab:10001", "[::1]:6379"])
def test_cluster_addresses(text: str) -> None:
    assert cluster_address(text) == text


@pytest.mark.parametrize("text", ["", "head", "head:", "http://head:80", "head:0", "a b:1"])
def test_bad_cluster_addresses(text: str) -> None:
    with pytest.raises(argparse.ArgumentTypeError, match="auto, HOST:PORT or ray://HOST:PORT"):
        cluster_address(text)


def test_cluster_without_its_extra_is_one_line(tmp_path: Path, monkeypatch, capsys) -> None:
    monkeypatch.setitem(sys.modules, "ray", None)  # an import of ray now fails
    with pytest.raises(RetargetError, match=r"pip install 'motionkit\[cluster\]'"):
        with open_executor(2, "auto", RetargetError):
            pass
    walk = tmp_path / "walk.bvh"
    walk.write_text("not read: the extra is checked first")
    out = tmp_path / "out"
    assert main(["retarget", str(walk), "--out", str(out), "--cluster", "auto"]) == 2
    err = capsys.readouterr().err
    assert err == (
        "motionkit: error: --cluster needs the [cluster] extra (ray is missing): "
        "pip install 'motionkit[cluster]'\n"
    )
    assert not out.exists()


class RefusingRay:
    """A stand-in for the ray module whose client handshake is refused `refusals` times, as a
    busy head's client server refuses it (the server's traceback after the first line)."""

    def __init__(self, refusals: int) -> None:
        self.refusals, self.calls = refusals, []

    def init(self, **kwargs) -> None:
        self.calls.append("init")
        if self.calls.count("init") <= self.refusals:
            raise ConnectionAbortedError(
                "Initialization failure from server:\nTraceback (most recent call last):\n"
                "  ...\nRuntimeError: Proxy failed to Connect to backend!\n"
            )

    def shutdown(self) -> None:
        self.calls.append("shutdown")

    def is_initialized(self) -> bool:
        return False

    def cluster_resources(self) -> dict[str, float]:
        return {"CPU": 3.0}


@pytest.mark.parametrize("refusals", [1, 2])
def test_a_refused_ray_handshake_is_tried_again(refusals: int, monkeypatch) -> None:
    ray = RefusingRay(refusals)
    monkeypatch.setitem(sys.modules, "ray", ray)
    monkeypatch.setattr("motionkit.runtime.executors._reachable", lambda address, error: None)
    if refusals == 1:
        with ray_session("ray://head:10001", RetargetError) as cpus:
            assert cpus == 3
        assert ray.calls == ["init", "shutdown", "init", "shutdown"]
        return
    with pytest.raises(RetargetError) as caught:
        with ray_session("ray://head:10001", RetargetError):
            pass
    assert str(caught.value) == (
        "--cluster ray://head:10001: cannot connect to a Ray cluster "
        "(RuntimeError: Proxy failed to Connect to backend!)"
    )
    assert ray.calls == ["init", "shutdown", "init", "shutdown"]  # nothing left connected


def test_task_keys_in_the_manifest(tmp_path: Path) -> None:
    """write_files records a key per file; claiming more names keeps them; rewriting a file
    forgets its old key first; a file missing or of another key is not up to date."""
    claim_out(tmp_path, ["a.bin", "b.bin"], RetargetError)
    write_files(tmp_path, {"a.bin": b"1", "b.bin": b"2"}, "k1")
    assert up_to_date(tmp_path, ["a.bin", "b.bin"], "k1")
    assert not up_to_date(tmp_path, ["a.bin"], "k2")
    claim_out(tmp_path, ["c.bin"], RetargetError)
    assert Manifest.load(tmp_path).keys == {"a.bin": "k1", "b.bin": "k1"}
    write_files(tmp_path, {"b.bin": b"3"}, "k2")
    assert Manifest.load(tmp_path).keys == {"a.bin": "k1", "b.bin": "k2"}
    assert (tmp_path / "b.bin").read_bytes() == b"3"
    (tmp_path / "a.bin").unlink()
    assert not up_to_date(tmp_path, ["a.bin"], "k1")
    record_names(tmp_path, ["b.bin"])  # names no longer listed lose their keys
    data = json.loads((tmp_path / MANIFEST).read_text())
    assert data == {"files": ["b.bin"], "keys": {"b.bin": "k2"}}
    write_files(tmp_path, {"b.bin": b"4"})  # no key: none recorded
    assert Manifest.load(tmp_path).keys == {}
