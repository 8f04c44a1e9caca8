"""Verlet-list upkeep shared by the body-pair lists of the DEM (``kernels.dem_lists``) and the
point–body lists of the coupling (``kernels.imp_lists``).

A list stays valid while nothing on it moved more than half the skin since it was built (the Verlet
rule, ``needs_rebuild``): one flag set on the device decides the rebuild, so a step needs no host
sync. A rebuild bins items in uniform cells (``cell_in``, ``bin_item``), each item's list is
sorted (``sort_ids``: the force sums then do not depend on the order threads filled the bins), and
``finish_rebuild`` counts the rebuild and lowers the flag.
"""

import functools

import warp as wp

from .dem_bodies import make_dem_structs
from .types import Namespace, kernel, scalar_types

__all__ = ["make_verlet"]


@functools.cache
def make_verlet(precision: str):
    """The Verlet rule, the binning functions and the rebuild bookkeeping kernels for one precision."""
    t = scalar_types(precision)
    T = t.scalar
    vec2 = t.vec2
    Bodies, Contacts, _ = make_dem_structs(precision)

    @wp.func
    def sort_ids(ids: wp.array(dtype=wp.int32), base: int, n: int):
        """Insertion sort of ids[base : base + n] (short lists of neighbour indices)."""
        for a in range(1, n):
            v = ids[base + a]
            b = a - 1
            while b >= 0 and ids[base + b] > v:
                ids[base + b + 1] = ids[base + b]
                b -= 1
            ids[base + b + 1] = v

    @wp.func
    def body_moved(B: Bodies, i: int, x_ref: wp.array(dtype=vec2), angle_ref: wp.array(dtype=T)):
        """Largest displacement [m] of body i's outline since (x_ref, angle_ref): centroid shift plus
        the arc its farthest vertex turned through."""
        return wp.length(B.x[i] - x_ref[i]) + B.core_radius[i] * wp.abs(B.angle[i] - angle_ref[i])

    @wp.func
    def needs_rebuild(B: Bodies, i: int, x_ref: wp.array(dtype=vec2), angle_ref: wp.array(dtype=T), skin: T):
        """Whether body i moved or turned more than half the skin since (x_ref, angle_ref), or went
        non-finite: the Verlet rule of the body–body and the point–body lists."""
        moved = body_moved(B, i, x_ref, angle_ref)
        return moved > T(0.5) * skin or not wp.isfinite(moved)

    @wp.func
    def cell_in(x: vec2, origin: vec2, inv_cell: T, nx: int, ny: int):
        """Cell (cx, cy) of a uniform binning holding x, clamped to the nx × ny cells."""
        cx = wp.clamp(int(wp.floor((x[0] - origin[0]) * inv_cell)), 0, nx - 1)
        cy = wp.clamp(int(wp.floor((x[1] - origin[1]) * inv_cell)), 0, ny - 1)
        return cx, cy

    @wp.func
    def bin_item(cell_count: wp.array(dtype=wp.int32), cell_items: wp.array(dtype=wp.int32), cell: int,
                 cap: int, item: int, status: wp.array(dtype=wp.int32), overflow: int):
        """Item into bin ``cell`` of a uniform binning (``cap`` items a bin); a full bin counts in
        ``status[overflow]``: the body–body and the point–body list builds."""
        s = wp.atomic_add(cell_count, cell, 1)
        if s < cap:
            cell_items[cell * cap + s] = item
        else:
            wp.atomic_add(status, overflow, 1)

    @kernel
    def clear_cells(flags: wp.array(dtype=wp.int32), cell_count: wp.array(dtype=wp.int32)):
        if flags[0] == 0:
            return
        cell_count[wp.tid()] = 0

    @kernel
    def reset_total(flags: wp.array(dtype=wp.int32), C: Contacts):
        if flags[0] != 0:
            C.total[0] = 0

    @kernel
    def finish_rebuild(flags: wp.array(dtype=wp.int32), rebuilds: wp.array(dtype=wp.int64)):
        if flags[0] != 0:
            rebuilds[0] = rebuilds[0] + wp.int64(1)
        flags[0] = 0

    return Namespace(sort_ids=sort_ids, body_moved=body_moved, needs_rebuild=needs_rebuild, cell_in=cell_in,
                     bin_item=bin_item, clear_cells=clear_cells, reset_total=reset_total,
                     finish_rebuild=finish_rebuild)
