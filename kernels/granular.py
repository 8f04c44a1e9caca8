"""Granular MPM on the device: domains of interaction, the interaction graph, its connected
components, and the per-node grid layers that keep components apart ("Granular MPM" §3.3–3.4).

Per step (all kernels, no host sync, capturable in a CUDA graph; on a step that keeps its labels
the rebuild kernels sit in a conditional graph node and are not launched at all):

1. ``prepare``: each point computes its domain of interaction (its domain scaled to the
   critical volume V_cr = m / ρ_cr, §3.3 and Fig. 4) as a parallelogram (centre, half-vectors
   a, b), the range of grid nodes its shape function reaches, resets its union–find parent, and
   counts itself into its grid cell (its rank there from the atomic add). For the shapes whose
   domains stay axis-aligned rectangles it keeps one 16-byte record instead (position and
   half-extents, ``Interaction.records``), so the search reads one record per candidate. The cell
   counts are summed (``kernels.scan``) and ``place`` puts every point at its cell's start plus
   its rank in a cell-sorted list (``Interaction.order``, with the records beside it): the points
   of a column of cells are then one contiguous run, whatever their number (no bin capacity).
2. ``link``: each point visits the runs of the columns of cells around its own. A pair interacts when the two points
   send data to a common node (the appendix's pre-task, from the node ranges) and their domains
   of interaction overlap (task 1, separating-axis test; for axis-aligned rectangles the two
   half-extent sums, and the node ranges are read only for pairs that overlap). Interacting pairs are merged in a
   lock-free union–find (compare-and-swap, the root of lower ``priority`` is hooked under the other), so the
   interaction graph is never stored and the search is cell-binned, not O(N²).
3. ``label``: every point takes its root as label: the point of its component first in a fixed
   pseudo-random order (``priority``), independent of thread order, so runs are reproducible
   (``MPMSolver.components`` reports the smallest scene index of each component instead), and
   zeroes its cell's count.
4. Task 2–3: instead of one grid per component, each grid node holds ``layers`` copies. In the
   first P2G of the step a point claims, at every node it reaches, the first copy that is free
   or already its component's (compare-and-swap on ``Grid.owner``); later kernels look the copy
   up. Components that share a node thus never share a copy there, and a component alone on a
   node uses copy 0, so the usual case costs one extra read per node. This is a greedy colouring
   per node rather than one colour per component: it needs no iterations, and uses no more
   copies than the most components meeting at one node. The tent outside staged scenes gives out
   its copies before P2G instead (``assign``): one thread per node walks the points of the four
   cells the node is a corner of (their runs in the cell-sorted list), gives each new component
   the next copy and stores each point's layer into ``Particles.slots``: no compare-and-swap
   races (where k components meet, the last claim waits k round trips), and the layers do not
   depend on thread timing.

Reuse of the labels (a Verlet-style skip, exact): the graph depends on each point's node range
(pre-task) and, for two granular points of a non-deforming domain, on their distance (task 1).
At a rebuild every point records its position and its node range, each cell one of its points
as reference, and the search records the margin M: the smallest change of a pair's offset
(max-norm) that would flip any overlap test it made, or let a pair the cell window pruned overlap
(``S.slack``, a global minimum: the rebuild decision is global anyway). Tests that were within a
band of flipping (``FLAG_BAND``) are left out of M: their pairs are listed (``S.pairs``, up to
PAIR_SLOTS a point, the rest in ``S.spill``) and are not merged by the search; ``settle`` keeps
each point's root in the forest of the other pairs (``S.base``), and ``relink`` merges on top of
it the listed pairs whose domains overlap now. A step then
rebuilds only when some point's node range changed, or when neither bound on how much any pair's
offset d_pq changed since is below M (less a round-off allowance): 2 max|Δx_p| (absolute moves),
or 2 max|Δx_p − Δx_ref(p)| + max|Δx_ref(c) − Δx_ref(c')| over cells c, c' within the search reach
(moves relative to the references: a body that translates, falls or flows as a whole keeps its
labels). When a listed pair flipped, or a point changed cells in a scene where that cannot change
the graph (``S.moves``: the tent, every point granular, every domain under half a cell), the step
relabels instead: ``relink`` and ``label`` over the forest and the lists, ``assign`` over the
rebuild's cell-sorted list (only at the nodes whose points changed labels: the others keep their
copies), the points that left their cell since claiming their copies in P2G.
Steps that keep or relabel get exactly the labels a rebuild would give. The check runs at the end
of a step, on the positions the next step starts from, and its verdict goes out with the clock's
advance (``judge``: one launch for both). The band is narrow (``mpm.CRITICAL_BAND``: one pair at
the threshold, as in a dense packing that dilates, where the paper's ρ_cr lets neighbours overlap
by only 0.17 % of a cell, does not make every step rebuild while it crosses), and each narrow
rebuild widens it as far as the pairs it counted just outside it allow (``BAND_SAMPLE``); a scene that
rebuilds at STREAK_START steps in a row (a dispersed flow) widens it so that the lists last about
WIDE_STEPS steps and relabels at every step between (``FLAG_WIDE``), and if it still rebuilds at
every step it skips the check for a while and just rebuilds (``FLAG_FORCED``). Deforming domains
(cpGIMP, CPDI) rebuild every step.

Non-granular materials (no critical density) are continua: their points interact with every
point they share a node with, so they are never split.
"""

import functools

import warp as wp

from .clock import CLOCK_DT, CLOCK_T
from .reductions import advance
from .scan import prefix_sum
from .shape_functions import SUPPORT_NODES
from .state import make_state_structs
from .types import kernel, scalar_types

__all__ = [
    "ASSIGN_CACHE",
    "DEFORMING_DOMAINS",
    "EXT_SLOTS",
    "FLAG_COUNT",
    "MOVE_ABSOLUTE",
    "MOVE_CELLS",
    "MOVE_RELATIVE",
    "FLAG_RANGE",
    "FLAG_CHANGED",
    "FLAG_RELABEL",
    "FLAG_RELABELS",
    "FLAG_WIDE",
    "FLAG_CALM",
    "FLAG_BAND",
    "FLAG_AGE",
    "FLAG_SPILLED",
    "FLAG_FLIPPED",
    "FLAG_STRAYED",
    "FLAG_BINS",
    "FLAG_MEASURED",
    "FLAG_ABSOLUTE",
    "FLAG_STAMP",
    "BAND_SAMPLE",
    "BAND_BINS",
    "BAND_BUDGET",
    "NARROW_GROWTH",
    "PAIR_SLOTS",
    "WIDE_STEPS",
    "CALM_STEPS",
    "FLAG_FORCED",
    "FLAG_STREAK",
    "FLAG_REBUILD",
    "FLAG_SLOTS",
    "NO_LAYER",
    "NO_MARGIN",
    "STAT_COMPONENTS",
    "STAT_LAYERS",
    "STATUS_LAYER_OVERFLOW",
    "STREAK_MAX",
    "STREAK_START",
    "COPY_RUN",
    "domains_overlap",
    "make_domain_of_interaction",
    "make_granular_kernels",
    "make_granular_statistics",
    "make_rebuild_decision",
    "make_interaction_struct",
    "make_reset_copies",
    "make_layer_row",
    "make_node_ranges",
    "make_node_reach",
    "slot_words",
]

#: Status counters (after the two of ``reductions``).
STATUS_LAYER_OVERFLOW = 2

#: Shapes whose domain of interaction follows F; for the others it is fixed from the start, and
#: its largest extent is computed once on the host (``static_extent``).
DEFORMING_DOMAINS = ("cpgimp", "cpdi1")
#: The largest extent of deforming domains, the margins and the moves are reduced into this many
#: slots (point p uses slot p % EXT_SLOTS, and only when it beats the slot): no million atomics on
#: one address, and few loads for ``judge``, one thread on the critical path of every step, to reduce
#: (H100, 262k points: 8 slots against 32 took ~2 µs off every scene's step, 203.2 → 201.1 µs on the
#: dispersed cloud).
EXT_SLOTS = 8

#: Registers per thread of ``check`` on CUDA: 32 lets a whole block of every warp slot of an SM run
#: at once (the compiler's 40 leave a quarter of them idle, and a 262k-point step a second wave).
CHECK_REGISTERS = 32

#: Slots of ``Interaction.motion`` (each reduced over EXT_SLOTS slots): max |Δx_p|, max
#: |Δx_p − Δx_ref(p)| and max |Δx_ref(c) − Δx_ref(c')| since the last rebuild, in quanta (rounded up).
#: They are the largest over the steps since the rebuild (zeroed only by ``reset_copies``): never
#: less than the current ones, so the bounds stay safe, and a point that does not beat its slot's
#: running maximum (most of them, once a body moves) costs ``check`` no atomic.
MOVE_ABSOLUTE = 0
MOVE_RELATIVE = 1
MOVE_CELLS = 2

#: Slots of ``Interaction.flags``: whether the next step rebuilds the interaction graph (set by
#: ``judge`` at the end of a step, or by the host: first step, after a reorder or a checkpoint) and
#: whether it labels the components anew (on every rebuild, and on a step whose check found a listed
#: pair flipped or a point in another cell, without a rebuild: ``relink``), how many of each so far,
#: and what ``check`` found: a node range changed (a rebuild) or a listed pair flipped / a point
#: changed cells (a relabel).
FLAG_REBUILD = 0
FLAG_COUNT = 1  # rebuilds so far
FLAG_RANGE = 2
FLAG_CHANGED = 3
FLAG_STREAK = 4  # consecutive steps whose check asked for a rebuild
FLAG_FORCED = 5  # steps left that rebuild without a check (a streak of rebuilds: see STREAK_START)
FLAG_RELABEL = 6
FLAG_RELABELS = 7  # relabels without a rebuild so far
FLAG_WIDE = 8  # 1 while the rebuilds list pairs within a wide band (a streak of rebuilds: see WIDE_STEPS)
FLAG_CALM = 9  # consecutive steps that kept everything while wide
FLAG_BAND = 10  # the band [quanta] of the next rebuild's pair lists
FLAG_AGE = 11  # steps since the last rebuild
FLAG_SPILLED = 12  # pairs the last rebuild listed in ``Interaction.spill`` (may exceed its size)
FLAG_FLIPPED = 13  # 1 when this step's ``relink`` found a listed pair flipped
FLAG_STRAYED = 14  # 1 once a relabel since the last rebuild took a point in another cell (``Interaction.home``)
FLAG_BINS = 15  # BAND_BINS slots: the sampled pairs of the last rebuild just outside its band (see BAND_SAMPLE)
FLAG_MEASURED = 23  # 1 when the last rebuild filled FLAG_BINS (a narrow rebuild that kept margins)
FLAG_ABSOLUTE = 24  # 1 when ``check`` keeps the absolute moves alone until the next rebuild (see ``judge``)
FLAG_STAMP = 25  # labellings so far (``judge``): ``label`` marks the cells whose labels changed with it (S.dirty)
FLAG_SLOTS = 26

#: Pairs a point lists (``Interaction.pairs``): the overlap tests of a rebuild that were within the
#: band of flipping; those past it go to one list for all (``Interaction.spill``), and past its
#: size they count in the margin instead. Eight hold the half neighbourhood of a point in a dense
#: flow with two by two points a cell (about four pairs each, up to seven), where every pair is
#: near flipping.
PAIR_SLOTS = 8

#: A scene whose checks ask for a rebuild STREAK_START steps in a row (a dispersed flow, whose
#: points change cells and meet at every step) first widens the band of its pair lists
#: (``FLAG_WIDE``): each rebuild lists the pairs within WIDE_STEPS times the growth per step of the
#: smaller bound on the pairs' moves since the last rebuild (see ``judge``; at least the narrow band,
#: at most ``band_cap``), so the lists last about WIDE_STEPS steps, and the steps between relabel
#: over them instead of rebuilding.
#: CALM_STEPS steps in a row that keep everything end it (a narrow rebuild). If the checks still ask
#: for a rebuild STREAK_START steps in a row, the scene stops checking: the next
#: ``min(streak, STREAK_MAX)`` steps rebuild without one, then a check decides again. A rebuild and a
#: relabel are always exact, so none of this changes a result, only what a step costs.
STREAK_START = 8
STREAK_MAX = 32
WIDE_STEPS = 16  # (H100, 1M points: 8, 16, 32 steps: cloud 624 / 622 / 622 µs, flowing column 502 / 496 / 494)
CALM_STEPS = 8
#: The narrow band follows the scene (``judge``). A rebuild that lists with the narrow band also
#: counts, over one point in BAND_SAMPLE (pseudo-random, ``priority``), the pairs it left out of
#: the lists whose overlap test is within 2^(k/4) to 2^((k+1)/4) times the band of flipping (bin
#: k < BAND_BINS: quarter octaves). The next narrow rebuild widens the band by as many quarter
#: octaves as keep the lists, estimated from those counts, within 1/BAND_BUDGET of the spill list,
#: with one more quarter octave to spare (the pairs just outside a band drift into it); it halves
#: the band when the lists outgrew twice that. A wider band lists more pairs (tested at every
#: check) and leaves the margin of all the others wider. A dense body settling under gravity, whose
#: neighbours overlap by 0.17 % of a cell (the paper's ρ_cr) and whose pairs across the load drift
#: towards parting, kept its margin at the narrow band itself and rebuilt every ~10 steps (CPU,
#: 262k points, 200 steps: 11 rebuilds with the fixed band, 5 with 2^-9.5 cells, 27 with 2^-9,
#: past the overlap, which lists every pair).
SAMPLE_SHIFT = 28
BAND_SAMPLE = 1 << (32 - SAMPLE_SHIFT)
BAND_BINS = 8
BAND_BUDGET = 4
#: ... and at most NARROW_GROWTH times the narrow band: a dispersed flow, whose pairs are far from
#: flipping, would widen it at every rebuild and put off the wide lists it needs (CPU, 16k points
#: of the dispersed cloud, first 100 steps: 19 rebuilds uncapped, 13 with the fixed band).
NARROW_GROWTH = 16
bin_vec = wp.types.vector(length=BAND_BINS, dtype=wp.int32)
#: A margin that nothing limits (no pair, no pruned window), in quanta (``Interaction.quantum``):
#: margins are reduced as integers, whose atomic minimum is native (a float one is a CAS loop, slow
#: when a million threads meet on a few slots).
NO_MARGIN = 2147483647

#: Slots of the per-step statistics array.
STAT_COMPONENTS = 0
STAT_LAYERS = 1


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


#: Guard [cells] on the distances by which ``link`` leaves cells out of a tent point's window in
#: a streak of rebuilds (plus 1e-6 of the coordinate in cells): far above the rounding of a
#: position within its cell.
PRUNE_GUARD = 1.0e-3

#: Components a node thread of ``assign`` (the tent's copies, ``make_granular_kernels``) keeps in
#: registers while it gives out copies; those past it are looked up in ``Grid.owner``.
ASSIGN_CACHE = 8

#: Grid copies are visited in runs of this many nodes along j: ``Grid.depth`` holds, for each run,
#: the most copies in use at one of its nodes, and the kernels over copies go that deep at every
#: node of the run, so their stores cover whole memory sectors (a store to a sector that other
#: threads leave partly unwritten is several times slower on an H100 than a whole one).
COPY_RUN = 8


@wp.func
def priority(i: int):
    """A fixed pseudo-random order of the points for the union–find (a multiplicative hash of the
    index, a bijection of the 32-bit integers): a component's root is its point of highest
    priority. Hooking the larger index under the smaller instead lines the hooks up along the
    cell-sorted order of a dense body, whose neighbours have nearby indices, into chains that every
    later search walks: a dense flow's merges took twice as long (H100, 262k and 1M points)."""
    return wp.uint32(i) * wp.uint32(2654435761)


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
def _overlap(precision: str):
    t = scalar_types(precision)

    @wp.func
    def project(a: t.vec2, b: t.vec2, n: t.vec2):
        return wp.abs(wp.dot(a, n)) + wp.abs(wp.dot(b, n))

    @wp.func
    def separated(d: t.vec2, a1: t.vec2, b1: t.vec2, a2: t.vec2, b2: t.vec2, n: t.vec2):
        return wp.abs(wp.dot(d, n)) >= project(a1, b1, n) + project(a2, b2, n)

    @wp.func
    def overlap(x1: t.vec2, a1: t.vec2, b1: t.vec2, x2: t.vec2, a2: t.vec2, b2: t.vec2):
        # Separating-axis test of two parallelograms x ± a ± b: the candidate axes are the edge
        # normals of both; touching (a zero-width overlap) counts as apart, as in Fig. 4(b).
        d = x2 - x1
        if separated(d, a1, b1, a2, b2, t.vec2(-a1[1], a1[0])):
            return False
        if separated(d, a1, b1, a2, b2, t.vec2(-b1[1], b1[0])):
            return False
        if separated(d, a1, b1, a2, b2, t.vec2(-a2[1], a2[0])):
            return False
        if separated(d, a1, b1, a2, b2, t.vec2(-b2[1], b2[0])):
            return False
        return True

    return overlap


def domains_overlap(precision: str):
    """``overlap(x1, a1, b1, x2, a2, b2) -> bool``: whether parallelograms x ± a ± b intersect."""
    return _overlap(precision)


@functools.cache
def make_domain_of_interaction(shape: str, precision: str):
    """``domain(P, p, rho_cr) -> (a, b)``: half-vectors [m] of the domain of interaction of point p.

    "Granular MPM" §3.3: the point's domain scaled about its centre to the critical volume
    V_cr = m / ρ_cr. Original MPM, uGIMP and the B-splines use the initial rectangle (a constant
    square for square seeding, Fig. 4); cpGIMP the rectangle stretched along F's columns; CPDI1 the
    parallelogram F (l_x, 0), F (0, l_y). ρ_cr ≤ 0 (a continuum) keeps the current size.
    """
    t = scalar_types(precision)
    T = t.scalar
    Particles = make_state_structs(precision)[0]

    @wp.func
    def domain(P: Particles, p: int, rho_cr: T):
        h0 = P.half0[p]
        a = t.vec2(h0[0], T(0.0))
        b = t.vec2(T(0.0), h0[1])
        if wp.static(shape == "cpgimp"):
            F = P.F[p]
            a = a * wp.sqrt(F[0, 0] * F[0, 0] + F[1, 0] * F[1, 0])
            b = b * wp.sqrt(F[0, 1] * F[0, 1] + F[1, 1] * F[1, 1])
        if wp.static(shape == "cpdi1"):
            F = P.F[p]
            a = h0[0] * t.vec2(F[0, 0], F[1, 0])
            b = h0[1] * t.vec2(F[0, 1], F[1, 1])
        vol = T(4.0) * wp.abs(a[0] * b[1] - a[1] * b[0])
        if rho_cr > T(0.0) and vol > T(0.0):
            s = wp.sqrt(P.mass[p] / (rho_cr * vol))
            a = s * a
            b = s * b
        return a, b

    return domain


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
    the narrow band and the widest [quanta]; moves: 1 when a point may change cells without a
    rebuild (the tent outside staged scenes, every point granular, every domain of interaction under
    half a cell: overlapping domains then share a node whatever their cells, and domains that do not
    overlap never interact), 0 else; moves_margin [quanta]: then the least change of offset that
    makes a pair the search did not visit (two or more cells apart) overlap, (1 − 2 largest
    half-extent) h, NO_MARGIN else; quantum: the unit of ``slack`` and ``motion`` [m]; roundoff: the
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


@functools.cache
def make_node_reach(shape: str, precision: str):
    """``node_reach(P, D, p) -> vec4i``: the range (x0, x1, y0, y1) of grid nodes (indices of one
    layer) that point p's stencil reaches, all corners for CPDI: what the pre-task compares."""
    from .transfer import CORNERS, make_stencil  # noqa: PLC0415 (transfer imports this module's helpers)

    K = SUPPORT_NODES[shape]
    NC = CORNERS.get(shape, 1)
    Particles, Grid, Domain = make_state_structs(precision)
    stencil = make_stencil(shape, precision)[0]

    @wp.func
    def node_reach(P: Particles, D: Domain, p: int):
        x0 = int(1073741824)
        y0 = int(1073741824)
        x1 = int(-1073741824)
        y1 = int(-1073741824)
        for k in range(wp.static(NC)):
            bx, by, wx, wy, dwx, dwy, g = stencil(P, D, p, k)
            x0 = wp.min(x0, bx)
            y0 = wp.min(y0, by)
            x1 = wp.max(x1, bx + K - 1)
            y1 = wp.max(y1, by + K - 1)
        return wp.vec4i(x0, x1, y0, y1)

    return node_reach


@functools.cache
def make_node_ranges(shape: str, precision: str):
    """Kernel ``node_ranges(P, D, out)`` over the points: each point's node range (``make_node_reach``)
    into ``out`` (N,) vec4i, for the host (``MPMSolver.node_ranges``)."""
    Particles, Grid, Domain = make_state_structs(precision)
    node_reach = make_node_reach(shape, precision)

    @kernel
    def node_ranges(P: Particles, D: Domain, out: wp.array(dtype=wp.vec4i)):
        p = wp.tid()
        out[p] = node_reach(P, D, p)

    return node_ranges


@functools.cache
def make_granular_kernels(shape: str, precision: str, staged: bool = False):
    """(check, prepare, place, link, settle, relink, label, assign) kernels of the interaction graph
    (module docstring).

    Launch each with dim = number of points and inputs ``[P, G, D, materials, S, status, clock]``.
    A step that relabels (``FLAG_RELABEL``, set by the previous step's ``judge``,
    ``make_rebuild_decision``; every step for deforming domains) runs ``reset_copies``, then, if it
    also rebuilds (``FLAG_REBUILD``), ``prepare``, the three scans of ``S.count`` (``kernels.scan``),
    ``place``, ``link`` and ``settle``, then ``relink``, ``label`` and ``assign``. ``check`` runs after
    the step's last G2P, then ``judge`` as the step's last kernel (``check`` and ``settle`` are None
    for deforming domains, which rebuild every step, list no pairs and have no ``judge``). S is an
    ``Interaction`` (``make_interaction_struct``): cells of ``S.count`` are indexed like ``Grid.mass``
    (column-major over the node lattice of one layer); ``S.ext_max`` holds for shapes outside
    DEFORMING_DOMAINS a constant set by the host in slot 0, else ``reset_copies`` zeroes it and
    ``prepare`` fills it. ``count`` starts zeroed and ``label`` zeroes the counts it used. ``assign``
    (the tent outside staged scenes; None else) runs over the nodes of one layer and gives out the
    grid copies there, instead of the claims in P2G. staged: points not yet released
    (``P.release`` ahead of ``clock[CLOCK_T]``) stay single components, in no cell.
    """
    t = scalar_types(precision)
    T = t.scalar
    K = SUPPORT_NODES[shape]
    Particles, Grid, Domain = make_state_structs(precision)
    Interaction = make_interaction_struct(precision)
    domain = make_domain_of_interaction(shape, precision)
    overlap = _overlap(precision)
    # how many cells apart two points that share a node can be: the K nodes of a stencil start at
    # the point's own cell (the tent: floor(c)) or one of the two cells before it (the others), so
    # K − 1 or K; plus the spread of the four corner stencils of CPDI1 (domains up to about a cell
    # across). It bounds the search and the cells whose references ``check`` compares: the tighter,
    # the longer the labels last
    W = K - 1 if shape == "linear" else K + (1 if shape == "cpdi1" else 0)
    WINDOW = (W + 1) * (2 * W + 1)  # cells of the half window that ``check`` visits, (0, 0) included
    tent_cells = shape == "linear" and not staged  # ``check`` compares cells instead of node ranges
    deforming = shape in DEFORMING_DOMAINS

    @wp.func
    def cell_at(x: t.vec2, D: Domain, rows: int):
        c = (x - D.origin) * D.inv_h
        cx = wp.clamp(int(wp.floor(c[0])), 0, D.layer_rows - 1)
        cy = wp.clamp(int(wp.floor(c[1])), 0, rows - 1)
        return cx, cy

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

    @wp.func
    def cell_of(P: Particles, D: Domain, p: int, rows: int):
        return cell_at(P.x[p], D, rows)

    @wp.func
    def cell_index(P: Particles, G: Grid, D: Domain, p: int):
        # point p's cell, column-major over the nodes of one layer (as S.count and Grid.mass)
        rows = G.mass.shape[1]
        cx, cy = cell_of(P, D, p, rows)
        return cx * rows + cy

    @wp.func
    def idle(P: Particles, S: Interaction, clock: wp.array(dtype=wp.float64), p: int):
        # whether point p takes no part in this step's search: no rebuild (non-deforming domains;
        # outside a CUDA graph the rebuild kernels are launched and return), or not yet released
        if wp.static(not deforming):
            if S.flags[FLAG_REBUILD] == 0:
                return True
        if wp.static(staged):
            if clock[CLOCK_T] < P.release[p]:
                return True
        return False

    @wp.func
    def start(S: Interaction, cell: int):
        # where the cell's run begins in S.order (the next cell's: where it ends)
        return prefix_sum(S.prefix1, S.prefix2, S.prefix3, cell)

    @wp.func
    def reduce_max(slots: wp.array(dtype=wp.int32), base: int, p: int, value: int):
        slot = base + p % EXT_SLOTS
        if value > slots[slot]:  # most values do not beat their slot: no atomic
            wp.atomic_max(slots, slot, value)

    @wp.func
    def reference(S: Interaction, p: int):
        return S.anchor[p]  # (the position at the last rebuild)

    @wp.func
    def moved(P: Particles, S: Interaction, p: int):
        return P.x[p] - reference(S, p)

    @wp.func
    def quanta(length: T, S: Interaction, up: bool):
        # a length [m] in whole quanta, capped: a displacement rounded up (never less than it is),
        # a margin rounded down (never more)
        v = length / S.quantum
        if up:
            v = wp.ceil(v)
        else:
            v = wp.floor(v)
        if v >= T(2.0e9):  # (2^31 - 1 is not a float32: compare below it)
            return NO_MARGIN
        return int(v)

    @wp.func
    def find(parent: wp.array(dtype=wp.int32), x: int):
        # root of x with path halving: each visited node is re-pointed to its grandparent, so the
        # trees stay shallow even when one component holds every point (a dense body); racing
        # writers only ever point a node at one of its ancestors, which keeps the forest valid
        r = x
        p = parent[r]
        while p != r:
            g = parent[p]
            if g != p:
                parent[r] = g
            r = p
            p = g
        return r

    @wp.func
    def unite(parent: wp.array(dtype=wp.int32), p: int, q: int):
        # p may be any ancestor of the point (a root it had): roots are only ever hooked under
        # others, so its root is still found from there; returns such an ancestor for the next call.
        # The root of lower ``priority`` is hooked under the other: every pointer goes up in
        # priority, so the forest stays acyclic whatever the order of the hooks
        a = find(parent, p)
        b = find(parent, q)
        while a != b:
            lo = a
            hi = b
            if priority(a) > priority(b):
                lo = b
                hi = a
            old = wp.atomic_cas(parent, lo, lo, hi)
            if old == lo:
                return hi
            a = find(parent, hi)
            b = find(parent, old)
        return a

    @wp.func
    def share(S: Interaction, p: int, q: int):
        # whether two points whose domains overlap share a node (the pre-task): always for the tent
        # (in one cell's reach at a rebuild; or, with S.moves, overlapping domains under half a cell)
        if wp.static(tent_cells):
            return True
        rp = S.reach[p]
        rq = S.reach[q]
        return rq[0] <= rp[1] and rp[0] <= rq[1] and rq[2] <= rp[3] and rp[2] <= rq[3]

    @wp.func
    def joined_with(xp: t.vec2, ep: t.vec2, P: Particles, S: Interaction, q: int):
        # the overlap test of a listed pair (p, q) with today's positions, p's position and
        # half-extents given, the operands as a rebuild's ``link`` would take them (sums and
        # |differences| of the same numbers: the same result whichever of the two searches)
        eq = S.ext[q]
        xq = P.x[q]
        sx = ep[0] + eq[0] - wp.abs(xq[0] - xp[0])
        sy = ep[1] + eq[1] - wp.abs(xq[1] - xp[1])
        return sx > T(0.0) and sy > T(0.0)

    @wp.func
    def joined_now(P: Particles, S: Interaction, p: int, q: int):
        return joined_with(P.x[p], S.ext[p], P, S, q)

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
        rho_cr = materials[P.material[p]][9]
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
            continuum_p = materials[P.material[p]][9] <= T(0.0)
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
            for k in range(first, last):
                q = S.order[k]
                if wp.static(deforming):
                    rq = S.reach[q]  # (an unreleased q is in no cell)
                    # pre-task: a common node (the node ranges overlap in both directions)
                    if rq[0] > rp[1] or rp[0] > rq[1] or rq[2] > rp[3] or rp[2] > rq[3]:
                        continue
                    # task 1: the domains of interaction overlap (continua always interact)
                    if continuum_p or materials[P.material[q]][9] <= T(0.0):
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
                        # the overlap test flips only once the offset d changes by more than
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
    def spilled(pair: wp.vec2i):
        # a spill entry (a, q), a = p or −p − 1 if the domains did not overlap: (p, code of q as in
        # S.pairs: q, or −q − 1 if apart)
        first = pair[0]
        code = pair[1]
        if first < 0:
            first = -first - 1
            code = -code - 1
        return first, code

    @wp.func
    def relist(P: Particles, S: Interaction, p: int, xp: t.vec2, ep: t.vec2, code: int, root: int):
        # a listed pair (p, q), q = code or −code − 1 if its domains did not overlap: merged if they
        # overlap now (and share a node; xp, ep: p's position and half-extents); returns its code for
        # today, and an ancestor of p (root: one it had, which saves walking up from p again on p's
        # next pair)
        q = code
        if code < 0:
            q = -code - 1
        joined = joined_with(xp, ep, P, S, q)
        ancestor = root
        now = -q - 1
        if joined:
            now = q
            if share(S, p, q):
                ancestor = unite(S.parent, root, q)
        return now, ancestor

    @kernel
    def relink(P: Particles, G: Grid, D: Domain, materials: wp.array(dtype=t.params), S: Interaction,
               status: wp.array(dtype=wp.int32), clock: wp.array(dtype=wp.float64)):
        # a relabel (every rebuild too), after ``reset_copies``: the listed pairs whose domains
        # overlap now are merged into the forest of the others (S.parent, which ``settle`` or the
        # last ``check`` set to S.base), and keep their new state; the layers the last claims kept
        # are void (all NO_LAYER in the first word tells the claiming P2G to claim; kernels/transfer.py)
        if wp.static(not deforming):
            if S.flags[FLAG_RELABEL] == 0:
                return
        p = wp.tid()
        # reset_copies has freed the copies by the depths of their runs (Grid.depth); no copy is
        # claimed now, so the depths start again from zero, here because reset_copies reads them
        # (the nodes of one run may sit in different thread blocks). The tent's relabels without a
        # rebuild keep the copies of the nodes whose points kept their labels (``assign``), and
        # their depths, and ``label`` voids the layers of the points that left their cells
        fresh = True
        if wp.static(tent_cells):
            fresh = S.flags[FLAG_REBUILD] != 0
        if fresh:
            runs = G.depth.shape[1]
            for k in range(p, G.depth.shape[0] * runs, P.x.shape[0]):
                G.depth[k // runs, k - (k // runs) * runs] = 0
            P.slots[p, 0] = -1
        if wp.static(not deforming):
            flipped = bool(False)
            root = p
            xp = P.x[p]  # (loaded once for all of p's pairs)
            ep = S.ext[p]
            for k in range(S.npairs[p]):
                code = S.pairs[k, p]
                now, root = relist(P, S, p, xp, ep, code, root)
                if now != code:
                    S.pairs[k, p] = now
                    flipped = True
            if p < wp.min(S.flags[FLAG_SPILLED], S.spill.shape[0]):
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
        if p == 0:
            if rebuilt:
                S.flags[FLAG_COUNT] = S.flags[FLAG_COUNT] + 1
            else:
                S.flags[FLAG_RELABELS] = S.flags[FLAG_RELABELS] + 1
        comp = find(S.parent, p)
        before = int(-1)
        if wp.static(tent_cells):
            before = P.comp[p]  # (the label of the last labelling)
        if before != comp:
            P.comp[p] = comp
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
            # (reset_copies freed them on a rebuild)
            for s in range(n, G.depth[i, j // COPY_RUN]):
                G.owner[s * lr + i, j] = -1
        if n > 0:
            wp.atomic_max(G.depth, i, j // COPY_RUN, n)

    @wp.func
    def flips(P: Particles, S: Interaction, p: int, code: int):
        # whether the overlap test of listed pair (p, q) differs from the one of the last labelling
        q = code
        if code < 0:
            q = -code - 1
        return joined_now(P, S, p, q) != (code >= 0)

    @kernel(max_unroll=WINDOW, max_registers=CHECK_REGISTERS)
    def check(P: Particles, G: Grid, D: Domain, materials: wp.array(dtype=t.params), S: Interaction,
              status: wp.array(dtype=wp.int32), clock: wp.array(dtype=wp.float64)):
        # after the step's last G2P: whether the next step needs a rebuild (see the module
        # docstring): a new node range rebuilds; the moves since the last rebuild, absolute and
        # relative to the cell's reference point, go to S.motion for ``judge``
        p = wp.tid()
        if S.flags[FLAG_RELABEL] != 0:
            S.parent[p] = S.base[p]  # (back to the forest of the unlisted pairs, for the next relabel)
        if S.flags[FLAG_RANGE] != 0 or S.flags[FLAG_FORCED] > 0:
            return  # a rebuild anyway
        # the pairs the last rebuild found within the band of flipping: their overlap tests again,
        # as a rebuild would make them now; a flip relabels. With the wide lists every step
        # relabels anyway (``judge``): no test here
        # (the narrow band lists its few pairs in the spill list alone: no per-point read here)
        flipped = bool(False)
        if S.flags[FLAG_WIDE] == 0 and p < wp.min(S.flags[FLAG_SPILLED], S.spill.shape[0]):
            first, code = spilled(S.spill[p])
            flipped = flipped or flips(P, S, first, code)
        if flipped:
            if S.flags[FLAG_CHANGED] == 0:  # (a load before the store: most find it set)
                S.flags[FLAG_CHANGED] = 1
        released = True
        if wp.static(tent_cells):
            # the tent's node range starts at the point's cell (the stencil's floor(c − 1) + 1 is
            # floor(c) on the grid): it changed iff the cell differs from the one of the last
            # labelling, which needs no read of the stored range. A relabel takes a point in another
            # cell when every domain is granular and under half a cell (S.moves); a rebuild else
            # (S.home differs from the cell of the rebuild only once a relabel took a point in another
            # cell, FLAG_STRAYED: until then S.cell0 tells)
            rows = G.mass.shape[1]
            cx, cy = cell_of(P, D, p, rows)
            home = int(0)
            if S.flags[FLAG_STRAYED] != 0:
                home = S.home[p]
            else:
                home = S.cell0[p]
            if cx * rows + cy != home:
                if S.moves != 0:
                    if S.flags[FLAG_CHANGED] == 0:
                        S.flags[FLAG_CHANGED] = 1
                else:
                    S.flags[FLAG_RANGE] = 1
                    return
        else:
            reach = wp.vec4i(0, -1, 0, -1)
            if wp.static(staged):
                released = clock[CLOCK_T] + clock[CLOCK_DT] >= P.release[p]  # (at the next step's time)
            if released:
                reach = node_reach(P, D, p)
            old = S.reach[p]
            if reach[0] != old[0] or reach[1] != old[1] or reach[2] != old[2] or reach[3] != old[3]:
                S.flags[FLAG_RANGE] = 1
                return
        if released:
            d = moved(P, S, p)
            reduce_max(S.motion, MOVE_ABSOLUTE * EXT_SLOTS, p, quanta(wp.max(wp.abs(d[0]), wp.abs(d[1])), S, True))
            if S.flags[FLAG_ABSOLUTE] != 0:
                return  # (the moves relative to the references bound nothing tighter here: see ``judge``)
            ref = S.ref[p]  # (kept per point: no gather through the cell on the way)
            e = d - moved(P, S, ref)
            reduce_max(S.motion, MOVE_RELATIVE * EXT_SLOTS, p, quanta(wp.max(wp.abs(e[0]), wp.abs(e[1])), S, True))
            if ref == p:
                rows = G.mass.shape[1]
                cell = S.cell0[p]  # (its cell at the last rebuild)
                cx = cell // rows
                cy = cell - cx * rows
                # a cell's reference point: how much the references of the cells within the search
                # reach (W cells: every pair that shares a node) moved relative to it; half the
                # window, (dx, dy) after (0, 0) column-major. The loop is unrolled and its reads take
                # clamped indices instead of branches, so they all leave at once rather than one
                # cell after another
                most = T(0.0)
                for k in range(WINDOW):
                    dx = k // (2 * W + 1)
                    dy = k - dx * (2 * W + 1) - W
                    if dx > 0 or dy > 0:
                        ix = cx + dx
                        iy = cy + dy
                        other = S.cell_ref[wp.min(ix, D.layer_rows - 1) * rows + wp.clamp(iy, 0, rows - 1)]
                        f = d - moved(P, S, wp.max(other, 0))
                        if other >= 0 and ix < D.layer_rows and iy >= 0 and iy < rows:
                            most = wp.max(most, wp.max(wp.abs(f[0]), wp.abs(f[1])))
                reduce_max(S.motion, MOVE_CELLS * EXT_SLOTS, p, quanta(most, S, True))

    if deforming:
        check = None
        settle = None
    if not tent_cells:
        assign = None
    return check, prepare, place, link, settle, relink, label, assign


@functools.cache
def make_rebuild_decision(precision: str):
    """Kernel ``judge(S, clock, steps)``, one thread, the last of a step, after ``check``
    (non-deforming domains; deforming ones rebuild every step): the next step rebuilds the
    interaction graph if ``check`` found a changed node range, or unless one of the two bounds on
    the change of the pairs' offsets is below the margin of the last rebuild (module docstring); it
    relabels (without a rebuild) if ``check`` found a listed pair flipped or a point in another
    cell. A streak of rebuilds widens the band of the pair lists, then stops the checks for a while
    (STREAK_START, WIDE_STEPS). It clears what ``check`` found, and advances the clock
    (``reductions.advance``): one launch for both, on the critical path of every step."""
    Interaction = make_interaction_struct(precision)
    T = scalar_types(precision).scalar

    @kernel(max_unroll=3 * EXT_SLOTS)
    def judge(S: Interaction, clock: wp.array(dtype=wp.float64), steps: wp.array(dtype=wp.int64)):
        advance(clock, steps)
        # (every load first, then the decision: the loads leave together instead of one after
        # another, on the critical path of every step; the loops are unrolled for the same reason)
        forced = S.flags[FLAG_FORCED]
        range_changed = S.flags[FLAG_RANGE] != 0
        changed = S.flags[FLAG_CHANGED] != 0
        flipped = S.flags[FLAG_FLIPPED] != 0
        streak = S.flags[FLAG_STREAK]
        wide = S.flags[FLAG_WIDE]
        calm = S.flags[FLAG_CALM]
        age = S.flags[FLAG_AGE] + 1
        measured = S.flags[FLAG_MEASURED] != 0
        listed = S.flags[FLAG_SPILLED]
        bins = bin_vec()
        for k in range(BAND_BINS):
            bins[k] = S.flags[FLAG_BINS + k]
        narrow_band = S.flags[FLAG_BAND]
        absolute_only = S.flags[FLAG_ABSOLUTE] != 0
        stamp = S.flags[FLAG_STAMP]
        # keep the labels if either bound on the change of every pair's offset is below the margin,
        # with the round-off of the displacements (2 or 4) and of the margin
        absolute = int(0)
        relative = int(0)
        cells = int(0)
        least = S.moves_margin
        for k in range(EXT_SLOTS):
            absolute = wp.max(absolute, S.motion[MOVE_ABSOLUTE * EXT_SLOTS + k])
            relative = wp.max(relative, S.motion[MOVE_RELATIVE * EXT_SLOTS + k])
            cells = wp.max(cells, S.motion[MOVE_CELLS * EXT_SLOTS + k])
            least = wp.min(least, S.slack[k])
        S.flags[FLAG_RANGE] = 0
        S.flags[FLAG_CHANGED] = 0
        S.flags[FLAG_FLIPPED] = 0
        if forced > 0:
            # a streak of rebuilds: this step's check was skipped, the next step rebuilds anyway
            S.flags[FLAG_FORCED] = forced - 1
            S.flags[FLAG_REBUILD] = 1
            S.flags[FLAG_RELABEL] = 1
            S.flags[FLAG_AGE] = 0
            S.flags[FLAG_MEASURED] = 0
            S.flags[FLAG_STAMP] = stamp + 1
            return
        q = S.quantum
        margin = T(least) * q
        keep_absolute = T(2.0) * T(absolute) * q + T(3.0) * S.roundoff < margin
        keep_relative = (T(2.0) * T(relative) + T(cells)) * q + T(7.0) * S.roundoff < margin
        if absolute_only:
            keep_relative = False  # (not measured: ``check`` skipped it)
        rebuild = range_changed or not (keep_absolute or keep_relative)
        # (with the wide lists ``check`` tests no pair and every step relabels; it counts as calm
        # when its ``relink`` found no pair flipped and no point changed cells)
        relabel = rebuild or changed or wide != 0
        unchecked = False  # (the next rebuild starts a window of rebuilds without checks)
        if wide != 0:
            changed = changed or flipped
        if rebuild:
            streak = streak + 1
            calm = 0
            if streak >= STREAK_START:
                if wide == 0:
                    wide = 1  # first, lists that last longer (WIDE_STEPS)
                    streak = 0
                else:
                    S.flags[FLAG_FORCED] = wp.min(streak, STREAK_MAX)
                    unchecked = True
        else:
            streak = 0
            if changed:
                calm = 0
            elif wide != 0:
                calm = calm + 1
                if calm >= CALM_STEPS:
                    # calm again: a rebuild with the narrow band, whose lists cost the checks less
                    wide = 0
                    calm = 0
                    rebuild = True
                    relabel = True
        if rebuild:
            band = S.band_min
            if wide == 0 and measured:
                # the narrow band, from what the last narrow rebuild listed and counted (BAND_SAMPLE):
                # widened by g quarter octaves where the pairs of bins 0..g (one to spare) keep the
                # lists within their budget, halved when the lists outgrew twice that
                budget = S.spill.shape[0] // BAND_BUDGET
                if listed > 2 * budget:
                    band = narrow_band // 2
                else:
                    estimate = listed
                    grow = int(0)
                    for k in range(BAND_BINS):
                        estimate += BAND_SAMPLE * bins[k]
                        if estimate <= budget and grow == k:
                            grow = k + 1
                    grow = wp.max(grow - 1, 0)
                    band = int(float(narrow_band) * wp.pow(2.0, 0.25 * float(grow)))
                band = wp.clamp(band, S.band_min, wp.min(NARROW_GROWTH * S.band_min, S.band_cap))
            if wide != 0:
                # how fast the smaller of the two bounds grew per step since the last rebuild
                # (rounded up), so that it reaches the band after about WIDE_STEPS steps: the
                # absolute one (2 max |Δx_p|) in a dispersed flow, the relative one in a dense body
                # that flows as a whole, whose points sit near the critical density (nearly every
                # pair near flipping): there a band that follows the absolute moves would list
                # every pair, past the slots, and still every step would rebuild
                grown = 2 * absolute
                if not absolute_only:
                    grown = wp.min(grown, 2 * relative + cells)
                rate = wp.min((grown + age - 1) // age, S.band_cap)
                band = wp.clamp(WIDE_STEPS * rate, S.band_min, S.band_cap)
            S.flags[FLAG_BAND] = band
            age = 0
        S.flags[FLAG_REBUILD] = 0
        S.flags[FLAG_RELABEL] = 0
        if rebuild:
            S.flags[FLAG_REBUILD] = 1
        if relabel:
            S.flags[FLAG_RELABEL] = 1
            S.flags[FLAG_STAMP] = stamp + 1
        if rebuild:
            # (whether the coming rebuild counts the pairs outside its band: a narrow one that keeps margins)
            S.flags[FLAG_MEASURED] = int(wide == 0 and not unchecked)
        # the moves relative to the references cost ``check`` its gathers; where they bound the
        # pairs' offsets twice as loosely as the absolute moves (a dispersed flow: the neighbours of
        # a point move their own ways, ~3 times) it keeps the absolute ones alone until the next
        # rebuild, which measures both again (twice: the first steps of a body at rest that starts
        # to settle have both bounds alike, and then the relative one alone lasts)
        if rebuild:
            absolute_only = False
        elif 0 < absolute and 4 * absolute < 2 * relative + cells:
            absolute_only = True
        S.flags[FLAG_ABSOLUTE] = int(absolute_only)
        S.flags[FLAG_STREAK] = streak
        S.flags[FLAG_WIDE] = wide
        S.flags[FLAG_CALM] = calm
        S.flags[FLAG_AGE] = age

    return judge


@functools.cache
def make_reset_copies(precision: str, deforming: bool, incremental: bool = False):
    """Kernel ``reset_copies(G, D, ext_max, slack, cell_ref, flags, motion)`` over the nodes of one
    layer, on the steps that relabel (every step for deforming domains): frees the copies the
    previous steps claimed (as deep as ``Grid.depth`` says, so a node without claims costs one read
    instead of a memset of every layer; ``relink`` then zeroes the depths) and, on a rebuild, resets
    ``ext_max`` (deforming domains) or ``slack``, ``cell_ref`` and ``motion`` (the others).
    incremental (the tent outside staged scenes): a relabel without a rebuild frees nothing here;
    ``assign`` gives out anew the copies of the nodes whose points changed labels, and frees theirs."""
    Particles, Grid, Domain = make_state_structs(precision)

    @kernel
    def reset_copies(G: Grid, D: Domain, ext_max: wp.array(dtype=wp.float32), slack: wp.array(dtype=wp.int32),
                     cell_ref: wp.array(dtype=wp.int32), flags: wp.array(dtype=wp.int32),
                     motion: wp.array(dtype=wp.int32)):
        # on a step that keeps the labels every point keeps its node range, so the copies claimed
        # at the last labelling are the ones this step claims again: they stay
        if wp.static(not deforming):
            if flags[FLAG_RELABEL] == 0:
                return
        if wp.static(incremental):
            if flags[FLAG_REBUILD] == 0:
                return
        i, j = wp.tid()
        k = i * G.owner.shape[1] + j
        if wp.static(deforming):
            if k < 2 * EXT_SLOTS:
                ext_max[k] = wp.float32(0.0)
        else:
            if flags[FLAG_REBUILD] != 0:
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
        for s in range(G.depth[i, j // COPY_RUN]):  # (whole runs: stores that cover whole sectors)
            G.owner[s * D.layer_rows + i, j] = -1

    return reset_copies


@functools.cache
def make_granular_statistics(precision: str, staged: bool = False):
    """Kernel ``statistics(P, G, D, clock, stats)`` over max(N, nodes of one layer) threads: the
    number of components (released points that are their own label) into stats[0] and the most
    grid layers in use at one node into stats[1], for the diagnostics of an output frame."""
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
