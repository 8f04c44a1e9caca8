"""Re-sorting of the points that triggers itself as their memory order drifts: the default,
``SolverConfig(sort_interval=None)``.

Points start in cell order (``cell_sort.device_order``), so that consecutive threads of P2G add
into neighbouring grid nodes and the atomics coalesce. As material flows that order degrades: on
an H100 a 1M-point block with shuffled points steps at 0.49x its sorted speed. ``Simulation``
measures the drift of the order (``PointSorter.drift``: the fraction of consecutive pairs whose
cells are not neighbours) after a batch of ``advance_to`` — where it already synchronises to read
the clock, so ``advance`` stays free of host syncs — and re-sorts when it passes a threshold.

It runs only where it can pay: on CUDA devices, for at least ``AUTO_SORT_MIN_POINTS`` points, and
not in coupled scenes (the point–body lists follow the memory order, so ``CoupledStage`` keeps
the points where they are). Every CPU run and every small scene is thus unchanged bit for bit.
"""

from __future__ import annotations

from ..model.config import SolverConfig

__all__ = ["AUTO_SORT_CHECK_STEPS", "AUTO_SORT_DRIFT", "AUTO_SORT_MIN_POINTS", "AutoSort", "auto_sort_applies"]

#: Re-sort when more than this fraction [-] of consecutive point pairs sit in cells that are not
#: neighbours. A first choice, to be measured on the GPU (drift against step time): cell order
#: gives about 1 / (points per cell column), a random order close to 1.
AUTO_SORT_DRIFT = 0.25
#: Fewest points for which the order is watched. Below it the points and the grid fit in a data-centre
#: GPU's L2 cache, where memory order matters little (to be measured, as the threshold).
AUTO_SORT_MIN_POINTS = 65536
#: Fewest steps between two drift checks [steps]; 0: after every batch of ``advance_to`` (up to
#: 400 steps on CUDA). A check is one kernel over the points and a 4-byte read back, a few per cent
#: of a large step. Checking at most every 100 steps let a shuffled 1M-point block run most of a
#: 1000-step window unsorted (about half the sorted throughput): every batch it is. Figures:
#: docs/benchmarks.md, "Tuning constants and their measured reasons".
AUTO_SORT_CHECK_STEPS = 0


def auto_sort_applies(config: SolverConfig, *, cuda: bool, points: int, coupled: bool) -> bool:
    """Whether the automatic re-sorting runs: sort_interval None (automatic), a CUDA device, at
    least AUTO_SORT_MIN_POINTS points, and no rigid bodies coupled to them."""
    return config.sort_interval is None and cuda and not coupled and points >= AUTO_SORT_MIN_POINTS


class AutoSort:
    """Checks the drift of the points' memory order at most every ``check_steps`` steps and
    re-sorts them by cell when it exceeds ``threshold``.

    Args:
        mpm: the ``MPMSolver`` whose points are watched.
        threshold: drift fraction [-] above which to re-sort (None: AUTO_SORT_DRIFT).
        check_steps: fewest steps between two checks (None: AUTO_SORT_CHECK_STEPS).

    Attributes:
        drift: the drift [-] found by the last check (None before the first).
        sorts: re-sorts done so far.
    """

    def __init__(self, mpm, *, threshold: float | None = None, check_steps: int | None = None):
        self.mpm = mpm
        # the module constants are read here, not bound as defaults, so tests may patch them
        self.threshold = AUTO_SORT_DRIFT if threshold is None else threshold
        self.check_steps = AUTO_SORT_CHECK_STEPS if check_steps is None else check_steps
        self.drift: float | None = None
        self.sorts = 0
        self._checked_at: int | None = None
        mpm._sorter.prepare()  # (buffers and kernels loaded before the first step)

    def after_batch(self, steps: int) -> bool:
        """Called by ``Simulation.advance_to`` after a batch, when the host has just read the
        device's step count ``steps``. Returns True when it re-sorted the points."""
        if self._checked_at is not None and steps - self._checked_at < self.check_steps:
            return False
        self._checked_at = steps
        self.drift = self.mpm.order_drift()
        if self.drift <= self.threshold:
            return False
        self.mpm.sort_points()
        self.sorts += 1
        return True
