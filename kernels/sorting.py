"""Reordering of the points by grid cell on the device, so that P2G atomics stay coalesced as
material flows (points that share nodes sit next to each other in memory)."""

import functools

import warp as wp

from .state import make_state_structs
from .types import kernel

__all__ = ["make_cell_keys", "make_gather_points"]


@functools.cache
def make_cell_keys(precision: str):
    """keys[p] = cell column × rows + cell row of point p (column-major, like the grid), values[p] = p."""
    Particles, Grid, Domain = make_state_structs(precision)

    @kernel
    def cell_keys(P: Particles, D: Domain, rows: int, cols: int, keys: wp.array(dtype=wp.int32),
                  values: wp.array(dtype=wp.int32)):
        p = wp.tid()
        c = (P.x[p] - D.origin) * D.inv_h
        cx = wp.clamp(int(wp.floor(c[0])), 0, cols - 1)  # non-finite points end up at a clamp
        cy = wp.clamp(int(wp.floor(c[1])), 0, rows - 1)
        keys[p] = cx * rows + cy
        values[p] = p

    return cell_keys


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
