"""The broad-phase cells of a DEM scene periodic in x (``kernels.dem_period``): whole cells across
the period, at least three of them."""

from __future__ import annotations

import math

import numpy as np

from ..errors import InputError

__all__ = ["periodic_cells"]


def periodic_cells(domain, cell: float, lo: np.ndarray, hi: np.ndarray) -> tuple[float, np.ndarray, tuple[int, int]]:
    """Cells that tile the period L = x1 − x0 exactly: (cell size [m], origin [m], (columns, rows)).
    The cell grows from ``cell`` [m] (2 × the largest bounding radius + the skin) to L / floor(L /
    cell), the origin's x is x0 and the rows span [lo_y, hi_y] [m] as without a period. A period of
    fewer than three cells is an InputError: the three columns around a body must be distinct, so
    that a pair is listed once, under one image (and L is then at least three grain diameters)."""
    (x0, _), (x1, _) = domain
    period = x1 - x0
    columns = math.floor(period / cell)
    if columns < 3:
        raise InputError("domain", domain, f"a period x1 - x0 of at least 3 DEM broad-phase cells, {3 * cell:.6g} m "
                         f"(a cell is 2 x the largest bounding radius + the Verlet skin = {cell:.6g} m)")
    cell = period / columns
    origin = np.array([x0, lo[1]], float)
    rows = max(math.ceil((hi[1] - lo[1]) / cell), 1)
    return cell, origin, (columns, rows)
