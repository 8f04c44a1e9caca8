"""Reordering of the points by grid cell on the device, so that P2G atomics stay coalesced as
material flows (points that share nodes sit next to each other in memory)."""

import functools

import warp as wp

from .state import make_state_structs
from .types import kernel, scalar_types

__all__ = ["make_cell_keys", "make_gather_points", "make_order_drift", "make_point_cell"]


@functools.cache
def make_point_cell(precision: str):
    """``point_cell(x, D, rows, cols)``: the grid cell (column cx, row cy) holding position x [m],
    clamped to the grid (non-finite points end up at a clamp). The one definition of a point's
    cell for the sort keys and for the drift measure."""
    Domain = make_state_structs(precision)[2]
    t = scalar_types(precision)

    @wp.func
    def point_cell(x: t.vec2, D: Domain, rows: int, cols: int):
        c = (x - D.origin) * D.inv_h
        return wp.clamp(int(wp.floor(c[0])), 0, cols - 1), wp.clamp(int(wp.floor(c[1])), 0, rows - 1)

    return point_cell


@functools.cache
def make_cell_keys(precision: str):
    """keys[p] = cell column × rows + cell row of point p (column-major, like the grid), values[p] = p."""
    Particles, Grid, Domain = make_state_structs(precision)
    point_cell = make_point_cell(precision)

    @kernel
    def cell_keys(P: Particles, D: Domain, rows: int, cols: int, keys: wp.array(dtype=wp.int32),
                  values: wp.array(dtype=wp.int32)):
        p = wp.tid()
        cx, cy = point_cell(P.x[p], D, rows, cols)
        keys[p] = cx * rows + cy
        values[p] = p

    return cell_keys


@functools.cache
def make_order_drift(precision: str):
    """How far the memory order of the points has drifted from cell order.

    Launched over n − 1 threads, thread k looks at the consecutive pair (p − 1, p), p = k + 1,
    and adds 1 to ``count[0]`` when the cells of the two points (``point_cell``, the cells of
    the sort keys) are not neighbours: |Δcx| > 1 or |Δcy| > 1. Neighbouring cells are the
    reason: two points in cells at most one apart share nodes of their B-spline stencils, so
    the P2G atomics of consecutive threads hit the same or adjacent grid memory; a pair farther
    apart does not. ``count`` [pairs] must be zeroed before; count / (n − 1) is the drift, a
    dimensionless fraction in [0, 1]: about 1 / (points per column) in cell order (only the
    pairs that cross from the top of one column to the bottom of the next), close to 1 for a
    random order of a large scene.
    """
    Particles, Grid, Domain = make_state_structs(precision)
    point_cell = make_point_cell(precision)

    @kernel
    def order_drift(P: Particles, D: Domain, rows: int, cols: int, count: wp.array(dtype=wp.int32)):
        p = wp.tid() + 1
        ax, ay = point_cell(P.x[p - 1], D, rows, cols)
        bx, by = point_cell(P.x[p], D, rows, cols)
        if wp.abs(bx - ax) > 1 or wp.abs(by - ay) > 1:
            wp.atomic_add(count, 0, 1)

    return order_drift


@functools.cache
def make_gather_points(precision: str, staged: bool = False):
    """dst[p] = src[order[p]] for every per-point array (and the release times when staged)."""
    Particles = make_state_structs(precision)[0]

    @kernel
    def gather_points(src: Particles, dst: Particles, order: wp.array(dtype=wp.int32)):
        p = wp.tid()
        q = order[p]
        dst.x[p] = src.x[q]
        dst.v[p] = src.v[q]
        dst.C[p] = src.C[q]
        dst.F[p] = src.F[q]
        dst.stress[p] = src.stress[q]
        dst.szz[p] = src.szz[q]
        dst.mass[p] = src.mass[q]
        dst.vol[p] = src.vol[q]
        dst.vol0[p] = src.vol0[q]
        dst.half0[p] = src.half0[q]
        dst.material[p] = src.material[q]
        dst.strain_energy[p] = src.strain_energy[q]
        dst.pid[p] = src.pid[q]
        if wp.static(staged):
            dst.release[p] = src.release[q]

    return gather_points
