"""Whether the Granular MPM block of a step is a conditional graph node or launched in line.

The interaction graph's rebuild and relabel (``granular_state.granular_plan``) run only in the
steps whose flag asks for them: inside a CUDA graph, as conditional nodes (``launch_plan.IfFlag``).
A skipped conditional node costs ~4.8 µs on an H100 (bench/launch_floor.py); a taken one costs
more than the same kernels laid in line, where each reads its flag and returns at once in a
step that needs nothing. Measured on one H100 (bench/README.md, "Conditional blocks laid in line"),
µs a step, conditional nodes → in line:

- sand-blocks (the block runs in 99 % of the steps): 153.7 → 142.3;
- silo-discharge (99 %): 183.7 → 168.5;
- silo-filling (0.04 %): 56.3 → 64.0, the other way.

Which layout is cheaper is known only from the run: a flowing scene rebuilds in nearly every
step, one at rest almost never, and one scene can do both in turn. So a ``BlockLayout`` per block
reads, after each batch of ``Simulation.advance_to`` (where the host reads the clock anyway), how
many of the steps of the last window ran it. From INLINE_ABOVE of them it lays the block in line;
at CONDITIONAL_BELOW or fewer it puts it back in its conditional node (the gap between the two
keeps a rate near the break-even, ~0.4 by the figures above, from switching at every window). The
Simulation then records its step graphs again (a few ms). The relabel block and the rebuild nested
in it are laid out each by its own rate: a 1M-point cloud relabels in every step but rebuilds in
15 % of them, where the rebuild's kernels launched over every point in the other 85 % cost more
than its conditional node (bench/README.md, "the rebuild as a conditional node inside the
relabel's"). Both layouts launch the same kernels on the same data: the results are the same
bits, whichever layout ran when.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from .launch_plan import IfFlag

__all__ = ["CONDITIONAL_BELOW", "INLINE_ABOVE", "WINDOW_STEPS", "BlockLayout"]

#: Fraction of a window's steps running the block from which it is laid in line.
INLINE_ABOVE = 0.6
#: Fraction at or below which an inline block goes back to its conditional nodes.
CONDITIONAL_BELOW = 0.3
#: Fewest steps a rate is taken over (the batches of ``advance_to`` are up to 400 steps on CUDA).
WINDOW_STEPS = 100


class BlockLayout:
    """The layout of an ``IfFlag`` block, chosen from how often it ran.

    counters: an int32 device array whose ``slots`` count, summed, the steps that ran the block so
    far (Granular MPM: the relabel block, the rebuilds and the relabels without one; the rebuild
    block, the rebuilds).
    """

    def __init__(self, block: IfFlag, counters: wp.array, slots: tuple[int, ...]):
        self.block = block
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
            counts = self.counters.numpy()
        return int(np.sum(counts[list(self.slots)], dtype=np.int64))

    def after_batch(self, steps: int, counts: np.ndarray | None = None) -> bool:
        """Account the steps up to ``steps`` (the clock's step count; ``counts`` as in ``runs``);
        True when the layout changed (the caller records its graphs again)."""
        runs = self.runs(counts)
        if self._window is None or steps < self._window[0]:
            self._window = (steps, runs)
            return False
        start, start_runs = self._window
        if steps - start < WINDOW_STEPS:
            return False
        self.rate = (runs - start_runs) / (steps - start)
        self._window = (steps, runs)
        want = self.rate > CONDITIONAL_BELOW if self.inline else self.rate >= INLINE_ABOVE
        if want == self.inline:
            return False
        self.set_inline(want)
        return True

    def set_inline(self, inline: bool) -> None:
        """Lay the block in line (True) or in a conditional node (False); takes effect at the next
        recording of the step's graphs."""
        self.block.inline = bool(inline)
        self.switches += 1
