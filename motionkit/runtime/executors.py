"""Where a batch's independent tasks (clips, trajopt targets) run: in this process, in local
worker processes, or on a Ray cluster (`--cluster`, the [cluster] extra). One interface for the
three: `Executor.run(fn, items, names, shared)` calls `fn(item, shared)` for every item and yields
each result as it finishes. Tasks return their outputs as data (the driver writes them), so a
cluster's nodes need not share a filesystem with it. A task whose worker dies is run once more;
if that worker dies too, the task is `lost` (the batch reports it failed and carries on)."""

from __future__ import annotations

import contextlib
import logging
import os
import socket
from collections import deque
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from typing import Any, Generic, Protocol, TypeVar

from motionkit.core.errors import MotionkitError
from motionkit.core.extras import require
from motionkit.runtime.workers import worker_pool

R = TypeVar("R")
TaskFn = Callable[[Any, Any], Any]  # fn(item, shared) -> result, importable by a worker

CONNECT_S = 10.0  # how long the address may take to accept a connection
ATTEMPTS = 2  # a task whose worker dies is run once more (Ray: max_retries=1)
CONNECT_ATTEMPTS = 2  # a refused client handshake is tried once more
# the settings a Ray worker takes from the driver's environment (not MOTIONKIT_CACHE: a path
# of this machine; each node keeps its own cache)
THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
LOCAL_ONLY = ("MOTIONKIT_CACHE",)


@dataclass(frozen=True)
class Finished(Generic[R]):
    """Task `index` done: its value, or `lost` saying why it has none (its worker died)."""

    index: int
    value: R | None = None
    lost: str = ""


class Executor(Protocol):
    workers: int  # tasks that run at once
    where: str  # for the batch's first line: "2 job(s)", "the Ray cluster at auto (8 CPUs)"
    in_process: bool  # tasks run in this process (they may draw progress lines)

    def run(
        self, fn: TaskFn, items: Sequence[Any], names: Sequence[str], shared: Any = None
    ) -> Iterator[Finished[Any]]: ...


@contextlib.contextmanager
def open_executor(
    jobs: int, cluster: str | None, error: type[MotionkitError], in_process: bool = False
) -> Iterator[Executor]:
    """The executor of a batch: the Ray cluster at `cluster` (connected here: `error` when it
    cannot be reached, before anything is written), else `jobs` local processes, or this
    process when `in_process` (a single task or --jobs 1 of a light stage)."""
    if cluster:
        with _ray_session(cluster, error) as workers:
            yield RayCluster(cluster, workers)
    elif in_process:
        yield InProcess()
    else:
        yield Processes(max(1, jobs))


class InProcess:
    """The tasks one after another in this process (a failure here is this process's)."""

    workers = 1
    where = "1 job(s)"
    in_process = True

    def run(
        self, fn: TaskFn, items: Sequence[Any], names: Sequence[str], shared: Any = None
    ) -> Iterator[Finished[Any]]:
        for i, item in enumerate(items):
            yield Finished(i, fn(item, shared))


class Processes:
    """Spawned local processes (motionkit.runtime.workers), `workers` tasks at a time. When a worker
    dies the pool is broken: the tasks it was running are run again in a new pool."""

    in_process = False

    def __init__(self, workers: int) -> None:
        self.workers = workers
        self.where = f"{workers} job(s)"

    def run(
        self, fn: TaskFn, items: Sequence[Any], names: Sequence[str], shared: Any = None
    ) -> Iterator[Finished[Any]]:
        pending, attempts = deque(range(len(items))), [0] * len(items)
        while pending:
            with worker_pool(self.workers, initializer=_start_worker, initargs=(shared,)) as pool:
                yield from self._drain(pool, fn, items, names, pending, attempts)

    def _drain(
        self,
        pool: ProcessPoolExecutor,
        fn: TaskFn,
        items: Sequence[Any],
        names: Sequence[str],
        pending: deque[int],
        attempts: list[int],
    ) -> Iterator[Finished[Any]]:
        """Run pending tasks in `pool` until none is left or the pool breaks (a worker died:
        the tasks it held go back to `pending`, or are lost after ATTEMPTS)."""
        running: dict[Future[Any], int] = {}
        broken = False
        while running or (pending and not broken):
            while pending and not broken and len(running) < self.workers:
                i = pending.popleft()
                try:
                    running[pool.submit(_in_worker, fn, names[i], items[i])] = i
                except BrokenProcessPool:
                    pending.appendleft(i)
                    broken = True
                    break
                attempts[i] += 1
            if not running:
                break
            done, _ = wait(running, return_when=FIRST_COMPLETED)
            for future in done:
                i = running.pop(future)
                try:
                    value = future.result()
                except BrokenProcessPool:
                    broken = True
                    if attempts[i] < ATTEMPTS:
                        pending.appendleft(i)
                    else:
                        yield Finished(i, lost=f"its worker process died ({ATTEMPTS} attempts)")
                    continue
                yield Finished(i, value)


class RayCluster:
    """Tasks on a Ray cluster this process is connected to (`_ray_session`): one CPU each,
    run once more when their worker or node dies (max_retries=1); `shared` is put in the
    object store once and fetched once per node."""

    in_process = False

    def __init__(self, address: str, workers: int) -> None:
        self.workers = workers
        self.where = f"the Ray cluster at {address} ({workers} CPUs)"

    def run(
        self, fn: TaskFn, items: Sequence[Any], names: Sequence[str], shared: Any = None
    ) -> Iterator[Finished[Any]]:
        import ray
        from ray.exceptions import RayError, RayTaskError

        remote = ray.remote(_run_task).options(
            num_cpus=1, max_retries=ATTEMPTS - 1, retry_exceptions=False
        )
        shared_ref = ray.put(shared)
        refs = {remote.remote(fn, names[i], item, shared_ref): i for i, item in enumerate(items)}
        try:
            while refs:
                ready, _ = ray.wait(list(refs), num_returns=1)
                for ref in ready:
                    i = refs.pop(ref)
                    try:
                        value = ray.get(ref)
                    except RayTaskError as exc:  # the task raised: a bug, as in a local process
                        raise exc.as_instanceof_cause() from None
                    except RayError as exc:  # its worker or node died on both attempts
                        reason = str(exc).strip().splitlines()[0] if str(exc).strip() else ""
                        lost = f"its Ray worker died ({ATTEMPTS} attempts): {reason}"
                        yield Finished(i, lost=lost.rstrip(": "))
                        continue
                    yield Finished(i, value)
        except BaseException:
            for ref in refs:
                ray.cancel(ref, force=True)
            raise


@contextlib.contextmanager
def _ray_session(address: str, error: type[MotionkitError]) -> Iterator[int]:
    """Connected to the Ray cluster at `address` for the block; its CPU count. A process that
    is connected already keeps its connection."""
    require("cluster", "--cluster", error)
    import ray

    owned = not ray.is_initialized()
    if owned:
        _reachable(address, error)  # ray.init waits minutes on an address nothing listens at
        _connect(address, error)
    try:
        cpus = int(ray.cluster_resources().get("CPU", 0))
        if cpus < 1:
            raise error(f"--cluster {address}: the Ray cluster has no CPUs to run tasks")
        yield cpus
    finally:
        if owned:
            ray.shutdown()


def _connect(address: str, error: type[MotionkitError]) -> None:
    """ray.init, tried CONNECT_ATTEMPTS times when the client server refuses the handshake (its
    per-client server may start too slowly on a busy head); a failed try leaves no half-made
    connection behind, which would make every later ray.init in the process fail."""
    import ray

    for attempt in range(1, CONNECT_ATTEMPTS + 1):
        try:
            ray.init(
                address=address,
                runtime_env={"env_vars": forwarded_environment()},
                logging_level=logging.WARNING,
                log_to_driver=True,
            )
            return
        except Exception as exc:  # ConnectionError, ValueError, TimeoutError, gRPC errors
            ray.shutdown()
            if isinstance(exc, ConnectionAbortedError) and attempt < CONNECT_ATTEMPTS:
                continue
            reason = _reason(exc)
            raise error(f"--cluster {address}: cannot connect to a Ray cluster ({reason})") from exc


def _reason(exc: BaseException) -> str:
    """One line for an exception: its first, or its last where the first only announces the
    rest (Ray's client puts the server's traceback after "Initialization failure from server:")."""
    lines = [line.strip() for line in str(exc).strip().splitlines() if line.strip()]
    if not lines:
        return type(exc).__name__
    return lines[-1] if lines[0].endswith(":") else lines[0]


def _reachable(address: str, error: type[MotionkitError]) -> None:
    """`error` unless something accepts a TCP connection at HOST:PORT (within CONNECT_S)."""
    if address == "auto":
        return
    host, _, port = address.removeprefix("ray://").rpartition(":")
    try:
        socket.create_connection((host.strip("[]"), int(port)), timeout=CONNECT_S).close()
    except OSError as exc:
        reason = exc.strerror or str(exc) or type(exc).__name__
        raise error(f"--cluster {address}: no Ray cluster answers there ({reason})") from None


def forwarded_environment() -> dict[str, str]:
    """The driver's MOTIONKIT_* settings (but its cache path) and BLAS thread counts, for the
    Ray workers: they solve with the same compile flags and thread counts as local ones."""
    return {
        name: value
        for name, value in os.environ.items()
        if (name.startswith("MOTIONKIT_") and name not in LOCAL_ONLY) or name in THREAD_VARIABLES
    }


# -- in the workers -------------------------------------------------------------------------------
_shared: Any = None  # a local worker process's `shared`, set once when it starts


def _start_worker(shared: Any) -> None:
    global _shared
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent decides on Ctrl-C
    _shared = shared


def _in_worker(fn: TaskFn, name: str, item: Any) -> Any:
    return _run_task(fn, name, item, _shared)


def _run_task(fn: TaskFn, name: str, item: Any, shared: Any) -> Any:
    """One task in a worker (local or Ray), by name: the seam where tests inject crashes."""
    return fn(item, shared)
