"""Worker processes that end with the block that uses them: spawned (a fork of a process that runs
JAX or BLAS threads can deadlock), deaf to the terminal's Ctrl-C (their parent decides), and
terminated when the block ends with an exception (an interrupt or SIGTERM included), the
temporary files they were writing removed."""

from __future__ import annotations

import contextlib
import multiprocessing
import signal
from collections.abc import Callable, Iterator
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

from motionkit.files.outputs import remove_temporaries

GRACE_S = 2.0  # a terminated worker that has not ended by then is killed


@contextlib.contextmanager
def worker_pool(
    jobs: int,
    out: Path | None = None,
    initializer: Callable[..., None] | None = None,
    initargs: tuple[Any, ...] = (),
) -> Iterator[ProcessPoolExecutor]:
    """A pool of `jobs` spawned processes (writing into `out`, if they write); stopped at once
    on an exception. `initializer(*initargs)` runs in each worker as it starts, and must ignore
    SIGINT as the default one does."""
    spawn = multiprocessing.get_context("spawn")
    pool = ProcessPoolExecutor(
        max(1, jobs), mp_context=spawn, initializer=initializer or _ignore_sigint, initargs=initargs
    )
    try:
        yield pool
    except BaseException:
        stop_workers(pool, out)
        raise
    pool.shutdown()


def stop_workers(pool: ProcessPoolExecutor, out: Path | None = None) -> None:
    """Cancel what has not started, end the workers now, and remove their temporaries; a second
    Ctrl-C or SIGTERM meanwhile waits until this is done."""
    signals = {signal.SIGINT, signal.SIGTERM}
    blocked = signal.pthread_sigmask(signal.SIG_BLOCK, signals)
    try:
        processes = list((pool._processes or {}).values())  # no public handle before 3.14
        result_writer = getattr(getattr(pool, "_result_queue", None), "_writer", None)
        pool.shutdown(wait=False, cancel_futures=True)
        for process in processes:
            process.terminate()
        for process in processes:
            process.join(GRACE_S)
            if process.is_alive():
                process.kill()
                process.join()
        if result_writer is not None:
            # A worker ended while it sent a result leaves half a message in the result pipe,
            # and the pool's manager thread would wait for the rest for ever (the interpreter
            # for that thread at exit). The workers gone, this end is the pipe's last writer:
            # closed, the reader gets end-of-file and the thread ends.
            result_writer.close()
        if out is not None:
            remove_temporaries(out, (p.pid for p in processes if p.pid is not None))
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, blocked)


def _ignore_sigint() -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)
