"""The cell binning of the search: how many cells apart two points that share a node can be, each
point's cell (column-major over the nodes of one layer, as ``Grid.mass``), the runs of the
cell-sorted list (``Interaction.order``), and which points sit out a step's search."""

import functools
from typing import NamedTuple

import warp as wp

from ..clock import CLOCK_T
from ..scan import prefix_sum
from ..shape_functions import SUPPORT_NODES
from ..state import make_state_structs
from ..types import scalar_types
from .domains import DEFORMING_DOMAINS
from .flags import FLAG_REBUILD
from .interaction import make_interaction_struct

__all__ = ["Cells", "make_cells"]


class Cells(NamedTuple):
    """The cell binning of one variant (``make_cells``)."""

    W: int  # cells apart that two points sharing a node can be: the reach of the search
    WINDOW: int  # cells of the half window that ``check`` visits, (0, 0) included
    tent_cells: bool  # the tent outside staged scenes: its node range follows from its cell
    deforming: bool  # a shape of DEFORMING_DOMAINS
    cell_of: wp.Function  # (P, D, p, rows) -> (cx, cy)
    cell_index: wp.Function  # (P, G, D, p) -> cell, column-major
    idle: wp.Function  # (P, S, clock, p) -> whether p takes no part in this step's search
    start: wp.Function  # (S, cell) -> where the cell's run begins in S.order


@functools.cache
def make_cells(shape: str, precision: str, staged: bool = False) -> Cells:
    """The cell binning of the search for a shape function (``Cells``); staged: points not yet
    released stay out of the search."""
    t = scalar_types(precision)
    K = SUPPORT_NODES[shape]
    Particles, Grid, Domain = make_state_structs(precision)
    Interaction = make_interaction_struct(precision)
    # how many cells apart two points that share a node can be: the K nodes of a stencil start at
    # the point's own cell (the tent: floor(c)) or one of the two cells before it (the others), so
    # K − 1 or K; plus the spread of the four corner stencils of CPDI1 (domains up to about a cell
    # across). It bounds the search and the cells whose references ``check`` compares: the tighter,
    # the longer the labels last
    W = K - 1 if shape == "linear" else K + (1 if shape == "cpdi1" else 0)
    WINDOW = (W + 1) * (2 * W + 1)  # cells of the half window that ``check`` visits, (0, 0) included
    tent_cells = shape == "linear" and not staged  # ``check`` compares cells instead of node ranges
    deforming = shape in DEFORMING_DOMAINS

    @wp.func
    def cell_at(x: t.vec2, D: Domain, rows: int):
        c = (x - D.origin) * D.inv_h
        cx = wp.clamp(int(wp.floor(c[0])), 0, D.layer_rows - 1)
        cy = wp.clamp(int(wp.floor(c[1])), 0, rows - 1)
        return cx, cy

    @wp.func
    def cell_of(P: Particles, D: Domain, p: int, rows: int):
        return cell_at(P.x[p], D, rows)

    @wp.func
    def cell_index(P: Particles, G: Grid, D: Domain, p: int):
        # point p's cell, column-major over the nodes of one layer (as S.count and Grid.mass)
        rows = G.mass.shape[1]
        cx, cy = cell_of(P, D, p, rows)
        return cx * rows + cy

    @wp.func
    def idle(P: Particles, S: Interaction, clock: wp.array(dtype=wp.float64), p: int):
        # whether point p takes no part in this step's search: no rebuild (non-deforming domains;
        # outside a CUDA graph the rebuild kernels are launched and return), or not yet released
        if wp.static(not deforming):
            if S.flags[FLAG_REBUILD] == 0:
                return True
        if wp.static(staged):
            if clock[CLOCK_T] < P.release[p]:
                return True
        return False

    @wp.func
    def start(S: Interaction, cell: int):
        # where the cell's run begins in S.order (the next cell's: where it ends)
        return prefix_sum(S.prefix1, S.prefix2, S.prefix3, cell)

    return Cells(W, WINDOW, tent_cells, deforming, cell_of, cell_index, idle, start)
