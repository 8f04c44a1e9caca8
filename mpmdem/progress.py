"""What the command line adds around a run: its progress on stderr (tqdm's bar on a terminal, a
plain line every few percent in a log, where the bar's carriage returns would pile up), and Ctrl-C
acted on between batches of steps (``deferred_sigint``)."""

from __future__ import annotations

import contextlib
import signal
import sys
import threading
import time
from collections.abc import Iterator

__all__ = ["Progress", "deferred_sigint", "run_callback"]


class Progress:
    """Simulated time reached [s] out of ``total`` [s].

    Args:
        total: the end time [s].
        stream: where to write (default stderr); a terminal gets tqdm's bar, anything else one
            line per ``every`` percent (and the last).
        every: percent of the run between two lines when not on a terminal.
    """

    def __init__(self, total: float, stream=None, every: float = 5.0):
        self.total, self.stream, self.every = total, stream or sys.stderr, every
        self.start = time.perf_counter()
        self.next = every
        self.bar = None
        isatty = getattr(self.stream, "isatty", None)
        if isatty is not None and isatty():
            from tqdm import tqdm

            self.bar = tqdm(total=total, unit="s", unit_scale=False, desc="sim time", file=self.stream,
                            bar_format="{l_bar}{bar}| {n:.4g}/{total:.4g} s [{elapsed}<{remaining}]{postfix}")

    def update(self, t: float, dt: float) -> None:
        """The clock reached t [s] with step dt [s]."""
        t = min(t, self.total)
        if self.bar is not None:
            self.bar.set_postfix_str(f"dt={dt:.3g} s", refresh=False)
            self.bar.update(t - self.bar.n)
            return
        percent = 100.0 * t / self.total
        if percent + 1e-9 >= self.next:
            print(f"sim time {t:.4g}/{self.total:.4g} s ({percent:.0f} %), dt={dt:.3g} s, "
                  f"{time.perf_counter() - self.start:.1f} s elapsed", file=self.stream, flush=True)
            while self.next <= percent + 1e-9:
                self.next += self.every

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


@contextlib.contextmanager
def deferred_sigint() -> Iterator[list]:
    """Within the block, Ctrl-C only appends to the list yielded; a second Ctrl-C raises
    KeyboardInterrupt at once. The run's progress callback (``run_callback``) raises it between
    batches of steps, so it never lands in the middle of an HDF5 write. Outside the main thread
    (where signal handlers cannot be set) Ctrl-C is left as it is."""
    interrupted: list = []

    def on_sigint(signum, frame):
        if interrupted:
            raise KeyboardInterrupt
        interrupted.append(True)

    previous = None
    if threading.current_thread() is threading.main_thread():
        previous = signal.signal(signal.SIGINT, on_sigint)
    try:
        yield interrupted
    finally:
        if previous is not None:
            signal.signal(signal.SIGINT, previous)


def run_callback(bar: Progress | None, interrupted: list):
    """``progress(t, dt)`` for ``Simulation.run``: KeyboardInterrupt once Ctrl-C was pressed
    (``deferred_sigint``), else the bar (if any) moves to t."""
    def progress(t: float, dt: float) -> None:
        if interrupted:
            raise KeyboardInterrupt
        if bar is not None:
            bar.update(t, dt)

    return progress
