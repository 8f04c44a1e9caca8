"""Progress of a study: one tqdm bar (runs done, failures, ETA) on a terminal, else a line per ~10 %."""

from __future__ import annotations

import sys
import time

__all__ = ["StudyProgress"]


class StudyProgress:
    """Counts finished runs; ``update(row)`` after each, ``close()`` at the end."""

    def __init__(self, name: str, total: int, skipped: int = 0, enabled: bool = True, stream=None):
        self.name, self.total, self.done, self.failed = name, total, 0, 0
        self.stream = stream or sys.stdout
        self.start = time.perf_counter()
        self.next_line = 0.1
        self.bar = None
        if not enabled:
            self.stream = None
            return
        note = f" ({skipped} already in the table)" if skipped else ""
        print(f"study {name}: {total} run(s) to go{note}", file=self.stream, flush=True)
        if self.stream.isatty():
            from tqdm import tqdm

            self.bar = tqdm(total=total, desc=f"study {name}", unit="run", file=self.stream, dynamic_ncols=True)

    def update(self, row: dict) -> None:
        self.done += 1
        self.failed += row.get("status") != "completed"
        if self.bar is not None:
            self.bar.set_postfix(failed=self.failed, refresh=False)
            self.bar.update(1)
        elif self.stream is not None and (self.done >= self.next_line * self.total or self.done == self.total):
            while self.next_line * self.total <= self.done:
                self.next_line += 0.1
            elapsed = time.perf_counter() - self.start
            eta = elapsed / self.done * (self.total - self.done)
            print(f"study {self.name}: {self.done}/{self.total} runs, {self.failed} failed, "
                  f"{elapsed:.0f} s elapsed, ETA {eta:.0f} s", file=self.stream, flush=True)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
