"""Frames written while the device steps on: a ``FrameWriter`` whose ``write_frame`` runs in one
worker thread.

A run copies a frame's fields to the host (the copies wait for the steps before it) and then writes
them: HDF5 stores, the XDMF views (and sidecars, when their interval is up), the CSV row. On a GPU
that write used to leave the device idle; here it goes to a worker thread, and the caller launches
the next frame's steps at once (they wait in the device, while the host mostly waits on them with
Python's lock released). One frame is written at a time and in order: a new frame, ``set_status``
and ``close`` first wait for the one in progress, so a Ctrl-C or a blow-up still finds every frame
before it whole in the file. An error of the write is raised by the next of those calls.

h5py lets Python's lock go around each HDF5 write; to take it back the writer waits for the thread
holding it to give it up, which a main thread running Python does only every
``sys.getswitchinterval()`` (5 ms by default): a frame of ~60 writes then took a hundred times its
own time. A run writing its frames lowers the interval while it runs (``thread_switch_interval``
with ``Tuning.writer_switch_interval``).
"""

from __future__ import annotations

import contextlib
import sys
import threading
from collections.abc import Iterator, Mapping
from concurrent.futures import Future, ThreadPoolExecutor

import numpy as np

from .closing import ClosesOnExit
from .writer import FrameWriter

__all__ = ["BackgroundFrameWriter", "thread_switch_interval"]


class BackgroundFrameWriter(ClosesOnExit):
    """``writer`` with ``write_frame`` in a worker thread (module docstring); the rest as ``writer``.

    Args:
        writer: An open FrameWriter; this object owns it from now on (``close`` closes it).
        pool: a one-thread executor shared with other writers (a batch's worlds: their frames are
            written one after another in one thread, which HDF5's lock would serialize anyway,
            without the threads contending for it); its owner shuts it down. None: a thread of its own.
    """

    def __init__(self, writer: FrameWriter, pool: ThreadPoolExecutor | None = None) -> None:
        self.writer = writer
        self.path = writer.path
        self._own_pool = pool is None
        self._pool = pool if pool is not None else ThreadPoolExecutor(max_workers=1,
                                                                      thread_name_prefix="mpmdem-frames")
        self._pending: Future | None = None

    def write_frame(self, time: float, fields: Mapping[str, np.ndarray] | None, diagnostics: Mapping[str, float],
                    body_fields: Mapping[str, np.ndarray] | None = None) -> None:
        """Start writing one frame (``FrameWriter.write_frame``) once the previous one is written; the
        arrays must not change afterwards (a run's are fresh host copies)."""
        self.wait()
        self._pending = self._pool.submit(self.writer.write_frame, time, fields, diagnostics, body_fields)

    def wait(self) -> None:
        """Return once the frame in progress is written; raise its error if it failed."""
        pending, self._pending = self._pending, None
        if pending is not None:
            pending.result()

    def set_status(self, status: str, message: str = "") -> None:
        """``FrameWriter.set_status`` after the frame in progress (marked even if that write failed)."""
        try:
            self.wait()
        finally:
            self.writer.set_status(status, message)

    def close(self) -> None:
        """Wait for the frame in progress, stop the worker and close the file; closing twice is harmless."""
        try:
            self.wait()
        finally:
            if self._own_pool:
                self._pool.shutdown(wait=True)
            self.writer.close()


#: the blocks inside ``thread_switch_interval`` now, of any thread, and the interval before the first
_switch_lock = threading.Lock()
_switch_holders: list[float] = []
_switch_before: list[float] = []


@contextlib.contextmanager
def thread_switch_interval(seconds: float) -> Iterator[None]:
    """Python's thread switch interval lowered to ``seconds`` [s] inside (``sys.setswitchinterval``;
    never raised; 0: left as it is), and set back after. Blocks of several threads may overlap
    (runs side by side: ``mpmdem.sim.device_turns``): the interval is then the least asked of those
    still inside, and the one from before the first comes back when the last leaves."""
    if not seconds > 0.0:
        yield
        return
    with _switch_lock:
        if not _switch_holders:
            _switch_before[:] = [sys.getswitchinterval()]
        _switch_holders.append(seconds)
        sys.setswitchinterval(min([_switch_before[0], *_switch_holders]))
    try:
        yield
    finally:
        with _switch_lock:
            _switch_holders.remove(seconds)
            sys.setswitchinterval(min([_switch_before[0], *_switch_holders]))
