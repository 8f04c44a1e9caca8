"""What the command line adds around a run: its progress on stderr (tqdm's bar on a terminal, a
plain line every few percent in a log, where the bar's carriage returns would pile up), and the
stop signals acted on between batches of steps (``run_callback``, with ``mpmdem.study.signals``)."""

from __future__ import annotations

import sys
import time

from .signals import Interrupted

__all__ = ["Progress", "run_callback"]


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


def run_callback(bar: Progress | None, received: list):
    """``progress(t, dt)`` for ``Simulation.run``: ``Interrupted`` once a stop signal was received
    (``mpmdem.study.signals.deferred_stop`` appends its number to ``received``), else the bar (if any)
    moves to t."""
    def progress(t: float, dt: float) -> None:
        if received:
            raise Interrupted(received[0])
        if bar is not None:
            bar.update(t, dt)

    return progress
