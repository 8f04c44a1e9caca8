"""Whether the Granular MPM block of a step is a conditional graph node or launched in line.

The interaction graph's rebuild and relabel (``GranularPlan.start``, ``mpmdem.sim.granular_state``) run
only in the steps whose flag asks for them: inside a CUDA graph, as conditional nodes
(``launch_plan.IfFlag``).
A skipped conditional node costs a few µs (bench/launch_floor.py); a taken one costs more than
the same kernels laid in line, where each reads its flag and returns at once in a step that needs
nothing: scenes whose block runs in nearly every step (sand-blocks, silo-discharge) are faster in
line, one whose block rarely runs (silo-filling) the other way (the figures: docs/benchmarks.md,
"Tuning constants and their measured reasons").

Which layout is cheaper is known only from the run: a flowing scene rebuilds in nearly every
step, one at rest almost never, and one scene can do both in turn. So a ``BlockLayout`` per block
reads, after each batch of ``Simulation.advance_to`` (where the host reads the clock anyway), how
many of the steps of the last window ran it. From ``Tuning.inline_above`` of them it lays the
block in line; at ``Tuning.conditional_below`` or fewer it puts it back in its conditional node
(the gap between the two keeps a rate near the break-even from switching at every window). The
Simulation then records its step graphs again (a few ms). The relabel block and the rebuild nested
in it are laid out each by its own rate: a large cloud may relabel in every step but rebuild in
few of them, where the rebuild's kernels launched over every point in the others cost more than
its conditional node. Both layouts launch the same kernels on the same data: the results are the same
bits, whichever layout ran when.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from .host_copy import host_copy
from .launch_plan import IfFlag
from .tuning import Tuning

__all__ = ["BlockLayout"]


class BlockLayout:
    """The layout of an ``IfFlag`` block, chosen from how often it ran.

    counters: an int32 device array whose ``slots`` count, summed, the steps that ran the block so
    far (Granular MPM: the relabel block, the rebuilds and the relabels without one; the rebuild
    block, the rebuilds). tuning: its ``inline_above``, ``conditional_below`` and
    ``layout_window_steps`` (the rates that switch the layout, the fewest steps a rate is taken over).
    """

    def __init__(self, block: IfFlag, counters: wp.array, slots: tuple[int, ...], tuning: Tuning):
        self.block = block
        self.tuning = tuning
        self.counters = counters
        self.slots = tuple(slots)
        #: how many times the layout changed
        self.switches = 0
        #: the block's rate over the last window (None before the first)
        self.rate: float | None = None
        self._window: tuple[int, int] | None = None  # (step, runs) at the window's start

    @property
    def inline(self) -> bool:
        """Whether the block is laid in line (else a conditional node)."""
        return self.block.inline

    def runs(self, counts: np.ndarray | None = None) -> int:
        """Steps that ran the block so far, from ``counts`` (the counters already copied to the
        host, which layouts sharing one counter array read once) or one small device-to-host copy."""
        if counts is None:
            counts = host_copy(self.counters)
        return int(np.sum(counts[list(self.slots)], dtype=np.int64))

    def after_batch(self, steps: int, counts: np.ndarray | None = None) -> bool:
        """Account the steps up to ``steps`` (the clock's step count; ``counts`` as in ``runs``);
        True when the layout changed (the caller records its graphs again)."""
        runs = self.runs(counts)
        if self._window is None or steps < self._window[0]:
            self._window = (steps, runs)
            return False
        start, start_runs = self._window
        tn = self.tuning
        if steps - start < tn.layout_window_steps:
            return False
        self.rate = (runs - start_runs) / (steps - start)
        self._window = (steps, runs)
        want = self.rate > tn.conditional_below if self.inline else self.rate >= tn.inline_above
        if want == self.inline:
            return False
        self.set_inline(want)
        return True

    def set_inline(self, inline: bool) -> None:
        """Lay the block in line (True) or in a conditional node (False); takes effect at the next
        recording of the step's graphs."""
        self.block.inline = bool(inline)
        self.switches += 1
