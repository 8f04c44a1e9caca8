"""Independent parts of a step on side CUDA streams while the step is recorded as a graph.

A small scene's step is a chain of latency-bound launches (bench/README.md, "Where a small
step's kernels wait"): the GPU is nearly idle, and a step costs the sum of its kernels'
latencies along the chain. Launches that read and write disjoint data need not be in one chain.
Recorded on two streams, the graph holds two branches that the GPU runs side by side, and the
step costs its longest branch (a fork and a join are edges of the graph, not launches).

Branches are taken only where they cannot change a result's meaning:

- on CUDA, while a graph is recorded (``Device.is_capturing``); elsewhere every launch goes to
  the current stream in the order it is issued, so CPU runs keep their bits;
- outside deterministic mode: two branches that add into one array (the bodies' loads) add in
  an order that varies from run to run, as the float atomics of one kernel already do there.

Conditional nodes (``launch_plan.IfFlag``) are recorded only while no branch is open: Warp
records them on the stream its capture began on, and pausing that capture with a branch open
fails ("capturing stream has unjoined work").
"""

from __future__ import annotations

import contextlib

import warp as wp

__all__ = ["StepStreams"]


class StepStreams:
    """Named side streams of one stage's step and the fork/join between them and the main stream.

    Args:
        device: the stage's Warp device.
        names: the side branches the step uses (one stream each).
        enabled: whether branches may be taken at all (False: deterministic runs).
    """

    def __init__(self, device, names: tuple[str, ...], enabled: bool = True):
        self.device = wp.get_device(device)
        self.enabled = bool(enabled) and self.device.is_cuda
        self._streams = {name: wp.Stream(self.device) for name in names} if self.enabled else {}
        self._main: wp.Stream | None = None
        self._forked: set[str] = set()

    def begin(self) -> None:
        """Start a step on the main stream alone (forgets the branches a step whose recording
        raised left open; a step that ran to its end joined them all)."""
        self._main = None
        self._forked.clear()

    def active(self) -> bool:
        """Whether launches go to side streams now: enabled, and a graph is being recorded."""
        return self.enabled and bool(self.device.is_capturing)

    @contextlib.contextmanager
    def branch(self, name: str, *, work: bool = True):
        """Launches issued inside go to side stream ``name``, after everything issued so far on the
        main stream (and on ``name`` before); with no branch taken (see ``active``; ``work`` False:
        the caller launches nothing here, and an empty branch would still cost its fork and join,
        ~0.4 µs a step on an H100), to the current stream, in order."""
        if not (work and self.active()):
            yield
            return
        if self._main is None:
            self._main = self.device.stream
        side = self._streams[name]
        side.wait_stream(self._main)
        self._forked.add(name)
        with wp.ScopedStream(side, sync_enter=False):
            yield

    def join(self, *names: str) -> None:
        """Make the main stream wait for the side streams ``names`` (all forked ones if none named).
        Every forked branch must be joined before the graph's recording ends."""
        if self._main is None:
            return
        for name in names or tuple(self._forked):
            if name in self._forked:
                self._main.wait_stream(self._streams[name])
                self._forked.discard(name)
        if not self._forked:
            self._main = None
