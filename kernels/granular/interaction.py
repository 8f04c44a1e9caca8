"""The ``Interaction`` struct: every array of the interaction graph, its reuse between rebuilds and
the grid copies' bookkeeping, bundled for the kernels."""

import functools

import warp as wp

from ..types import scalar_types

__all__ = ["make_interaction_struct"]


@functools.cache
def make_interaction_struct(precision: str):
    """The arrays of the interaction graph, bundled for the kernels: count (≥ cells + 1, whole scan
    tiles) int32 points per cell at this rebuild (zero between rebuilds); prefix1, prefix2, prefix3
    its three-level exclusive prefix sums (``kernels.scan``): the start of each cell's run in order;
    rank (N,) int32 each point's place among its cell's points (``prepare``), then for the non-deforming
    domains its place in order (``place``: the start of its cell's run plus that rank); cell0 (N,)
    int32 (non-deforming domains; one entry else) each point's cell at the last rebuild; order (N,)
    int32 the points by cell (column-major cells, like the grid); labels (N,) int32 (the tent outside staged scenes; one
    entry else) the component of order[k] at k, for ``assign``; slot_bytes (N, 4) uint8 (likewise)
    the bytes of ``Particles.slots`` (the same memory: byte n of a word is bits 8n..8n+7,
    little-endian), which ``assign`` stores one by one; records (N,) vec4 (non-deforming domains;
    one entry else) the search record of order[k] at k: its position at the last rebuild [m] and
    its ``ext``, read as one 16-byte record; parent (N,) int32 union–find links; dom_a, dom_b (N,)
    vec2 half-vectors of the domains of interaction [m] (deforming domains; one entry else); ext
    (N,) vec2 (non-deforming domains; one entry else): the half-extents of the axis-aligned domain
    of interaction [m], −1 for a continuum point (what the tests of listed pairs gather besides the
    positions); anchor (N,) vec2 (likewise) the position at the last rebuild [m]; reach (N,)
    vec4i node range (x0, x1, y0, y1) (one entry for the tent outside staged scenes, whose range
    follows from its cell); ext_max (2 EXT_SLOTS,) float32 largest half-extent [cells], x and y;
    slack (EXT_SLOTS,) int32: the margin of the last rebuild's pair tests and pruned windows in
    whole quanta (rounded down), reduced in slots; flags (FLAG_SLOTS,) int32; motion (3 EXT_SLOTS,)
    int32 (``MOVE_*``); cell_ref (cells,) int32: each cell's reference point at the last rebuild, −1
    for none; ref (N,) int32: the reference point of each point's cell at the last rebuild
    (non-deforming domains); pairs (PAIR_SLOTS, N) int32 (slot-major: the points of a warp read
    one slot in one coalesced load) and npairs (N,) int32 (non-deforming
    domains; one entry else): the partners q of the first ``npairs[p]`` of point p's overlap tests
    at the last rebuild that were within the band (``FLAG_BAND``) of flipping, each stored as q if
    the domains overlapped at the last labelling, −q − 1 if not; spill (capacity,) vec2i: those past
    PAIR_SLOTS, (p, q) or (−p − 1, q) (``FLAG_SPILLED`` counts them; those past the capacity count
    in ``slack`` instead); base (N,) int32 (likewise): each point's root in the forest of the pairs
    that were not listed (the part of the graph that holds until the next rebuild); home (N,) int32
    (the tent outside staged scenes): each point's cell at the last labelling; band_min, band_cap:
    the narrow band and the widest [quanta]; moves: 1 when a point may change cells and node
    ranges without a rebuild (domains that do not deform, outside staged scenes, every point
    granular, every domain of interaction under half a cell: overlapping domains then share a node
    whatever their cells, and domains that do not overlap never interact; ``check`` then stores a
    new range in ``reach`` and relabels), 0 else; moves_margin [quanta]: then the least change of
    offset that makes a pair the search did not visit (more than a cell apart) overlap, (1 − 2
    largest half-extent) h, NO_MARGIN else; quantum: the unit of ``slack`` and ``motion`` [m]; roundoff: the
    round-off allowance [m] of one displacement or margin."""
    t = scalar_types(precision)

    @wp.struct
    class Interaction:
        count: wp.array(dtype=wp.int32)
        prefix1: wp.array(dtype=wp.int32)
        prefix2: wp.array(dtype=wp.int32)
        prefix3: wp.array(dtype=wp.int32)
        rank: wp.array(dtype=wp.int32)
        cell0: wp.array(dtype=wp.int32)
        order: wp.array(dtype=wp.int32)
        labels: wp.array(dtype=wp.int32)
        slot_bytes: wp.array2d(dtype=wp.uint8)
        records: wp.array(dtype=t.vec4)
        parent: wp.array(dtype=wp.int32)
        dom_a: wp.array(dtype=t.vec2)
        dom_b: wp.array(dtype=t.vec2)
        ext: wp.array(dtype=t.vec2)
        anchor: wp.array(dtype=t.vec2)
        reach: wp.array(dtype=wp.vec4i)
        ext_max: wp.array(dtype=wp.float32)
        slack: wp.array(dtype=wp.int32)
        motion: wp.array(dtype=wp.int32)
        cell_ref: wp.array(dtype=wp.int32)
        ref: wp.array(dtype=wp.int32)
        pairs: wp.array2d(dtype=wp.int32)
        npairs: wp.array(dtype=wp.int32)
        spill: wp.array(dtype=wp.vec2i)
        base: wp.array(dtype=wp.int32)
        home: wp.array(dtype=wp.int32)
        dirty: wp.array(dtype=wp.int32)
        band_min: int
        band_cap: int
        moves: int
        moves_margin: int
        quantum: t.scalar
        flags: wp.array(dtype=wp.int32)
        roundoff: t.scalar

    return Interaction
