"""Worker pools end cleanly: a worker stopped while it was sending its result leaves half a
message in the result pipe, and the pool's manager thread (which the interpreter joins at exit)
must still end."""

import struct
import threading
import time

from motionkit.runtime.workers import stop_workers, worker_pool


def test_stopped_pool_ends_its_manager_thread_despite_half_a_result() -> None:
    with worker_pool(1) as pool:
        future = pool.submit(time.sleep, 30.0)
        while not future.running():
            time.sleep(0.01)
        # what a worker killed halfway through sending a 1,000-byte result leaves behind
        writer = pool._result_queue._writer
        writer._send(struct.pack("!i", 1000) + b"\x00" * 10)
        manager = pool._executor_manager_thread
        time.sleep(0.5)  # the manager thread has read the header and waits for the rest
        assert manager is not None and manager.is_alive()
        stop_workers(pool)
        manager.join(10.0)
        if manager.is_alive() and not writer.closed:  # let the test process end all the same
            writer._send(b"\x00" * 990)
        assert not manager.is_alive(), "the pool's manager thread still waits for the result"
    assert threading.main_thread().is_alive()
