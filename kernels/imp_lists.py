"""The point–body lists of the MPM–DEM coupling (MPM-SDEM §4), rebuilt on the device.

``check_lists`` flags a rebuild when a point or a moving body has moved (or turned) more than half
the skin since the last build, or a staged point has entered the scene: the DEM's Verlet rule
(``kernels.verlet``); without free bodies it also clears the bodies' loads. On a flagged step only,
points are binned in cells of the MPM grid (``bin_points``); each body visits the cells its core's
bounding box, grown by a, the largest r_p and the skin, covers (``tile`` threads per body share its
cells, so a long wall is not one thread's work) and lists the points within a_i + r_p + skin of its
core outline (``build_lists``: eq. 44's gap plus the skin). Each point then sorts its bodies (sums in
a fixed order) and carries the tangential history of pairs that stay listed (``finish_lists``).
"""

import functools

import warp as wp

from .contact_geometry import make_contact_geometry
from .imp_links import STATUS_CELL_OVERFLOW, STATUS_SLOT_OVERFLOW, make_imp_structs, make_release_gate
from .types import Namespace, kernel, scalar_types
from .verlet import make_verlet

__all__ = ["make_imp_lists"]

#: Position of a point not listed yet (a staged point before its release).
_UNLISTED = 1.0e30


@functools.cache
def make_imp_lists(precision: str, staged: bool = False):
    """Kernels ``check_lists``, ``bin_points``, ``build_lists`` and ``finish_lists`` of the point–body
    lists for one precision (staged: points before their release time are left out)."""
    t = scalar_types(precision)
    T = t.scalar
    vec2 = t.vec2
    Particles, Bodies, Links, Params, veci, vec2h = make_imp_structs(precision)
    verlet = make_verlet(precision)
    needs_rebuild, sort_ids, cell_in, bin_item = verlet.needs_rebuild, verlet.sort_ids, verlet.cell_in, verlet.bin_item
    polygon_distance = make_contact_geometry(precision).polygon_distance
    released = make_release_gate(precision, staged)

    @kernel
    def check_lists(P: Particles, B: Bodies, L: Links, prm: Params, clock: wp.array(dtype=wp.float64),
                    flags: wp.array(dtype=wp.int32), moving: int, clear: int):
        """Flag a rebuild when point i moved more than half the skin (or was just released), or
        moving body i (i < moving) moved or turned more than half the skin; body i < ``clear`` has
        its loads of this step cleared (where the DEM stage has no contact launch to do it). One
        launch over max(points, moving, clear) threads: a small scene's step is paid per launch."""
        i = wp.tid()
        if i == 0:
            L.near_count[0] = 0  # (``sift`` packs this step's near points after it)
        if i < clear:
            B.force[i] = vec2()
            B.torque[i] = T(0.0)
        if i < moving:
            if needs_rebuild(B, i, L.body_x_ref, L.body_angle_ref, prm.skin):
                flags[0] = 1
        if i >= P.x.shape[0]:
            return
        if not released(P, clock, i):
            return
        moved = wp.length(P.x[i] - L.x_ref[i])
        if moved > T(0.5) * prm.skin or not wp.isfinite(moved):
            flags[0] = 1

    @wp.func
    def cell_of(x: vec2, prm: Params):
        return cell_in(x, prm.cell_origin, prm.inv_cell, prm.cells_x, prm.cells_y)

    @kernel
    def bin_points(P: Particles, L: Links, prm: Params, clock: wp.array(dtype=wp.float64),
                   flags: wp.array(dtype=wp.int32), cell_count: wp.array(dtype=wp.int32),
                   cell_items: wp.array(dtype=wp.int32), status: wp.array(dtype=wp.int32)):
        """Point p into its cell's bin; keep its old list for the history hand-over."""
        if flags[0] == 0:
            return
        p = wp.tid()
        if p == 0:
            L.listed_count[0] = 0  # (``finish_lists`` packs them anew)
        S = L.slots
        base = p * S
        for s in range(S):
            L.old_body[base + s] = L.body[base + s]
            L.old_key[base + s] = L.key[base + s]
            L.old_slip[base + s] = L.slip[base + s]
            L.body[base + s] = -1
        L.count[p] = 0
        if not released(P, clock, p):
            L.x_ref[p] = vec2(T(_UNLISTED), T(_UNLISTED))
            return
        x = P.x[p]
        L.x_ref[p] = x
        cx, cy = cell_of(x, prm)
        bin_item(cell_count, cell_items, cx * prm.cells_y + cy, prm.cell_cap, p, status, STATUS_CELL_OVERFLOW)

    @kernel
    def build_lists(P: Particles, B: Bodies, L: Links, prm: Params, world: wp.array(dtype=vec2),
                    flags: wp.array(dtype=wp.int32), cell_count: wp.array(dtype=wp.int32),
                    cell_items: wp.array(dtype=wp.int32), status: wp.array(dtype=wp.int32)):
        """Body b (with ``tile`` lanes) lists the points within a_b + r_p + skin of its outline."""
        if flags[0] == 0:
            return
        tid = wp.tid()
        b = tid // prm.tile
        lane = tid - b * prm.tile
        xb = B.x[b]
        a = B.radius[b]
        grow = a + prm.r_max + prm.skin
        reach = B.core_radius[b] + grow
        start = B.vstart[b]
        count = B.vcount[b]
        # the cells of the core's box grown by the reach (not of the bounding circle: a long thin
        # wall's circle covers the whole domain)
        lo = world[start]
        hi = lo
        for k in range(1, count):
            w = world[start + k]
            lo = wp.min(lo, w)
            hi = wp.max(hi, w)
        lo_x, lo_y = cell_of(lo - vec2(grow, grow), prm)
        hi_x, hi_y = cell_of(hi + vec2(grow, grow), prm)
        nx = hi_x - lo_x + 1
        ny = hi_y - lo_y + 1
        if lane == 0:
            L.body_x_ref[b] = xb
            L.body_angle_ref[b] = B.angle[b]
        S = L.slots
        for c in range(lane, nx * ny, prm.tile):
            gx = lo_x + c // ny
            gy = lo_y + c - (c // ny) * ny
            cell = gx * prm.cells_y + gy
            for s in range(wp.min(cell_count[cell], prm.cell_cap)):
                p = cell_items[cell * prm.cell_cap + s]
                x = P.x[p]
                if wp.length(x - xb) < reach:
                    if polygon_distance(x, world, start, count) < a + L.radius[p] + prm.skin:
                        k = wp.atomic_add(L.count, p, 1)
                        if k < S:
                            L.body[p * S + k] = b
                        else:
                            wp.atomic_add(status, STATUS_SLOT_OVERFLOW, 1)

    @kernel
    def finish_lists(L: Links, flags: wp.array(dtype=wp.int32)):
        """Sort each point's bodies (a fixed summation order) and carry the history of pairs
        that stay listed; pack the points the force kernel must visit until the next build: those
        with a body listed, and those whose contact must be cleared (``forces``)."""
        if flags[0] == 0:
            return
        p = wp.tid()
        S = L.slots
        base = p * S
        n = wp.min(L.count[p], S)
        L.count[p] = n
        if n > 0 or L.active[p] != 0:
            L.listed[wp.atomic_add(L.listed_count, 0, 1)] = p
        sort_ids(L.body, base, n)
        for s in range(S):
            key = veci(-1, -1)
            slip = vec2h()
            if s < n:
                b = L.body[base + s]
                for o in range(S):
                    if L.old_body[base + o] == b:
                        key = L.old_key[base + o]
                        slip = L.old_slip[base + o]
            L.key[base + s] = key
            L.slip[base + s] = slip

    return Namespace(check_lists=check_lists, bin_points=bin_points, build_lists=build_lists,
                     finish_lists=finish_lists)
