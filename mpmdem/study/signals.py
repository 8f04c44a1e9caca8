"""Ctrl-C (SIGINT) and SIGTERM (what a batch scheduler sends) end a command-line run alike: the run
stops between two batches of steps, never in the middle of an HDF5 write, the file is marked
"interrupted", summary.json is written, and the exit code is 128 + the signal's number (130 for
Ctrl-C, 143 for SIGTERM)."""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Iterator

__all__ = ["STOP_SIGNALS", "Interrupted", "deferred_stop", "exit_code", "sigterm_raises"]

#: the signals that stop a run
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)


class Interrupted(KeyboardInterrupt):
    """A run stopped by ``signum`` (a KeyboardInterrupt, so code that handles Ctrl-C handles it)."""

    def __init__(self, signum: int):
        self.signum = signum
        what = "Ctrl-C" if signum == signal.SIGINT else signal.Signals(signum).name
        super().__init__(f"stopped by {what}")


def exit_code(error: KeyboardInterrupt) -> int:
    """128 + the number of the signal that stopped the run (130 for a plain KeyboardInterrupt)."""
    return 128 + getattr(error, "signum", signal.SIGINT)


#: the list of the main thread's ``deferred_stop`` while one is open: runs in other threads of the
#: process (side by side on one GPU: ``mpmdem.study.cluster``) stop on the signals it receives
_main_received: list[list[int]] = []


@contextlib.contextmanager
def deferred_stop() -> Iterator[list]:
    """Within the block, SIGINT or SIGTERM only appends its number to the list yielded; a second
    one raises ``Interrupted`` at once. The run's progress callback (``mpmdem.study.run_progress.run_callback``)
    raises ``Interrupted`` between batches of steps once the list is not empty. Outside the main
    thread (where signal handlers cannot be set) the signals are left as they are, and the list
    yielded is that of the main thread's open block, if there is one."""
    main = threading.current_thread() is threading.main_thread()
    if not main:
        yield _main_received[-1] if _main_received else []
        return
    received: list[int] = []

    def on_signal(signum, frame):
        if received:
            raise Interrupted(signum)
        received.append(signum)

    previous = {s: signal.signal(s, on_signal) for s in STOP_SIGNALS}
    _main_received.append(received)
    try:
        yield received
    finally:
        _main_received.remove(received)
        for s, handler in previous.items():
            signal.signal(s, handler)


@contextlib.contextmanager
def sigterm_raises() -> Iterator[None]:
    """Within the block, SIGTERM raises ``Interrupted`` at once, as Ctrl-C raises KeyboardInterrupt
    (for the runs that take no progress callback, such as a case's variant runs)."""
    previous = None

    def on_sigterm(signum, frame):
        raise Interrupted(signum)

    if threading.current_thread() is threading.main_thread():
        previous = signal.signal(signal.SIGTERM, on_sigterm)
    try:
        yield
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)
