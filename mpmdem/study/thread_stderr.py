"""sys.stderr per thread, for runs side by side in threads of one process.

A run of a study writes its messages to a buffer of its own (``contextlib.redirect_stderr`` swaps
``sys.stderr`` for the whole process: two threads doing so at once would leave it pointing at one
run's buffer). ``routed_stderr`` puts a proxy in ``sys.stderr`` for the time the threads run;
``captured_stderr`` then sends only the calling thread's writes to its buffer.
"""

from __future__ import annotations

import contextlib
import sys
import threading
from collections.abc import Iterator

__all__ = ["captured_stderr", "routed_stderr"]


class _ThreadStderr:
    """Writes go to the calling thread's buffer, if it set one, else to the stream it replaced; every
    other attribute (encoding, fileno, isatty, ...) is the replaced stream's."""

    def __init__(self, base):
        self.base = base
        self.local = threading.local()

    def _target(self):
        return getattr(self.local, "target", None) or self.base

    def write(self, text: str) -> int:
        return self._target().write(text)

    def flush(self) -> None:
        self._target().flush()

    def __getattr__(self, name):
        return getattr(self.base, name)


@contextlib.contextmanager
def routed_stderr() -> Iterator[None]:
    """Inside, ``sys.stderr`` sends each thread's writes where its ``captured_stderr`` says."""
    if isinstance(sys.stderr, _ThreadStderr):
        yield
        return
    base = sys.stderr
    sys.stderr = _ThreadStderr(base)
    try:
        yield
    finally:
        sys.stderr = base


@contextlib.contextmanager
def captured_stderr(buffer) -> Iterator[None]:
    """The calling thread's writes to ``sys.stderr`` go to ``buffer`` inside: for this thread alone
    within ``routed_stderr``, else for the process (``contextlib.redirect_stderr``)."""
    proxy = sys.stderr
    if not isinstance(proxy, _ThreadStderr):
        with contextlib.redirect_stderr(buffer):
            yield
        return
    previous = getattr(proxy.local, "target", None)
    proxy.local.target = buffer
    try:
        yield
    finally:
        proxy.local.target = previous
