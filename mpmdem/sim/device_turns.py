"""Several runs of one process sharing one CUDA device side by side, each in its own thread and on
its own stream.

Runs in separate processes time-slice a GPU: without MPS the device runs one process's kernels at a
time, so small, latency-bound steps of two processes do not overlap. Streams of one process do.
Warp's current stream belongs to the device, not to a thread, so the threads take turns: a thread
issues its launches holding the turn, with its own stream made current, and gives the turn up only
while it waits for its own stream (``wait``: before a host read of the device clock, where a run
would otherwise block). While it waits, the other threads launch their steps on their streams, and
the GPU runs the streams' kernels together.

What this changes in a run: nothing on the device. Each run's launches go to its stream in the order
it issues them, as they would to the device's stream alone; no run reads another's arrays. On the
CPU (no streams) a turn is the same lock and a run's kernels run as they are launched: the runs
interleave at the same points and each keeps its bits.

``current()`` is the turns of the calling thread (None outside ``DeviceTurns.turn``): a Simulation
built inside a turn takes part without being told (``mpmdem.sim.simulation``).
"""

from __future__ import annotations

import collections
import contextlib
import gc
import threading
import time
from collections.abc import Iterator

import warp as wp

__all__ = ["DeviceTurns", "current"]

_local = threading.local()


def current(device=None) -> DeviceTurns | None:
    """The turns the calling thread holds (``DeviceTurns.turn``), if they are on ``device`` (any
    device when None); else None."""
    turns = getattr(_local, "turns", None)
    if turns is None or device is None:
        return turns
    return turns if wp.get_device(device) == turns.device else None


class _TurnQueue:
    """A lock taken in the order it was asked for (``threading.Lock`` is not fair: a thread that
    gives it up and asks again at once would most often get it back before the threads waiting)."""

    def __init__(self):
        self._cond = threading.Condition()
        self._queue: collections.deque = collections.deque()
        self._held = False

    def acquire(self) -> None:
        me = object()
        with self._cond:
            self._queue.append(me)
            while self._held or self._queue[0] is not me:
                self._cond.wait()
            self._queue.popleft()
            self._held = True

    def release(self) -> None:
        with self._cond:
            self._held = False
            self._cond.notify_all()


class DeviceTurns:
    """The turn to issue work on one device, shared by the threads of one process (see the module).

    Args:
        device: the Warp device the threads' runs use.
    """

    def __init__(self, device):
        self.device = wp.get_device(device)
        self._lock = _TurnQueue()
        #: seconds per thread name: ``held`` (issuing work, the turn held), ``queued`` (waiting for
        #: the turn), ``device`` (waiting for its own stream); what ``bench/side_by_side.py`` reports
        self.seconds: dict[str, dict[str, float]] = {}
        #: the device's stream before any turn, made current again when a thread's turn ends
        self._home = self.device.stream if self.device.is_cuda else None

    @contextlib.contextmanager
    def turn(self) -> Iterator[DeviceTurns]:
        """Hold the turn inside, on a stream of this thread's own (CUDA); ``current()`` is these turns."""
        if getattr(_local, "turns", None) is not None:
            raise RuntimeError("a thread holds one turn at a time")
        mine = self.seconds.setdefault(threading.current_thread().name, {"held": 0.0, "queued": 0.0, "device": 0.0})
        asked = time.perf_counter()
        self._lock.acquire()
        _local.since = time.perf_counter()
        mine["queued"] += _local.since - asked
        try:
            _local.stream = wp.Stream(self.device) if self.device.is_cuda else None
            _local.turns = self
            self._make_current()
            try:
                yield self
            finally:
                _local.turns = None
                if self.device.is_cuda:
                    wp.synchronize_stream(_local.stream)
                    self.device.set_stream(self._home, sync=False)
                _local.stream = None
                mine["held"] += time.perf_counter() - _local.since
        finally:
            self._lock.release()

    def _make_current(self) -> None:
        if self.device.is_cuda:
            self.device.set_stream(_local.stream, sync=False)

    def wait(self) -> None:
        """Return once the work this thread issued so far has run, letting the other threads issue
        theirs meanwhile (the turn is given up and taken back after the threads already waiting)."""
        if getattr(_local, "turns", None) is not self:  # (a run used after its turn ended: no turn to give up)
            if self.device.is_cuda:
                wp.synchronize_stream()
            return
        event = wp.record_event() if self.device.is_cuda else None
        mine = self.seconds[threading.current_thread().name]
        given = time.perf_counter()
        mine["held"] += given - _local.since
        self._lock.release()
        try:
            if event is not None:
                wp.synchronize_event(event)
        finally:
            ran = time.perf_counter()
            mine["device"] += ran - given
            self._lock.acquire()
            _local.since = time.perf_counter()
            mine["queued"] += _local.since - ran
            self._make_current()

    @contextlib.contextmanager
    def capturing(self) -> Iterator[None]:
        """Inside: no automatic garbage collection in any thread, so that no other thread (a frame
        writer) frees a device array while this one records a graph (a free would be recorded
        on the capturing stream)."""
        enabled = gc.isenabled()
        gc.disable()
        try:
            yield
        finally:
            if enabled:
                gc.enable()
