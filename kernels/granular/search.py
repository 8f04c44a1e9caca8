"""The search of a rebuild ("Granular MPM" §3.4, appendix Tables A1–A2), without storing the
interaction graph and without an O(N²) loop:

1. ``prepare``: each point computes its domain of interaction (``domains``) and the range of grid
   nodes its shape function reaches, resets its union–find parent, and counts itself into its cell
   (its rank there from the atomic add). Non-deforming domains keep one 16-byte record instead
   (position and half-extents, ``Interaction.records``). The counts are summed (``kernels.scan``).
2. ``place``: every point goes to its cell's start plus its rank in the cell-sorted list
   (``Interaction.order``): the points of a column of cells are one contiguous run.
3. ``link``: each point visits the runs of the columns of cells around its own; a pair interacts
   when the two points share a node (the pre-task) and their domains of interaction overlap (task 1);
   interacting pairs are merged in the union–find (``unionfind``). Pair tests within the band of
   flipping are listed instead, and the others give the margin of the label reuse (``reuse``).
"""

import functools

import warp as wp

from ..clock import CLOCK_T
from ..plasticity import P_RHO_CRIT
from ..state import make_state_structs
from ..types import kernel, scalar_types
from .cells import make_cells
from .domains import domains_overlap, make_domain_of_interaction, make_node_reach
from .flags import (
    BAND_BINS,
    EXT_SLOTS,
    FLAG_BAND,
    FLAG_BINS,
    FLAG_FORCED,
    FLAG_REBUILD,
    FLAG_SPILLED,
    FLAG_STRAYED,
    FLAG_WIDE,
    NO_MARGIN,
    PAIR_SLOTS,
    SAMPLE_SHIFT,
    bin_vec,
)
from .interaction import make_interaction_struct
from .pairs import make_pairs
from .unionfind import priority, unite

__all__ = ["PRUNE_GUARD", "make_reset_search", "make_search_kernels"]

#: Guard [cells] on the distances by which ``link`` leaves cells out of a tent point's window in
#: a streak of rebuilds (plus 1e-6 of the coordinate in cells): far above the rounding of a
#: position within its cell.
PRUNE_GUARD = 1.0e-3


@functools.cache
def make_search_kernels(shape: str, precision: str, staged: bool = False, link_lanes: int = 1):
    """(prepare, place, link) of a rebuild (module docstring; launched as in
    ``make_granular_kernels``).

    link_lanes > 1: ``link`` is launched over link_lanes threads a point. In a pass that only
    merges (a streak of rebuilds, FLAG_FORCED, or deforming domains: no margin, no listed pair),
    lane l takes every link_lanes-th point of each run it visits, so a point's chain of pair tests
    and merges is that much shorter; the union–find's roots do not depend on the order of the
    merges (``unionfind``), so the components are the same. A checked pass (margins, listed pairs:
    per point sums) runs in lane 0 alone."""
    t = scalar_types(precision)
    T = t.scalar
    Particles, Grid, Domain = make_state_structs(precision)
    Interaction = make_interaction_struct(precision)
    cells = make_cells(shape, precision, staged)
    W, tent_cells, deforming = cells.W, cells.tent_cells, cells.deforming
    cell_of, cell_index, idle, start = cells.cell_of, cells.cell_index, cells.idle, cells.start
    pairs = make_pairs(shape, precision, staged)
    quanta = pairs.quanta
    domain = make_domain_of_interaction(shape, precision)
    overlap = domains_overlap(precision)
    node_reach = make_node_reach(shape, precision)

    @wp.func
    def search_window(ext_x: T, ext_y: T, S: Interaction, D: Domain):
        # cells to search on each side for partners of a point of half-extents ext [m]: two domains
        # overlap only if the centres are closer than the sum of their half-extents, so the cells
        # beyond (own extent + largest extent) need no visit, nor those beyond the stencil (W);
        # also the least slack [m] of a pruned window (how far a pair it leaves out stays apart)
        emx = S.ext_max[0]
        emy = S.ext_max[1]
        if wp.static(deforming):
            for k in range(1, EXT_SLOTS):
                emx = wp.max(emx, S.ext_max[2 * k])
                emy = wp.max(emy, S.ext_max[2 * k + 1])
        ex = wp.float32(ext_x * D.inv_h) + emx
        ey = wp.float32(ext_y * D.inv_h) + emy
        wx = wp.min(W, int(ex) + 1)
        wy = wp.min(W, int(ey) + 1)
        slack = T(1.0e30)
        if wx < W:
            slack = wp.min(slack, T(wp.float32(wx) - ex) / D.inv_h)
        if wy < W:
            slack = wp.min(slack, T(wp.float32(wy) - ey) / D.inv_h)
        return wx, wy, slack

    @kernel
    def prepare(P: Particles, G: Grid, D: Domain, materials: wp.array(dtype=t.params), S: Interaction,
                status: wp.array(dtype=wp.int32), clock: wp.array(dtype=wp.float64)):
        if wp.static(not deforming):
            if S.flags[FLAG_REBUILD] == 0:
                return
        p = wp.tid()
        S.parent[p] = p
        if wp.static(staged):
            if clock[CLOCK_T] < P.release[p]:
                S.reach[p] = wp.vec4i(0, -1, 0, -1)  # an empty node range: shares no node
                S.npairs[p] = 0
                return
        rho_cr = materials[P.material[p]][P_RHO_CRIT]
        a, b = domain(P, p, rho_cr)
        if wp.static(deforming):
            S.dom_a[p] = a
            S.dom_b[p] = b
        # half-extents of the domain of interaction in cells (a continuum reaches its whole stencil),
        # whose maximum bounds how far the search must look
        ex = wp.float32((wp.abs(a[0]) + wp.abs(b[0])) * D.inv_h)
        ey = wp.float32((wp.abs(a[1]) + wp.abs(b[1])) * D.inv_h)
        if rho_cr <= T(0.0):
            ex = wp.float32(W)
            ey = wp.float32(W)
        if wp.static(deforming):
            slot = 2 * (p % EXT_SLOTS)
            if ex > S.ext_max[slot]:  # most points are not the largest: skip the atomic
                wp.atomic_max(S.ext_max, slot, ex)
            if ey > S.ext_max[slot + 1]:
                wp.atomic_max(S.ext_max, slot + 1, ey)
        else:
            xp = P.x[p]
            S.anchor[p] = xp
            if rho_cr > T(0.0):
                S.ext[p] = t.vec2(wp.abs(a[0]) + wp.abs(b[0]), wp.abs(a[1]) + wp.abs(b[1]))
                if S.flags[FLAG_FORCED] == 0:  # (a margin for this step's check: see ``link``)
                    wx, wy, slack = search_window(wp.abs(a[0]) + wp.abs(b[0]), wp.abs(a[1]) + wp.abs(b[1]), S, D)
                    slot = p % EXT_SLOTS
                    q = quanta(slack, S, False)
                    if q < S.slack[slot]:  # most points do not beat their slot: no atomic
                        wp.atomic_min(S.slack, slot, q)
            else:
                S.ext[p] = t.vec2(T(-1.0), T(-1.0))  # a continuum: interacts through its nodes
        if wp.static(not tent_cells):
            S.reach[p] = node_reach(P, D, p)  # (the tent's follows from its cell: not stored)
        cell = cell_index(P, G, D, p)
        if wp.static(not deforming):
            S.cell0[p] = cell
        S.rank[p] = wp.atomic_add(S.count, cell, 1)

    @kernel
    def place(P: Particles, G: Grid, D: Domain, materials: wp.array(dtype=t.params), S: Interaction,
              status: wp.array(dtype=wp.int32), clock: wp.array(dtype=wp.float64)):
        # after the scan of the cell counts: each point to its cell's run in S.order (with its record)
        p = wp.tid()
        if idle(P, S, clock, p):
            return
        k = start(S, cell_index(P, G, D, p)) + S.rank[p]
        S.order[k] = p
        if wp.static(not deforming):
            S.rank[p] = k  # (from now on its place in order: ``link`` and ``label`` read it alone)
            xp = P.x[p]
            e = S.ext[p]
            S.records[k] = t.vec4(xp[0], xp[1], e[0], e[1])

    @kernel
    def link(P: Particles, G: Grid, D: Domain, materials: wp.array(dtype=t.params), S: Interaction,
                status: wp.array(dtype=wp.int32), clock: wp.array(dtype=wp.float64)):
        p = wp.tid()
        lane = int(0)
        if wp.static(link_lanes > 1):
            lane = p - (p // wp.static(link_lanes)) * wp.static(link_lanes)
            p = p // wp.static(link_lanes)
        if idle(P, S, clock, p):
            return
        rows = G.mass.shape[1]
        cx, cy = cell_of(P, D, p, rows)
        rp = wp.vec4i()
        if wp.static(not tent_cells):
            rp = S.reach[p]
        xp = P.x[p]
        ap = t.vec2()
        bp = t.vec2()
        ep = t.vec2()
        continuum_p = False
        if wp.static(deforming):
            ap = S.dom_a[p]
            bp = S.dom_b[p]
            ep = t.vec2(wp.abs(ap[0]) + wp.abs(bp[0]), wp.abs(ap[1]) + wp.abs(bp[1]))
            continuum_p = materials[P.material[p]][P_RHO_CRIT] <= T(0.0)
        else:
            ep = S.ext[p]
            continuum_p = ep[0] < T(0.0)
        wx = W
        wy = W
        if not continuum_p:
            wx, wy, slack = search_window(ep[0], ep[1], S, D)
        margin_p = T(1.0e30)
        # the margin and the pairs about to flip are for this step's check: none in a streak of
        # rebuilds (FLAG_FORCED), whose steps skip it
        checked = True
        band = T(0.0)
        wide = False  # (the narrow band lists few pairs, all in the spill list, which ``check`` tests)
        if wp.static(not deforming):
            checked = S.flags[FLAG_FORCED] == 0
            band = T(S.flags[FLAG_BAND]) * S.quantum
            wide = S.flags[FLAG_WIDE] != 0
        offset = int(0)  # (link_lanes: this lane's first candidate of a run, and the stride)
        stride = int(1)
        if wp.static(link_lanes > 1):
            merges_only = not checked
            if wp.static(deforming):
                merges_only = True
            if merges_only:
                offset = lane
                stride = wp.static(link_lanes)
            elif lane != 0:
                return
        listed_p = int(0)  # pairs listed in p's slots
        # (one point in BAND_SAMPLE of a narrow rebuild counts the pairs just outside the band: those
        # whose ``priority`` has its top bits zero, scattered over any lattice, which p % BAND_SAMPLE
        # is not: a 2 × 2 packing sampled by index sees one row of its cells)
        counting = checked and not wide and (priority(p) >> wp.uint32(SAMPLE_SHIFT)) == wp.uint32(0)
        bins = bin_vec()
        root = p  # an ancestor of p in the union-find forest: saves walking up from p on each merge
        # half the neighbourhood: the points after p in S.order within its own column of cells (its
        # cell and those above it), and the next columns' cells within the window; the windows are
        # symmetric, so every pair is met once. Each column is one run of S.order: one loop, with
        # the point and its record read side by side
        lo = wp.max(cy - wy, 0)
        hi = wp.min(cy + wy, rows - 1)
        if wp.static(tent_cells):
            if not checked and not continuum_p:
                # no margins to keep (a streak of rebuilds): the window shrinks to the cells where
                # a partner could overlap p. A point of the next column, or of the cell above or
                # below, is at least p's distance to that side of its cell away, and two domains
                # overlap only closer than the sum of their half-extents, at most p's own plus the
                # largest (with a guard for the rounding of the distances): the pairs left out
                # share no edge, and each pair is still met by its left or lower point, whose
                # window this is
                c = (xp - D.origin) * D.inv_h
                fx = c[0] - T(cx)
                fy = c[1] - T(cy)
                # (the guard grows with the coordinate: a few float32 ulps of c, in cells)
                guard = T(PRUNE_GUARD) + T(1.0e-6) * (wp.abs(c[0]) + wp.abs(c[1]))
                reach_x = ep[0] * D.inv_h + T(S.ext_max[0]) + guard
                reach_y = ep[1] * D.inv_h + T(S.ext_max[1]) + guard
                if T(1.0) - fx >= reach_x:
                    wx = 0
                if T(1.0) - fy >= reach_y:
                    hi = wp.min(cy, rows - 1)
                if fy >= reach_y:
                    lo = cy
        own = int(0)  # p's place in S.order
        if wp.static(deforming):
            own = start(S, cx * rows + cy) + S.rank[p]
        else:
            own = S.rank[p]  # (``place`` stored it)
        for ix in range(cx, wp.min(cx + wx + 1, D.layer_rows)):
            first = own + 1
            if ix != cx:
                first = start(S, ix * rows + lo)
            last = start(S, ix * rows + hi + 1)
            for k in range(first + offset, last, stride):
                q = S.order[k]
                if wp.static(deforming):
                    rq = S.reach[q]  # (an unreleased q is in no cell)
                    # pre-task: a common node (the node ranges overlap in both directions;
                    # "Granular MPM" appendix Table A1)
                    if rq[0] > rp[1] or rp[0] > rq[1] or rq[2] > rp[3] or rp[2] > rq[3]:
                        continue
                    # task 1: the domains of interaction overlap (continua always interact; Table A2,
                    # Fig. A2)
                    if continuum_p or materials[P.material[q]][P_RHO_CRIT] <= T(0.0):
                        root = unite(S.parent, root, q)
                        continue
                    if overlap(xp, ap, bp, P.x[q], S.dom_a[q], S.dom_b[q]):
                        root = unite(S.parent, root, q)
                else:
                    # axis-aligned domains: the record of q alone decides task 1, the node
                    # ranges (the pre-task) are read only for pairs that pass it or a continuum
                    box_q = S.records[k]
                    joined = False
                    listed = False
                    if continuum_p or box_q[2] < T(0.0):
                        joined = True  # continua interact with every point they share a node with
                    else:
                        # task 1 for rectangles ("Granular MPM" appendix Table A2: both axes overlap).
                        # The overlap test flips only once the offset d changes by more than
                        # |s| in max-norm, s = least (sum of half-extents − |d|); touching is apart
                        sx = ep[0] + box_q[2] - wp.abs(box_q[0] - xp[0])
                        sy = ep[1] + box_q[3] - wp.abs(box_q[1] - xp[1])
                        joined = sx > T(0.0) and sy > T(0.0)
                        if checked:
                            near = wp.abs(wp.min(sx, sy))
                            if near < band:
                                # within the band of flipping: listed, tested anew at every step's
                                # check and merged by ``relink`` (not here), so it does not shrink
                                # the margin of all the others; past PAIR_SLOTS into the spill list
                                code = q
                                if not joined:
                                    code = -q - 1
                                if listed_p < PAIR_SLOTS and wide:
                                    S.pairs[listed_p, p] = code
                                    listed_p += 1
                                    listed = True
                                else:
                                    spilled = wp.atomic_add(S.flags, FLAG_SPILLED, 1)
                                    if spilled < S.spill.shape[0]:
                                        first = p
                                        if not joined:
                                            first = -p - 1
                                        S.spill[spilled] = wp.vec2i(first, q)
                                        listed = True
                            if not listed:
                                margin_p = wp.min(margin_p, near)
                                if counting and near >= band and near < T(4.0) * band:
                                    # its quarter octave above the band (an unrolled loop: registers)
                                    b = wp.clamp(int(wp.floor(T(4.0) * wp.log2(near / band))), 0, BAND_BINS - 1)
                                    for u in range(BAND_BINS):
                                        if u == b:
                                            bins[u] = bins[u] + 1
                    if joined and not listed:
                        if wp.static(tent_cells):
                            # the tent's nodes are the corners of its cell and the window reaches
                            # one cell (W = 1): every pair met here shares a node
                            root = unite(S.parent, root, q)
                        else:
                            rq = S.reach[q]
                            if rq[0] <= rp[1] and rp[0] <= rq[1] and rq[2] <= rp[3] and rp[2] <= rq[3]:
                                root = unite(S.parent, root, q)
        if wp.static(not deforming):
            if lane == 0:
                S.npairs[p] = listed_p
            if checked:
                slot = p % EXT_SLOTS
                q = quanta(margin_p, S, False)
                if q < S.slack[slot]:
                    wp.atomic_min(S.slack, slot, q)
            if counting:
                for k in range(BAND_BINS):
                    if bins[k] > 0:
                        wp.atomic_add(S.flags, FLAG_BINS + k, bins[k])

    return prepare, place, link


@functools.cache
def make_reset_search(precision: str, deforming: bool):
    """Kernel ``reset_search(G, D, ext_max, slack, cell_ref, flags, motion)`` over the nodes of one
    layer, first of a rebuild (every step for deforming domains): resets ``ext_max`` (deforming
    domains, which ``prepare`` fills) or the margins ``slack``, the cells' reference points
    ``cell_ref``, the ``motion`` since the rebuild and the counts of the last one's lists (the
    others). The copies of the last claims are freed by ``relink`` (``labels``)."""
    Particles, Grid, Domain = make_state_structs(precision)

    @kernel
    def reset_search(G: Grid, D: Domain, ext_max: wp.array(dtype=wp.float32), slack: wp.array(dtype=wp.int32),
                     cell_ref: wp.array(dtype=wp.int32), flags: wp.array(dtype=wp.int32),
                     motion: wp.array(dtype=wp.int32)):
        i, j = wp.tid()
        k = i * G.owner.shape[1] + j
        if wp.static(deforming):
            if k < 2 * EXT_SLOTS:
                ext_max[k] = wp.float32(0.0)
        else:
            if flags[FLAG_REBUILD] == 0:
                return
            if k == 0:
                flags[FLAG_SPILLED] = 0
                flags[FLAG_STRAYED] = 0
            if k < BAND_BINS:
                flags[FLAG_BINS + k] = 0
            if k < EXT_SLOTS:
                slack[k] = NO_MARGIN
            if k < 3 * EXT_SLOTS:
                motion[k] = 0
            cell_ref[k] = -1

    return reset_search
