"""A real local Ray cluster for the module's tests: a head node on 127.0.0.1 with 2 CPUs, started
once per session in its own process group and ended with it (also when a test fails). Its
workers have their own motionkit cache and no C compiler (CC=false), so a worker that compiled
the trajopt derivatives itself would fail: they must use the ones the driver sends."""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
START_S = 120.0  # a head node starts in about 15 s on 2 busy cores


@dataclass(frozen=True)
class Cluster:
    address: str  # HOST:PORT of its GCS
    client: str  # ray://HOST:PORT of its client server
    cache: Path  # the workers' MOTIONKIT_CACHE


def _free_ports(count: int) -> list[int]:
    sockets = [socket.socket() for _ in range(count)]
    for s in sockets:
        s.bind(("127.0.0.1", 0))
    ports = [s.getsockname()[1] for s in sockets]
    for s in sockets:
        s.close()
    return ports


def _ray() -> str:
    return str(Path(sys.executable).with_name("ray"))


@pytest.fixture(autouse=True, scope="module")
def _quick_compile() -> Iterator[None]:
    """Compile the trajopt derivatives at -O0 (seconds); the workers get it from the driver.
    For the cluster module only: the other trajopt tests solve with the default flags."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("MOTIONKIT_TRAJOPT_COMPILE", "-O0")
        yield


@pytest.fixture(scope="session")
def ray_cluster(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Cluster]:
    gcs, client, *agents = _free_ports(7)
    cache = tmp_path_factory.mktemp("worker-cache")
    env = os.environ | {
        # tests/faults: its start-up hook lets MOTIONKIT_TEST_KILL end a worker mid-task
        "PYTHONPATH": os.pathsep.join(
            filter(None, [str(REPO), str(REPO / "tests" / "faults"), os.environ.get("PYTHONPATH")])
        ),
        "RAY_USAGE_STATS_ENABLED": "0",
        "MOTIONKIT_CACHE": str(cache),
        "CC": "false",
        # the client server waits this long for a client's own server process (Ray's default,
        # 30 s, is too short on 2 cores that another test worker keeps busy)
        "RAY_CLIENT_SERVER_CHECK_CHANNEL_TIMEOUT_S": "180",
    }
    command = [
        _ray(), "start", "--head", "--block", "--node-ip-address=127.0.0.1", f"--port={gcs}",
        f"--ray-client-server-port={client}", "--num-cpus=2", "--include-dashboard=false",
        f"--dashboard-port={agents[0]}", f"--dashboard-agent-listen-port={agents[1]}",
        f"--dashboard-agent-grpc-port={agents[2]}", f"--metrics-export-port={agents[3]}",
        f"--runtime-env-agent-port={agents[4]}", "--object-store-memory=200000000",
        "--disable-usage-stats",
    ]  # fmt: skip
    log = tmp_path_factory.mktemp("ray-log") / "head.log"
    with open(log, "wb") as stream:
        head = subprocess.Popen(
            command, env=env, stdout=stream, stderr=subprocess.STDOUT, start_new_session=True
        )
    try:
        _wait_until_up(f"127.0.0.1:{gcs}", head, log, env)
        yield Cluster(f"127.0.0.1:{gcs}", f"ray://127.0.0.1:{client}", cache)
    finally:
        _stop(head)


def _wait_until_up(address: str, head: subprocess.Popen, log: Path, env: dict) -> None:
    deadline = time.monotonic() + START_S
    while time.monotonic() < deadline:
        if head.poll() is not None:
            pytest.fail(f"ray start ended with {head.returncode}:\n{log.read_text()[-3000:]}")
        status = subprocess.run(
            [_ray(), "status", f"--address={address}"], env=env, capture_output=True, text=True
        )
        if status.returncode == 0 and "CPU" in status.stdout:
            return
        time.sleep(1.0)
    _stop(head)
    pytest.fail(f"the Ray head did not come up in {START_S:.0f} s:\n{log.read_text()[-3000:]}")


def _stop(head: subprocess.Popen) -> None:
    """End the head (`ray start --block` stops what it started on SIGTERM), then anything left
    in its process group: only the processes this fixture started."""
    if head.poll() is None:
        head.send_signal(signal.SIGTERM)
        try:
            head.wait(30)
        except subprocess.TimeoutExpired:
            pass
    try:
        os.killpg(head.pid, signal.SIGKILL)
    except ProcessLookupError:
        pass
    if head.poll() is None:
        head.wait(10)


@pytest.fixture
def worker_cache(ray_cluster: Cluster) -> Path:
    """The workers' cache, emptied of compiled trajopt libraries."""
    shutil.rmtree(ray_cluster.cache / "trajopt_compiled", ignore_errors=True)
    return ray_cluster.cache
