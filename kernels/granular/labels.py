"""The labelling of the components after a rebuild's search or over the reuse's pair lists:
``settle`` keeps each point's root in the forest of the pairs that were not listed
(``Interaction.base``), ``relink`` merges on top of it the listed pairs whose domains overlap now,
and ``label`` gives every point its root as label: the point of its component first in the fixed
``priority`` order, independent of thread order (``MPMSolver.components`` reports the smallest
scene index of each component instead). ``relink`` also frees the grid copies of the last claims
and ``label`` zeroes their depths (``layers``). ``label`` also zeroes the cell counts for the next rebuild,
records the cells' reference points for ``check``, and for the tent the labels in cell-sorted order
that ``assign`` reads ("Granular MPM" §3.4 task 2)."""

import functools

import warp as wp

from ..clock import CLOCK_T
from ..state import make_state_structs
from ..types import kernel, scalar_types
from .cells import make_cells
from .flags import (
    FLAG_COUNT,
    FLAG_FLIPPED,
    FLAG_FRESH,
    FLAG_REBUILD,
    FLAG_RELABEL,
    FLAG_RELABELS,
    FLAG_SPILLED,
    FLAG_STAMP,
    FLAG_STRAYED,
)
from .interaction import make_interaction_struct
from .layers import COPY_RUN
from .pairs import make_pairs
from .unionfind import find

__all__ = ["make_label_kernels"]


@functools.cache
def make_label_kernels(shape: str, precision: str, staged: bool = False, relink_lanes: int = 1):
    """(settle, relink, label) (module docstring; launched as in ``make_granular_kernels``).

    relink_lanes > 1 (domains that do not deform): ``relink`` is launched over relink_lanes threads a
    point, lane l taking the listed pairs l, l + relink_lanes, ... of its point and lane 0 the spill
    entry and the point's layers (every thread frees its share of the copies). With the wide lists a dense flow lists
    nearly every neighbour pair, and a relabel at every step merges them: the lanes run a point's
    chain of pair tests and merges side by side. The union–find's roots do not depend on the order
    of the merges (``unionfind``), so the labels are the same."""
    t = scalar_types(precision)
    Particles, Grid, Domain = make_state_structs(precision)
    Interaction = make_interaction_struct(precision)
    cells = make_cells(shape, precision, staged)
    tent_cells, deforming = cells.tent_cells, cells.deforming
    cell_of, cell_index, start = cells.cell_of, cells.cell_index, cells.start
    pairs = make_pairs(shape, precision, staged)
    spilled, relist = pairs.spilled, pairs.relist

    @kernel
    def settle(P: Particles, G: Grid, D: Domain, materials: wp.array(dtype=t.params), S: Interaction,
               status: wp.array(dtype=wp.int32), clock: wp.array(dtype=wp.float64)):
        # after ``link`` (rebuilds of non-deforming domains): every point's root in the forest of the
        # pairs that were not listed, kept in S.base for the relabels until the next rebuild, and
        # made its parent (no merge runs now, so the roots stay put: the forest stays valid)
        if S.flags[FLAG_REBUILD] == 0:
            return
        p = wp.tid()
        r = find(S.parent, p)
        S.base[p] = r
        S.parent[p] = r

    @wp.func
    def fresh_copies(S: Interaction):
        # whether this labelling gives out every copy anew (``relink`` frees them and voids every
        # point's layers, ``label`` zeroes the depths): a rebuild, or a relabel that ``judge`` made
        # fresh (FLAG_FRESH: the kept copies had filled half a node's layers). Another relabel keeps
        # the copies: the tent's ``assign`` gives out anew those of the nodes whose points changed labels,
        # and elsewhere a point whose label changed claims its copies in P2G (``label`` voids its
        # layers), as does a point whose node range changed (``check``). The copies its old label
        # kept stay claimed until the next fresh labelling, empty: a label names one component at a time,
        # so no two components ever share a copy
        fresh = True
        if wp.static(not deforming):
            fresh = S.flags[FLAG_REBUILD] != 0 or S.flags[FLAG_FRESH] != 0
        return fresh

    @kernel
    def relink(P: Particles, G: Grid, D: Domain, materials: wp.array(dtype=t.params), S: Interaction,
               status: wp.array(dtype=wp.int32), clock: wp.array(dtype=wp.float64)):
        # a relabel (every rebuild too): the listed pairs whose domains overlap now are merged into
        # the forest of the others (S.parent, which ``settle`` or the last ``check`` set to S.base),
        # and keep their new state; in a fresh labelling (``fresh_copies``) the copies are freed and
        # every point's layers void (−1 in the first word tells the claiming P2G to claim;
        # kernels/transfer.py)
        if wp.static(not deforming):
            if S.flags[FLAG_RELABEL] == 0:
                return
        tid = wp.tid()
        p = tid
        lane = int(0)
        if wp.static(relink_lanes > 1):
            lane = p - (p // wp.static(relink_lanes)) * wp.static(relink_lanes)
            p = p // wp.static(relink_lanes)
        # the copies the last claims kept are freed (no kernel reads Grid.owner between the step's
        # last grid update and the claiming P2G): the threads take the nodes of one layer in turn,
        # each as deep as the depth of its run (Grid.depth, COPY_RUN: a node without claims costs
        # one read), which ``label`` zeroes after them (the nodes of one run may sit in different
        # thread blocks). The tent's relabels without a rebuild keep the copies of the nodes whose
        # points kept their labels (``assign``, which frees the others), and their depths, and
        # ``label`` voids the layers of the points that left their cells
        if fresh_copies(S):
            rows = G.owner.shape[1]
            for k in range(tid, D.layer_rows * rows, P.x.shape[0] * wp.static(relink_lanes)):
                i = k // rows
                j = k - i * rows
                for s in range(G.depth[i, j // COPY_RUN]):
                    G.owner[s * D.layer_rows + i, j] = -1
            if lane == 0:
                P.slots[p, 0] = -1
        if wp.static(not deforming):
            flipped = bool(False)
            root = p
            xp = P.x[p]  # (loaded once for all of p's pairs)
            ep = S.ext[p]
            for k in range(lane, S.npairs[p], wp.static(relink_lanes)):
                code = S.pairs[k, p]
                now, root = relist(P, S, p, xp, ep, code, root)
                if now != code:
                    S.pairs[k, p] = now
                    flipped = True
            if lane == 0 and p < wp.min(S.flags[FLAG_SPILLED], S.spill.shape[0]):
                pair = S.spill[p]
                first, code = spilled(pair)
                now, _ = relist(P, S, first, P.x[first], S.ext[first], code, first)
                if now != code:
                    flipped = True
                    if now < 0:
                        first = -first - 1
                    S.spill[p] = wp.vec2i(first, pair[1])
            if flipped:
                if S.flags[FLAG_FLIPPED] == 0:  # (for ``judge``: whether the wide lists still change)
                    S.flags[FLAG_FLIPPED] = 1

    @kernel
    def label(P: Particles, G: Grid, D: Domain, materials: wp.array(dtype=t.params), S: Interaction,
                status: wp.array(dtype=wp.int32), clock: wp.array(dtype=wp.float64)):
        rebuilt = True
        if wp.static(not deforming):
            if S.flags[FLAG_RELABEL] == 0:
                return
            rebuilt = S.flags[FLAG_REBUILD] != 0
        p = wp.tid()
        if fresh_copies(S):
            # no copy is claimed now (``relink`` freed them): the depths start again from zero
            runs = G.depth.shape[1]
            for k in range(p, G.depth.shape[0] * runs, P.x.shape[0]):
                G.depth[k // runs, k - (k // runs) * runs] = 0
        if p == 0:
            if rebuilt:
                S.flags[FLAG_COUNT] = S.flags[FLAG_COUNT] + 1
            else:
                S.flags[FLAG_RELABELS] = S.flags[FLAG_RELABELS] + 1
        comp = find(S.parent, p)
        before = P.comp[p]  # (the label of the last labelling)
        if before != comp:
            P.comp[p] = comp
            if wp.static(not tent_cells):
                if not rebuilt:
                    P.slots[p, 0] = -1  # (it claims its new component's copies in P2G)
        if wp.static(staged):
            if clock[CLOCK_T] < P.release[p]:
                return
        rows = G.mass.shape[1]
        if wp.static(deforming):
            S.count[cell_index(P, G, D, p)] = 0  # (see below)
        else:
            # the point's cell at the last rebuild, where the cell-sorted list has it
            cell = S.cell0[p]
            if rebuilt:
                ref = S.order[start(S, cell)]  # the cell's reference: its first point in order
                S.cell_ref[cell] = ref
                S.ref[p] = ref
                # zero this point's cell count for the next rebuild (every point of a cell writes the
                # same zero; cells without points were never counted), which spares a memset of
                # every cell
                S.count[cell] = 0
            if wp.static(tent_cells):
                # the component in the cell-sorted order, for ``assign``; −1 for a point that has
                # left that cell since (S.moves), whose copies the claiming P2G finds instead
                cx, cy = cell_of(P, D, p, rows)
                here = cx * rows + cy
                if here != cell:
                    comp = -1
                    if S.flags[FLAG_STRAYED] == 0:  # (``check`` then compares with S.home)
                        S.flags[FLAG_STRAYED] = 1
                    P.slots[p, 0] = -1  # (it claims its copies in P2G: void the layers it had)
                if rebuilt:
                    S.labels[S.rank[p]] = comp  # (its place in order)
                    S.home[p] = here
                else:
                    # a relabel: the nodes of a cell whose points all kept their labels keep their
                    # copies (``assign`` gives them out only where a label changed). What S.labels
                    # holds for the point follows from P.comp and S.home of the last labelling (−1 if
                    # it had left its cell then): no gather through S.rank, and no store if unchanged
                    home = S.home[p]
                    if home != cell:
                        before = -1
                    if before != comp:
                        S.dirty[cell] = S.flags[FLAG_STAMP]
                        S.labels[S.rank[p]] = comp
                    if home != here:
                        S.home[p] = here

    return settle, relink, label
