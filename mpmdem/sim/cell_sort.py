"""Memory order of the material points: by grid cell, so consecutive threads touch neighbouring
nodes (coalesced P2G atomics). Points start in that order (``device_order``) and may be
re-sorted on the device as material flows (``PointSorter``); outputs keep the scene's order
through ``Particles.pid``."""

from __future__ import annotations

import numpy as np
import warp as wp

from ..kernels import sorting as sorting_kernels
from ..kernels.state import make_state_structs
from .host_copy import host_copy
from .mpm_state import POINT_FIELDS

__all__ = ["PointSorter", "device_order"]


def device_order(x: np.ndarray, origin, cell_size: float) -> np.ndarray:
    """Permutation that puts points (N, 2) [m] in the order they live in on the device.

    By cell column, then by height: consecutive threads touch nodes that are neighbours in memory
    (the grid is stored with j fastest), which keeps the P2G atomics coalesced (about 2x faster
    on an H100 than a row-by-row order). Outputs are returned in the scene's order (fields()).
    """
    return np.lexsort((x[:, 1], np.floor((x[:, 0] - origin[0]) / cell_size)))


class PointSorter:
    """Permutes every per-point array of ``points`` in place (scratch arrays allocated on first use).

    Args:
        points: the stage's ``Particles`` struct (its arrays are never replaced, only overwritten).
        domain: the stage's ``Domain`` struct; grid_shape: (layers × rows, columns) of the grid.
        precision, staged: as the stage's (staged scenes also permute the release times).
    """

    def __init__(self, points, domain, grid_shape: tuple[int, int], precision: str, staged: bool, device):
        self.points, self.domain, self.grid_shape = points, domain, grid_shape
        self.precision, self.staged, self.device = precision, staged, device
        self._scratch = None
        self._drift_count = None

    def _buffers(self):
        if self._scratch is None:
            points, n = self.points, len(self.points.x)
            Particles = make_state_structs(self.precision)[0]
            scratch = Particles()
            for name in POINT_FIELDS:
                setattr(scratch, name, wp.empty_like(getattr(points, name)))
            scratch.tmp = points.tmp
            scratch.comp = points.comp
            scratch.slots = points.slots
            scratch.fcont = points.fcont
            scratch.release = wp.empty_like(points.release) if self.staged else points.release
            keys = wp.empty(2 * n, dtype=wp.int32, device=self.device)
            values = wp.empty(2 * n, dtype=wp.int32, device=self.device)
            self._scratch = (scratch, keys, values)
        return self._scratch

    def _rows_cols(self) -> tuple[int, int]:
        """(rows, cols) of the cell keys: cells per grid column, and columns (the clamp of cx)."""
        return self.grid_shape[1], self.grid_shape[0]

    def prepare(self) -> None:
        """Allocate the scratch arrays and compile and load the sort's and the drift check's kernels
        now (each kernel is a module of its own: ``kernels.types.kernel``), so that the first
        re-sort during a run costs what later ones do, not a compilation."""
        self._buffers()
        for k in (sorting_kernels.make_cell_keys(self.precision),
                  sorting_kernels.make_gather_points(self.precision, self.staged),
                  sorting_kernels.make_order_drift(self.precision)):
            wp.load_module(k.module, device=self.device)

    def drift(self) -> float:
        """The fraction [-] of consecutive point pairs in memory whose cells are not neighbours
        (``kernels.sorting.make_order_drift``): near 0 in cell order, near 1 in a random order.
        One kernel and one 4-byte read back, so one host synchronisation."""
        n = len(self.points.x)
        if n < 2:
            return 0.0
        if self._drift_count is None:
            self._drift_count = wp.zeros(1, dtype=wp.int32, device=self.device)
        count = self._drift_count
        count.zero_()
        rows, cols = self._rows_cols()
        wp.launch(sorting_kernels.make_order_drift(self.precision), n - 1,
                  inputs=[self.points, self.domain, rows, cols, count], device=self.device)
        return int(host_copy(count)[0]) / (n - 1)

    def reorder(self, order: wp.array | None = None) -> None:
        """new[p] = old[order[p]] for every per-point array; None: by grid cell (radix sort)."""
        dev = self.device
        n = len(self.points.x)
        scratch, keys, values = self._buffers()
        if order is None:
            rows, cols = self._rows_cols()
            wp.launch(sorting_kernels.make_cell_keys(self.precision), n,
                      inputs=[self.points, self.domain, rows, cols, keys, values], device=dev)
            wp.utils.radix_sort_pairs(keys, values, n)
            order = values
        wp.launch(sorting_kernels.make_gather_points(self.precision, self.staged), n,
                  inputs=[self.points, scratch, order], device=dev)
        for name in POINT_FIELDS + (("release",) if self.staged else ()):
            wp.copy(getattr(self.points, name), getattr(scratch, name))
