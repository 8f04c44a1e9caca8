"""The grid layers ("Granular MPM" §3.4 tasks 2–3: one parallel grid per component, each run
separately with its points' data read and written back, appendix Tables A4–A5): instead of one grid
per component, each grid node holds ``layers`` copies, and the components that share a node never
share a copy there, so all of them run in one pass. In the first P2G of a step a point claims, at
every node it reaches, the first copy that is free or already its component's (compare-and-swap on
``Grid.owner``, ``make_layer_row``); later kernels look the copy up. A component alone on a node uses copy 0, so
the usual case costs one extra read per node: a greedy colouring per node, no iterations, and no
more copies than the most components meeting at one node. The tent outside staged scenes gives its
copies out before P2G instead (``make_assign``: one thread per node, no compare-and-swap races, and
layers that do not depend on thread timing). Also: the per-frame
statistics of components and layers."""

import functools

import warp as wp

from ..clock import CLOCK_T
from ..state import make_state_structs
from ..types import kernel, scalar_types
from .cells import make_cells
from .flags import (
    FLAG_REBUILD,
    FLAG_RELABEL,
    FLAG_STAMP,
    STAT_COMPONENTS,
    STAT_LAYERS,
    STATUS_LAYER_OVERFLOW,
)
from .interaction import make_interaction_struct

__all__ = ["ASSIGN_CACHE", "COPY_RUN", "NO_LAYER", "make_assign", "make_granular_statistics", "make_layer_row",
           "slot_words"]

#: The layer of a stencil node that has no copy of the point's component (a layer overflow) in
#: ``Particles.slots``, which keeps the layer of each of a point's stencil nodes in 8 bits, four to a
#: word: the P2G that claims the copies writes them, the later passes of the step read them instead
#: of looking the copies up (``slot_words``). On a step that keeps the labels the copies and the
#: point's nodes are those of the last claim, so that P2G reads them too; ``prepare`` voids them at
#: a rebuild (a first word of −1, every layer NO_LAYER, which a real claim could only write for a
#: point that found no copy at all: it then claims again, and finds none again).
NO_LAYER = 255


def slot_words(nodes: int) -> int:
    """Words of ``Particles.slots`` per point for a stencil of ``nodes`` nodes (8 bits each)."""
    return (nodes + 3) // 4

#: Components a node thread of ``assign`` (the tent's copies, ``make_granular_kernels``) keeps in
#: registers while it gives out copies; those past it are looked up in ``Grid.owner``.
ASSIGN_CACHE = 8

#: Grid copies are visited in runs of this many nodes along j: ``Grid.depth`` holds, for each run,
#: the most copies in use at one of its nodes, and the kernels over copies go that deep at every
#: node of the run, so their stores cover whole memory sectors (a store to a sector that other
#: threads leave partly unwritten is several times slower than a whole one).
COPY_RUN = 8


@functools.cache
def make_layer_row(insert: bool):
    """``layer_row(owner, i, j, comp, layer_rows, layers) -> row`` (−1 when none): the row of the
    grid copy that component ``comp`` uses at node (i, j).

    With ``insert`` it is ``layer_row(owner, depth, i, j, comp, layer_rows, layers) -> (row, layer)``
    (layer ``NO_LAYER`` when none) and claims the first free copy (compare-and-swap) when the
    component has none there, raising the depth of the node's run (``Grid.depth``, ``COPY_RUN``) to
    cover it.
    """

    @wp.func
    def scan(owner: wp.array2d(dtype=wp.int32), depth: wp.array2d(dtype=wp.int32), i: int, j: int, comp: int,
             layer_rows: int, layers: int):
        # (row, layer) of the component's copy, (−1, NO_LAYER) when none
        for s in range(layers):
            r = s * layer_rows + i
            k = owner[r, j]
            if k == comp:
                return r, s
            if k < 0:
                if wp.static(insert):
                    old = wp.atomic_cas(owner, r, j, -1, comp)
                    if old == -1:
                        run = j // COPY_RUN
                        if depth[i, run] <= s:  # (most claims are within the run's depth already)
                            wp.atomic_max(depth, i, run, s + 1)
                        return r, s
                    if old == comp:
                        return r, s
                else:
                    return -1, NO_LAYER  # (the copies in use are a prefix)
        return -1, NO_LAYER

    if insert:
        return scan

    @wp.func
    def find_row(owner: wp.array2d(dtype=wp.int32), i: int, j: int, comp: int, layer_rows: int, layers: int):
        r, s = scan(owner, owner, i, j, comp, layer_rows, layers)  # (a lookup touches no depth)
        return r

    return find_row


@functools.cache
def make_assign(shape: str, precision: str, staged: bool = False):
    """Kernel ``assign`` of the tent outside staged scenes (``make_granular_kernels``), over the nodes
    of one layer after ``label``: each node gives out its copies to the components of the points of
    the four cells it is a corner of, and stores each point's layer into ``Particles.slots``."""
    t = scalar_types(precision)
    Particles, Grid, Domain = make_state_structs(precision)
    Interaction = make_interaction_struct(precision)
    start = make_cells(shape, precision, staged).start

    cache_vec = wp.types.vector(length=ASSIGN_CACHE, dtype=wp.int32)

    @kernel(max_unroll=ASSIGN_CACHE)
    def assign(P: Particles, G: Grid, D: Domain, materials: wp.array(dtype=t.params), S: Interaction,
               status: wp.array(dtype=wp.int32), clock: wp.array(dtype=wp.float64)):
        # the tent outside staged scenes, after ``label``, over the nodes of one layer: node (i, j)
        # gives its copies to the components of the points whose stencil reaches it, which are the
        # points of the four cells it is a corner of (their runs in S.order), in that order, and
        # writes each point's layer into its slot for this node (Particles.slots: the claiming P2G
        # then finds them set and claims nothing). One thread decides a node's copies alone, so it
        # needs no compare-and-swap; the claims in P2G cost a chain of them where many components
        # meet (each loser of a race tries the next copy), and these are the same copies a claim
        # would give, in a fixed order: reproducible. The list is that of the last rebuild: a point
        # that has left its cell since (label −1) claims its copies in P2G.
        if S.flags[FLAG_RELABEL] == 0:
            return
        i, j = wp.tid()
        rows = G.mass.shape[1]
        lr = D.layer_rows
        rebuilt = S.flags[FLAG_REBUILD] != 0
        if not rebuilt:
            # a relabel without a rebuild: the same points in the same order as at the last
            # labelling, so a node whose four cells kept every label keeps its copies and the
            # layers its points hold (the points that left their cells claim theirs in P2G)
            stamp = S.flags[FLAG_STAMP]
            changed = False
            for dx in range(2):
                for dy in range(2):
                    cx = wp.clamp(i - 1 + dx, 0, lr - 1)
                    cy = wp.clamp(j - 1 + dy, 0, rows - 1)
                    if S.dirty[cx * rows + cy] == stamp:
                        changed = True
            if not changed:
                return
        # the components of the first ASSIGN_CACHE copies, in layer order (−2 where none: no label)
        seen = cache_vec()
        for u in range(ASSIGN_CACHE):
            seen[u] = -2
        n = int(0)  # copies given out
        for dx in range(2):
            cx = i - 1 + dx
            if cx >= 0 and cx < lr:
                k = start(S, cx * rows + wp.max(j - 1, 0))
                for dy in range(2):
                    cy = j - 1 + dy
                    if cy >= 0 and cy < rows:
                        end = start(S, cx * rows + cy + 1)
                        # this node is corner (i − cx, j − cy) of the cell: its slot in the stencil
                        corner = (1 - dx) * 2 + (1 - dy)
                        while k < end:
                            # (both read along the cell-sorted list: one line serves many points)
                            q = S.order[k]
                            comp = S.labels[k]
                            k += 1
                            if comp < 0:
                                continue
                            s = int(-1)
                            for u in range(ASSIGN_CACHE):
                                if seen[u] == comp:
                                    s = u
                            if s < 0:
                                for r in range(ASSIGN_CACHE, n):
                                    if s < 0 and G.owner[r * lr + i, j] == comp:
                                        s = r
                            if s < 0:
                                if n < D.layers:
                                    s = n
                                    G.owner[s * lr + i, j] = comp
                                    for u in range(ASSIGN_CACHE):
                                        if u == n:
                                            seen[u] = comp
                                    n += 1
                                else:
                                    wp.atomic_add(status, STATUS_LAYER_OVERFLOW, 1)
                            if s >= 0:
                                # this node's byte of the point's slots (prepare left it NO_LAYER):
                                # the four nodes of a point store to the four bytes of one word
                                S.slot_bytes[q, corner] = wp.uint8(s)
        if not rebuilt:
            # the copies this node gave out before, past the ones it gives out now, are free
            # (``relink`` freed them on a rebuild)
            for s in range(n, G.depth[i, j // COPY_RUN]):
                G.owner[s * lr + i, j] = -1
        if n > 0:
            wp.atomic_max(G.depth, i, j // COPY_RUN, n)

    return assign


@functools.cache
def make_granular_statistics(precision: str, staged: bool = False):
    """Kernel ``statistics(P, G, D, clock, stats)`` over max(N, nodes of one layer) threads: the
    number of components (released points that are their own label) into stats[0] and the most
    grid layers in use at one node into stats[1] (claimed: the copies that relabels keep for a
    component that has left the node count until the next rebuild), for the diagnostics of an
    output frame."""
    Particles, Grid, Domain = make_state_structs(precision)

    @kernel
    def statistics(P: Particles, G: Grid, D: Domain, clock: wp.array(dtype=wp.float64),
                   stats: wp.array(dtype=wp.int32)):
        tid = wp.tid()
        if tid < P.comp.shape[0]:
            counted = P.comp[tid] == tid
            if wp.static(staged):
                if clock[CLOCK_T] < P.release[tid]:
                    counted = False
            if counted:
                wp.atomic_add(stats, STAT_COMPONENTS, 1)
        rows = G.owner.shape[1]
        if tid < D.layer_rows * rows:
            i = tid // rows
            j = tid - i * rows
            used = int(0)
            for s in range(D.layers):
                if G.owner[s * D.layer_rows + i, j] >= 0:
                    used = s + 1
            if used > 0:
                wp.atomic_max(stats, STAT_LAYERS, used)

    return statistics
