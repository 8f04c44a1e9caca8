"""The Verlet lists of body pairs of the DEM, rebuilt on the device when a body moved half a skin.

Bodies of ordinary size are binned in uniform cells (``bin_bodies``); each body then lists the
pairs it owns (the lower index of two small bodies, the small one of a small–large pair) whose
bounding circles come within the skin, or, for a large core (a wall), whose outline does
(``list_pairs``), sorted by partner so that the force sums do not depend on the order in which
threads filled the cells, and hands over the tangential history of the pairs that stay listed.
Outside deterministic mode ``build_lists`` also packs the listed slots at the front of
``Contacts.pairs``, one atomic a block (``scan.block_append``), so that the force pass runs on
full warps. The structs are ``kernels.dem_bodies``'s, the binning ``kernels.verlet``'s.
"""

import functools

import warp as wp

from .contact_geometry import make_contact_geometry
from .dem_bodies import FREE, STATUS_CELL_OVERFLOW, STATUS_NEIGHBOR_OVERFLOW, make_dem_structs
from .dem_period import make_dem_period
from .scan import block_append
from .types import Namespace, kernel, scalar_types
from .verlet import make_verlet

__all__ = ["make_dem_lists"]


@functools.cache
def make_dem_lists(precision: str, deterministic: bool = False, disk_pairs: bool = False, periodic: bool = False,
                   max_registers: int | None = None):
    """Kernels ``bin_bodies`` and ``build_lists`` of the body-pair lists for one precision (the
    packing of the listed slots only outside deterministic mode; with ``disk_pairs`` the pairs of
    two bodies flagged ``B.disk`` are left out of the packed list: ``kernels.dem_disks`` takes them).
    ``periodic``: x periodic, the cell columns wrap and distances take the partner's nearest image
    (``kernels.dem_period``), a large body's outline tested against the image of the body nearest it.
    ``max_registers``: the register cap of ``build_lists`` on CUDA (None: the compiler's choice)."""
    t = scalar_types(precision)
    T = t.scalar
    vec2 = t.vec2
    vec4 = t.vec4
    Bodies, Contacts, Params = make_dem_structs(precision)
    verlet = make_verlet(precision)
    sort_ids, cell_in, bin_item = verlet.sort_ids, verlet.cell_in, verlet.bin_item
    geometry = make_contact_geometry(precision)
    polygon_distance, box_distance = geometry.polygon_distance, geometry.box_distance
    image, periodic_cell = make_dem_period(precision).image, make_dem_period(precision).periodic_cell

    @wp.func
    def cell_of(x: vec2, prm: Params):
        if wp.static(periodic):
            return periodic_cell(x, prm)
        return cell_in(x, prm.cell_origin, prm.inv_cell, prm.cells_x, prm.cells_y)

    @kernel
    def bin_bodies(B: Bodies, prm: Params, small: wp.array(dtype=wp.int32), flags: wp.array(dtype=wp.int32),
                   cell_count: wp.array(dtype=wp.int32), cell_items: wp.array(dtype=wp.int32),
                   status: wp.array(dtype=wp.int32)):
        if flags[0] == 0:
            return
        i = small[wp.tid()]
        cx, cy = cell_of(B.x[i], prm)
        bin_item(cell_count, cell_items, cx * prm.cells_y + cy, prm.cell_cap, i, status, STATUS_CELL_OVERFLOW)

    @wp.func
    def add_pair(C: Contacts, i: int, j: int, n: int, status: wp.array(dtype=wp.int32)):
        if n < C.slots:
            C.nbr[i * C.slots + n] = j
        else:
            wp.atomic_add(status, STATUS_NEIGHBOR_OVERFLOW, 1)
        return n + 1

    @wp.func
    def match_old(C: Contacts, base: int, old_count: int, j: int, o: int):
        """The first old slot at or after o whose partner is not below j (the old partners are
        sorted): o, and whether that slot holds j."""
        while o < old_count and C.old_nbr[base + o] < j:
            o += 1
        return o, o < old_count and C.old_nbr[base + o] == j

    @wp.func
    def hand_over(C: Contacts, base: int, n: int, old_count: int):
        """The tangential history of the pairs that stay listed moved from their old slot o to their
        new slot s (both lists sorted by partner, so o rises with s); new pairs start without one,
        slots no longer listed are cleared, every listed pair's energy is reset.

        In place, without a copy of the old histories: a pair with o = s (most pairs, at a rebuild)
        stays where it is; those with o > s are moved in rising s, those with o < s in falling s,
        and only then are the new pairs' slots cleared. A move never reads a slot written before it:
        in rising s, the slots written lie below s <= o; in falling s, above s > o; and a slot
        written by one sweep is never the source of the other's (the matching is monotone)."""
        o = int(0)
        for s in range(n):
            o, found = match_old(C, base, old_count, C.nbr[base + s], o)
            if found and o > s:
                C.key[base + s] = C.key[base + o]
                C.slip[base + s] = C.slip[base + o]
        o_hi = old_count - 1
        for r in range(n):  # (falling s: j falls, so the old slot searched from the top falls too)
            s = n - 1 - r
            j = C.nbr[base + s]
            while o_hi >= 0 and C.old_nbr[base + o_hi] > j:
                o_hi -= 1
            if o_hi >= 0 and o_hi < s and C.old_nbr[base + o_hi] == j:
                C.key[base + s] = C.key[base + o_hi]
                C.slip[base + s] = C.slip[base + o_hi]
        o = int(0)
        for s in range(n):
            o, found = match_old(C, base, old_count, C.nbr[base + s], o)
            if not found:
                C.key[base + s] = wp.vec4i(-1, -1, -1, -1)
                C.slip[base + s] = vec4()
            if C.energy[base + s] != T(0.0):
                C.energy[base + s] = T(0.0)
        for s in range(n, old_count):  # (the slots this list no longer uses; those past old_count are clean)
            C.nbr[base + s] = -1
            C.key[base + s] = wp.vec4i(-1, -1, -1, -1)
            C.slip[base + s] = vec4()
            C.energy[base + s] = T(0.0)

    @wp.func
    def list_pairs(B: Bodies, C: Contacts, prm: Params, world: wp.array(dtype=vec2),
                   is_large: wp.array(dtype=wp.int32), large: wp.array(dtype=wp.int32), n_large: int,
                   cell_count: wp.array(dtype=wp.int32), cell_items: wp.array(dtype=wp.int32),
                   status: wp.array(dtype=wp.int32), i: int):
        """Body i's owned pairs listed anew (sorted by partner), their history carried over; returns
        how many."""
        K = C.slots
        base = i * K
        # keep the old partners for the history hand-over, fold the slots' dissipated work. Only the
        # old_count slots listed are read and cleared: the slots past a list are kept clean (nbr −1,
        # no key, slip, energy or work: the end of this function), and a body lists ~2 of its K.
        # The histories stay in their slots: ``hand_over`` moves those whose slot changes.
        old_count = C.count[i]
        folded = C.body_dissipated[i]
        # (the stores are skipped where they would write what is there: a slot that saw no touch
        # since the last build has no work, and the new list's partners overwrite nbr below n)
        for s in range(old_count):
            C.old_nbr[base + s] = C.nbr[base + s]
            work = C.dissipated[base + s]
            if work[0] != 0.0 or work[1] != 0.0:
                folded = folded + work
                C.dissipated[base + s] = wp.vec2d(0.0, 0.0)
        C.body_dissipated[i] = folded
        xi = B.x[i]
        ri = B.core_radius[i] + B.radius[i]
        free_i = B.motion[i] == FREE  # pairs need one free body; others never meet
        n = int(0)
        if is_large[i] == 0:
            cx, cy = cell_of(xi, prm)
            gx_lo = wp.max(cx - 1, 0)
            gx_hi = wp.min(cx + 2, prm.cells_x)
            if wp.static(periodic):  # (three distinct columns: cells_x >= 3)
                gx_lo = cx - 1
                gx_hi = cx + 2
            for gx_at in range(gx_lo, gx_hi):
                gx = gx_at
                if wp.static(periodic):
                    gx = (gx_at + prm.cells_x) % prm.cells_x
                for gy in range(wp.max(cy - 1, 0), wp.min(cy + 2, prm.cells_y)):
                    c = gx * prm.cells_y + gy
                    for s in range(wp.min(cell_count[c], prm.cell_cap)):
                        j = cell_items[c * prm.cell_cap + s]
                        if j > i and (free_i or B.motion[j] == FREE):
                            rj = B.core_radius[j] + B.radius[j]
                            xj = B.x[j]
                            if wp.static(periodic):
                                xj = xj + image(xi, xj, prm)
                            if wp.length(xj - xi) < ri + rj + prm.skin:
                                n = add_pair(C, i, j, n, status)
        for s in range(n_large):
            j = large[s]
            if j != i and (is_large[i] == 0 or j > i):
                if free_i or B.motion[j] == FREE:
                    listed = False
                    xs = xi  # (periodic: i's image nearest j, in j's frame, as the force pass pairs them)
                    if wp.static(periodic):
                        xs = xi - image(xi, B.x[j], prm)
                    if is_large[i] != 0:
                        listed = wp.length(B.x[j] - xs) - ri - B.core_radius[j] - B.radius[j] < prm.skin
                    else:
                        # a large core's outline only where its bounding box comes near (a wall is far
                        # from most bodies); the box test keeps a margin well above round-off, so the
                        # pairs listed are those of the outline test alone
                        reach = ri + B.radius[j] + prm.skin
                        start = B.vstart[j]
                        count = B.vcount[j]
                        if box_distance(xs, world, start, count) < reach + T(1.0e-3) * (reach + wp.length(xs)):
                            listed = polygon_distance(xs, world, start, count) - ri - B.radius[j] < prm.skin
                    if listed:
                        n = add_pair(C, i, j, n, status)
        n = wp.min(n, K)
        C.count[i] = n
        # insertion sort by partner: the pair order (and so the force sums) do not depend on the
        # order in which threads filled the cells
        sort_ids(C.nbr, base, n)
        hand_over(C, base, n, old_count)
        B.x_ref[i] = xi
        B.angle_ref[i] = B.angle[i]
        return n

    @wp.func
    def general_pair(B: Bodies, C: Contacts, i: int, s: int):
        """Whether owned slot s of body i goes to the general pair search (not two disks of the
        disk–disk pass)."""
        return B.disk[i] == 0 or B.disk[C.nbr[i * C.slots + s]] == 0

    @kernel(max_registers=max_registers)
    def build_lists(B: Bodies, C: Contacts, prm: Params, world: wp.array(dtype=vec2),
                    is_large: wp.array(dtype=wp.int32), large: wp.array(dtype=wp.int32), n_large: int,
                    flags: wp.array(dtype=wp.int32), cell_count: wp.array(dtype=wp.int32),
                    cell_items: wp.array(dtype=wp.int32), status: wp.array(dtype=wp.int32),
                    total: wp.array(dtype=wp.int32), bodies: int):
        """Rebuild the lists of bodies i < ``bodies`` (``list_pairs``); outside deterministic mode,
        pack the listed slots at the front of ``C.pairs`` (``total`` is ``C.total``), so the force
        pass runs on full warps (a body lists ~3 of its K slots), one atomic a block
        (``block_append``: launched over whole blocks). The order of the bodies there follows the
        atomics, which deterministic mode cannot have: it runs one thread per slot instead."""
        if flags[0] == 0:
            return
        i = wp.tid()
        n = int(0)
        if i < bodies:
            n = list_pairs(B, C, prm, world, is_large, large, n_large, cell_count, cell_items, status, i)
        if wp.static(not deterministic and not disk_pairs):
            off = block_append(total, n)
            for s in range(n):
                C.pairs[off + s] = i * C.slots + s
        if wp.static(not deterministic and disk_pairs):  # (the general pairs only)
            m = int(0)
            for s in range(n):
                if general_pair(B, C, i, s):
                    m += 1
            off = block_append(total, m)
            for s in range(n):
                if general_pair(B, C, i, s):
                    C.pairs[off] = i * C.slots + s
                    off += 1

    return Namespace(bin_bodies=bin_bodies, build_lists=build_lists)
