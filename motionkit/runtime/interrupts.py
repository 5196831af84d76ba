"""Ctrl-C and SIGTERM that reach through a C solver. CasADi calls Python's signal handlers
while IPOPT runs and stops the solve when one raises, but it turns the exception into a
warning and a return status, so the interrupt itself would be lost and the program would go
on. `interruptible()` notes the signal, lets the solve stop, and raises afterwards what the
signal's own handler raises (KeyboardInterrupt, the CLI's Terminated, or the default action)."""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Callable, Iterator
from typing import Any

SIGNALS = (signal.SIGINT, signal.SIGTERM)


@contextlib.contextmanager
def interruptible() -> Iterator[None]:
    """For a block that runs a C solve: a SIGINT or SIGTERM meanwhile stops the solve and is
    raised when the block ends. Signals that are ignored stay ignored; outside the main thread
    (where handlers cannot be set) the block runs as it is."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {s: signal.getsignal(s) for s in SIGNALS}
    watched = [s for s, handler in previous.items() if handler is not signal.SIG_IGN]
    caught: list[int] = []

    def note(signum: int, frame: Any) -> None:
        caught.append(signum)
        raise KeyboardInterrupt  # what makes the solver stop at its next check

    for signum in watched:
        signal.signal(signum, note)
    try:
        yield
    except KeyboardInterrupt:
        if not caught:
            raise
    finally:
        for signum in watched:
            signal.signal(signum, previous[signum])
    if caught:
        _deliver(caught[0], previous[caught[0]])


def _deliver(signum: int, handler: Callable[[int, Any], Any] | int | None) -> None:
    """Act on `signum` as its handler would have."""
    if callable(handler):
        handler(signum, None)
    elif signum == signal.SIGINT:
        raise KeyboardInterrupt
    else:  # SIG_DFL: the default action (SIGTERM ends the process)
        signal.raise_signal(signum)
