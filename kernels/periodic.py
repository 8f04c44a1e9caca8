"""A periodic x direction of the grid: the ghost columns beyond the left and right sides are images
of the interior columns one period (the domain width L = x1 − x0, a whole number of cells) away.

The grid keeps its ghost columns (``GHOST_NODES`` per side, the widest stencil's reach), so no P2G or
G2P variant changes: points near the seam scatter onto ghost columns as they would onto any node.
Node index i and i + n (n = L / h cells) are the same node; the period's canonical columns are
node_lo[0] … node_lo[0] + n − 1, and the column on the right side (node_hi[0]) is the image of
the left one.

* ``make_periodic_fold``: after a P2G, each canonical node adds what was scattered onto its images
  (in a fixed order: deterministic, no atomics) and clears them, so the grid update sees the
  whole mass, momentum and force at the canonical node and nothing at the images;
* ``make_periodic_copy``: after a grid update, every image takes its canonical node's velocities,
  so that G2P reads the same field on both sides of the seam;
* ``make_wrap_point``: after G2P moved a point, its x goes back into [x0, x1), and the potential
  energy m g·Δx that this move adds is booked as the work term "work_inflow" (the energy a point
  brings in), so that the energy balance holds with gravity along x.
"""

import functools

import warp as wp

from .clock import CLOCK_DT
from .grid import WORK_INFLOW, work_slot
from .state import make_state_structs
from .types import kernel, scalar_types

__all__ = ["make_periodic_copy", "make_periodic_fold", "make_wrap_point", "make_wrap_x"]


@wp.func
def canonical_column(i: int, lo: int, n: int) -> int:
    """The column of the period [lo, lo + n) that column i is an image of (itself if inside)."""
    return lo + ((i - lo) % n + n) % n


@functools.cache
def make_periodic_fold(precision: str, *, mass: bool, momentum: bool, force: bool, remap: bool = False,
                       xpic: bool = False):
    """``periodic_fold(G, D, clock)``, launched over (n, columns of the grid) with n the period in
    nodes: canonical node (node_lo[0] + k, j) gathers mass, momentum (``Grid.vm`` with remap), force
    and the XPIC accumulator ``Grid.pk`` (as flagged) from its images i ± n, ± 2n, … in increasing
    i, and zeroes them: a point on either side of the seam then loads the same node. Only the
    fields a P2G scattered are touched (the flags of the wall fold that follows it)."""
    t = scalar_types(precision)
    T = t.scalar
    Grid, Domain = make_state_structs(precision)[1:]

    @wp.func
    def fold_vec(a: wp.array2d(dtype=t.vec2), i: int, j: int, first: int, n: int, rows: int):
        s = a[i, j]
        r = first
        while r < rows:
            if r != i:
                s = s + a[r, j]
                a[r, j] = t.vec2()
            r += n
        a[i, j] = s

    @kernel
    def periodic_fold(G: Grid, D: Domain, clock: wp.array(dtype=wp.float64)):
        k, j = wp.tid()
        if clock[CLOCK_DT] <= wp.float64(0.0):
            return
        lo = D.node_lo[0]
        n = D.node_hi[0] - lo
        i = lo + k
        rows = D.layer_rows
        first = i % n  # the leftmost image (or i itself)
        if wp.static(mass):
            m = G.mass[i, j]
            r = first
            while r < rows:
                if r != i:
                    m += G.mass[r, j]
                    G.mass[r, j] = T(0.0)
                r += n
            G.mass[i, j] = m
        if wp.static(momentum):
            if wp.static(remap):
                fold_vec(G.vm, i, j, first, n, rows)
            else:
                fold_vec(G.mom, i, j, first, n, rows)
        if wp.static(force):
            fold_vec(G.force, i, j, first, n, rows)
        if wp.static(xpic):
            fold_vec(G.pk, i, j, first, n, rows)

    return periodic_fold


@functools.cache
def make_periodic_copy(precision: str, *, remap: bool = False, xpic: bool = False):
    """``periodic_copy(G, D, clock)``, launched over the whole layer: every node outside the
    period's canonical columns takes the velocities V, Ṽ (and the MUSL re-mapped ``Grid.vm`` with
    remap, XPIC's ``Grid.vs`` and ``Grid.vk`` with xpic) of its canonical node. Run after each grid
    update and before the wall images, which then mirror the ghost rows of every column alike."""
    Grid, Domain = make_state_structs(precision)[1:]

    @kernel
    def periodic_copy(G: Grid, D: Domain, clock: wp.array(dtype=wp.float64)):
        i, j = wp.tid()
        if clock[CLOCK_DT] <= wp.float64(0.0):
            return
        lo = D.node_lo[0]
        n = D.node_hi[0] - lo
        c = canonical_column(i, lo, n)
        if c == i:
            return
        G.v[i, j] = G.v[c, j]
        G.vt[i, j] = G.vt[c, j]
        if wp.static(remap):
            G.vm[i, j] = G.vm[c, j]
        if wp.static(xpic):
            G.vs[i, j] = G.vs[c, j]
            G.vk[i, j] = G.vk[c, j]

    return periodic_copy


@functools.cache
def make_wrap_x(precision: str):
    """``wrap_x(x, D) -> x``: a position [m] whose x left [lo, hi) moved back by whole periods
    L = hi − lo; positions inside are returned untouched (the same bits)."""
    t = scalar_types(precision)
    Domain = make_state_structs(precision)[2]

    @wp.func
    def wrap_x(x: t.vec2, D: Domain):
        lo = D.lo[0]
        hi = D.hi[0]
        if x[0] >= lo and x[0] < hi:
            return x
        period = hi - lo
        y = x[0] - period * wp.floor((x[0] - lo) / period)
        if y >= hi or y < lo:  # (round-off of a point a hair outside the period)
            y = lo
        return t.vec2(y, x[1])

    return wrap_x


@functools.cache
def make_wrap_point(precision: str):
    """``wrap_point(P, D, p, work)``: point p's position back into the period (``make_wrap_x``);
    when it moved, m g·(x_out − x_in) [J/m] (the potential energy its move adds to the diagnostics'
    energy_gravity) goes to the "work_inflow" slots of ``work``."""
    Particles, Grid, Domain = make_state_structs(precision)
    wrap_x = make_wrap_x(precision)

    @wp.func
    def wrap_point(P: Particles, D: Domain, p: int, work: wp.array(dtype=wp.float64)):
        x_out = P.x[p]
        x_in = wrap_x(x_out, D)
        if x_in[0] != x_out[0]:
            wp.atomic_add(work, work_slot(WORK_INFLOW, 0, p * 7, D.tile_rows, D.layer_rows),  # (one tile)
                          wp.float64(P.mass[p]) * wp.float64(D.gravity[0]) * wp.float64(x_out[0] - x_in[0]))
            P.x[p] = x_in

    return wrap_point
