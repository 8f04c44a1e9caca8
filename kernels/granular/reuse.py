"""Reuse of the labels between rebuilds (a Verlet-style skip, exact): ``check`` after the step's
last G2P and ``judge`` as its last kernel decide whether the next step rebuilds the interaction
graph, relabels over the pair lists, or keeps the labels.

The graph depends on each point's node range (the pre-task) and, for two granular points of a
non-deforming domain, on their distance (task 1). A rebuild records each point's position and node
range, each cell one reference point, and the margin M: the least change of a pair's offset
(max-norm) that would flip an overlap test it made, or let a pair the cell window pruned overlap.
Tests within a band of flipping (``FLAG_BAND``) are listed instead (``Interaction.pairs``,
``spill``) and tested again at every check. The next step rebuilds when a node range changed, or
when neither bound on the change of any pair's offset is below M (less a round-off allowance):
2 max|Δx_p| (absolute moves), or 2 max|Δx_p − Δx_ref(p)| + max|Δx_ref(c) − Δx_ref(c')| (moves
relative to the references: a body that moves as a whole keeps its labels; with
``Interaction.moves`` the pairs the search did not visit are bounded by the absolute moves alone,
against ``moves_margin``). A listed pair that flipped relabels instead; so does a tent point in
another cell where that cannot change the graph (``Interaction.moves``), and a point of another
shape with a new node range there only claims its copies anew. Steps that keep or relabel get
exactly the labels a rebuild would give. The band
follows the scene (``BAND_SAMPLE``), widens in a streak of rebuilds (``FLAG_WIDE``, WIDE_STEPS) and
a scene that still rebuilds at every step skips the check for a while (``FLAG_FORCED``). Deforming
domains (cpGIMP, CPDI) rebuild every step and have neither kernel."""

import functools

import warp as wp

from ..clock import CLOCK_DT, CLOCK_T
from ..reductions import finish_step
from ..state import make_state_structs
from ..types import kernel, scalar_types
from .cells import make_cells
from .domains import make_node_reach
from .flags import (
    BAND_BINS,
    BAND_BUDGET,
    BAND_SAMPLE,
    CALM_STEPS,
    EXT_SLOTS,
    FLAG_ABSOLUTE,
    FLAG_AGE,
    FLAG_BAND,
    FLAG_BINS,
    FLAG_CALM,
    FLAG_CHANGED,
    FLAG_DEEP,
    FLAG_FLIPPED,
    FLAG_FORCED,
    FLAG_FRESH,
    FLAG_MEASURED,
    FLAG_RANGE,
    FLAG_REBUILD,
    FLAG_RELABEL,
    FLAG_SPILLED,
    FLAG_STAMP,
    FLAG_STRAYED,
    FLAG_STREAK,
    FLAG_WIDE,
    MOVE_ABSOLUTE,
    MOVE_CELLS,
    MOVE_RELATIVE,
    NARROW_GROWTH,
    NO_MARGIN,
    STATUS_DEEP_CLAIM,
    STREAK_MAX,
    STREAK_START,
    WIDE_STEPS,
    bin_vec,
)
from .interaction import make_interaction_struct
from .pairs import make_pairs

__all__ = ["CHECK_REGISTERS", "make_check", "make_rebuild_decision"]

#: Registers per thread of ``check`` on CUDA in large scenes (``make_check``): 32 lets a whole block
#: of every warp slot of an SM run at once (the compiler's 40 leave a quarter of them idle, and a
#: 262k-point step a second wave).
CHECK_REGISTERS = 32


@functools.cache
def make_check(shape: str, precision: str, staged: bool = False, capped: bool = True, moves: bool = False):
    """Kernel ``check`` over the points, after the step's last G2P (non-deforming domains; launched as
    in ``make_granular_kernels``): a changed node range asks for a rebuild (with ``Interaction.moves``
    the point claims its copies anew instead), a listed pair flipped or a tent point in another cell
    for a relabel, and the moves since the last rebuild go to
    ``Interaction.motion`` for ``judge``. capped: at CHECK_REGISTERS registers a thread (large scenes,
    where occupancy counts; a small scene's few warps gain from the reference window's loads in
    flight at once). moves: for scenes with ``Interaction.moves``, whose references are compared
    within one cell (the window of the search there) instead of W."""
    t = scalar_types(precision)
    T = t.scalar
    Particles, Grid, Domain = make_state_structs(precision)
    Interaction = make_interaction_struct(precision)
    cells = make_cells(shape, precision, staged)
    W, WINDOW, tent_cells = cells.W, cells.WINDOW, cells.tent_cells
    if moves:
        # (``Interaction.moves``: the search visits one cell around each point, and the pairs
        # farther apart are bounded by the absolute moves against ``moves_margin``)
        W, WINDOW = 1, 2 * 3
    cell_of = cells.cell_of
    pairs = make_pairs(shape, precision, staged)
    quanta, spilled, flips = pairs.quanta, pairs.spilled, pairs.flips
    node_reach = make_node_reach(shape, precision)

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

    @kernel(max_unroll=WINDOW, max_registers=CHECK_REGISTERS if capped else None)
    def check(P: Particles, G: Grid, D: Domain, materials: wp.array(dtype=t.params), S: Interaction,
              status: wp.array(dtype=wp.int32), clock: wp.array(dtype=wp.float64)):
        # after the step's last G2P: whether the next step needs a rebuild (see the module
        # docstring): a new node range rebuilds (with S.moves the point claims anew); the moves since
        # the last rebuild, absolute and relative to the cell's reference point, go to S.motion for
        # ``judge``
        p = wp.tid()
        if p == 0:
            if status[STATUS_DEEP_CLAIM] != 0:
                # a claim of this step went past half a node's layers: the next step's relabel
                # frees the copies the relabels kept (``flags.STATUS_DEEP_CLAIM``, ``judge``)
                status[STATUS_DEEP_CLAIM] = 0
                S.flags[FLAG_DEEP] = 1
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
                if S.moves != 0:
                    # every domain granular and under half a cell: two domains that overlap share a
                    # node whatever their ranges, so the graph does not depend on them and the
                    # labels hold; the point claims its copies at its new nodes in the next P2G (its
                    # layers voided; its stored range is only compared here)
                    S.reach[p] = reach
                    P.slots[p, 0] = -1
                else:
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
                # reach (W cells: every pair that shares a node; one with S.moves) moved relative to it;
                # half the window, (dx, dy) after (0, 0) column-major. The loop is unrolled and its reads take
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

    return check


@functools.cache
def make_rebuild_decision(precision: str):
    """Kernel ``judge(S, clock, steps, max_speed, h, cap, cap_bound)``, one thread, the last of a step, after ``check``
    (non-deforming domains; deforming ones rebuild every step): the next step rebuilds the
    interaction graph if ``check`` found a changed node range, or unless one of the two bounds on
    the change of the pairs' offsets is below the margin of the last rebuild (module docstring); it
    relabels (without a rebuild) if ``check`` found a listed pair flipped or a point in another
    cell. A streak of rebuilds widens the band of the pair lists, then stops the checks for a while
    (STREAK_START, WIDE_STEPS). It clears what ``check`` found, and ends the step on the clock
    (``reductions.finish_step``: t += dt and the next step's dt): one launch for all, on the
    critical path of every step."""
    Interaction = make_interaction_struct(precision)
    T = scalar_types(precision).scalar

    @kernel(max_unroll=3 * EXT_SLOTS)
    def judge(S: Interaction, clock: wp.array(dtype=wp.float64), steps: wp.array(dtype=wp.int64),
              max_speed: wp.array(dtype=wp.float32), h: wp.float64, cap: wp.float64, cap_bound: wp.float64):
        finish_step(clock, steps, max_speed, h, cap, cap_bound)
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
        deep = S.flags[FLAG_DEEP] != 0
        # keep the labels if either bound on the change of every pair's offset is below the margin,
        # with the round-off of the displacements (2 or 4) and of the margin
        absolute = int(0)
        relative = int(0)
        cells = int(0)
        least = int(NO_MARGIN)  # (the margin of the pairs the search visited or pruned)
        for k in range(EXT_SLOTS):
            absolute = wp.max(absolute, S.motion[MOVE_ABSOLUTE * EXT_SLOTS + k])
            relative = wp.max(relative, S.motion[MOVE_RELATIVE * EXT_SLOTS + k])
            cells = wp.max(cells, S.motion[MOVE_CELLS * EXT_SLOTS + k])
            least = wp.min(least, S.slack[k])
        S.flags[FLAG_RANGE] = 0
        S.flags[FLAG_CHANGED] = 0
        S.flags[FLAG_FLIPPED] = 0
        S.flags[FLAG_DEEP] = 0
        S.flags[FLAG_FRESH] = 0  # (a rebuild gives out every copy anew anyway)
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
        # the pairs the search did not visit at all (S.moves: more than a cell apart at the rebuild)
        # need S.moves_margin to meet; the moves relative to the references do not bound them,
        # since ``check`` compares the references of cells within that window only: two clumps that
        # approach each other across a wider gap move rigidly, and only the absolute moves see it
        far = T(2.0) * T(absolute) * q + T(3.0) * S.roundoff < T(S.moves_margin) * q
        keep_absolute = T(2.0) * T(absolute) * q + T(3.0) * S.roundoff < margin and far
        keep_relative = (T(2.0) * T(relative) + T(cells)) * q + T(7.0) * S.roundoff < margin and far
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
        if deep and not rebuild:
            # the copies the relabels kept fill a node: the next relabel frees every copy
            relabel = True
            S.flags[FLAG_FRESH] = 1
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
