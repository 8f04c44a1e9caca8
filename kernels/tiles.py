"""Tiles: the grid of a batch holds its worlds side by side along x, each world on a tile of
``Domain.tile_rows`` node rows with its own left and right walls (``mpmdem.sim.batch_scene``).

Every tile is laid out as its world's lone grid (ghost nodes, domain, ghost nodes), followed by
empty rows up to the tile's width, so node row i of tile w is row i − w·tile_rows of the lone
grid. ``Domain.node_lo``/``node_hi`` and ``lo``/``hi`` hold tile 0's walls; a node or point of
tile w sees them moved w·tile_rows rows (w·tile_rows·h metres) along x. An untiled grid is one
tile (``tile_rows`` = ``layer_rows``): every shift is zero and nothing changes, bit for bit.
"""

import functools

import warp as wp

from .state import make_state_structs
from .types import Namespace, scalar_types

__all__ = ["make_tiles", "tile_first"]


@wp.func
def tile_first(i: int, tile_rows: int):
    """First node row of the tile that holds node row i ≥ 0."""
    return (i // tile_rows) * tile_rows


@functools.cache
def make_tiles(precision: str):
    """``walls(D, i) -> (lo, hi, first, end)``: the wall node indices (vec2i, x shifted to the tile
    of node row i), and the tile's first row and one past its last (within the grid);
    ``shift(D, x) -> s``: the x shift [m] of the walls of the tile that holds x-position x [m]
    (0 left of the grid, the last tile's right of it); ``row(D, x)``: the node row at or left of x
    (clamped to the grid)."""
    t = scalar_types(precision)
    T = t.scalar
    Domain = make_state_structs(precision)[2]

    @wp.func
    def walls(D: Domain, i: int):
        first = tile_first(i, D.tile_rows)
        lo = wp.vec2i(D.node_lo[0] + first, D.node_lo[1])
        hi = wp.vec2i(D.node_hi[0] + first, D.node_hi[1])
        return lo, hi, first, wp.min(first + D.tile_rows, D.layer_rows)

    @wp.func
    def row(D: Domain, x: T):
        return wp.clamp(int(wp.floor((x - D.origin[0]) * D.inv_h)), 0, D.layer_rows - 1)

    @wp.func
    def shift(D: Domain, x: T):
        return T(tile_first(row(D, x), D.tile_rows)) * D.h

    return Namespace(walls=walls, shift=shift, row=row)
