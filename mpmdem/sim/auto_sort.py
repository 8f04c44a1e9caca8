"""Re-sorting of the points that triggers itself as their memory order drifts: the default,
``SolverConfig(sort_interval=None)``.

Points start in cell order (``cell_sort.device_order``), so that consecutive threads of P2G add
into neighbouring grid nodes and the atomics coalesce. As material flows that order degrades, and
a large scene with shuffled points steps at about half its sorted speed (docs/benchmarks.md,
"Tuning constants and their measured reasons"). ``Simulation`` measures the drift of the order
(``PointSorter.drift``: the fraction of consecutive pairs whose cells are not neighbours) after a
batch of ``advance_to`` — where it already synchronises to read the clock, so ``advance`` stays
free of host syncs — and re-sorts when it passes a threshold.

It runs only where it can pay: on CUDA devices, for at least ``Tuning.auto_sort_min_points``
points, and not in coupled scenes (the point–body lists follow the memory order, so
``CoupledStage`` keeps the points where they are). Every CPU run and every small scene is thus unchanged bit for bit.
"""

from __future__ import annotations

from ..model.config import SolverConfig
from .tuning import Tuning

__all__ = ["AutoSort", "auto_sort_applies"]


def auto_sort_applies(config: SolverConfig, tuning: Tuning, *, cuda: bool, points: int, coupled: bool) -> bool:
    """Whether the automatic re-sorting runs: sort_interval None (automatic), a CUDA device, at
    least ``tuning.auto_sort_min_points`` points, and no rigid bodies coupled to them."""
    return config.sort_interval is None and cuda and not coupled and points >= tuning.auto_sort_min_points


class AutoSort:
    """Checks the drift of the points' memory order at most every ``check_steps`` steps and
    re-sorts them by cell when it exceeds ``threshold``.

    Args:
        mpm: the ``MPMSolver`` whose points are watched.
        threshold: drift fraction [-] above which to re-sort (``Tuning.auto_sort_drift``).
        check_steps: fewest steps between two checks (``Tuning.auto_sort_check_steps``).

    Attributes:
        drift: the drift [-] found by the last check (None before the first).
        sorts: re-sorts done so far.
    """

    def __init__(self, mpm, threshold: float, check_steps: int):
        self.mpm = mpm
        self.threshold = threshold
        self.check_steps = check_steps
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
