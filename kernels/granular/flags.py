"""The control state of the interaction graph on the device: the named slots of ``Interaction.flags``
(one int32 array, so that the host and a CUDA graph's conditional nodes read single words of it),
of ``Interaction.motion`` and of the statistics, and the sizes and thresholds of the label reuse
(``reuse``) that the search and the checks share."""

import warp as wp

__all__ = [
    "BAND_BINS",
    "BAND_BUDGET",
    "BAND_SAMPLE",
    "CALM_STEPS",
    "EXT_SLOTS",
    "FLAG_ABSOLUTE",
    "FLAG_AGE",
    "FLAG_BAND",
    "FLAG_BINS",
    "FLAG_CALM",
    "FLAG_CHANGED",
    "FLAG_COUNT",
    "FLAG_FLIPPED",
    "FLAG_DEEP",
    "FLAG_FORCED",
    "FLAG_FRESH",
    "FLAG_MEASURED",
    "FLAG_RANGE",
    "FLAG_REBUILD",
    "FLAG_RELABEL",
    "FLAG_RELABELS",
    "FLAG_SLOTS",
    "FLAG_SPILLED",
    "FLAG_STAMP",
    "FLAG_STRAYED",
    "FLAG_STREAK",
    "FLAG_WIDE",
    "MOVE_ABSOLUTE",
    "MOVE_CELLS",
    "MOVE_RELATIVE",
    "NARROW_GROWTH",
    "NO_MARGIN",
    "PAIR_SLOTS",
    "SAMPLE_SHIFT",
    "STAT_COMPONENTS",
    "STAT_LAYERS",
    "STATUS_DEEP_CLAIM",
    "STATUS_LAYER_OVERFLOW",
    "STATUS_SLOTS",
    "STREAK_MAX",
    "STREAK_START",
    "WIDE_STEPS",
    "bin_vec",
]

#: Status counters (after the two of ``reductions``).
STATUS_LAYER_OVERFLOW = 2
#: 1 when a claim of this step took a copy past half a node's layers. Relabels keep the copies
#: between rebuilds (a point claims anew where its label or node range changed, and its old
#: component's copies stay claimed, empty): ``check`` then asks for a relabel that frees them
#: (FLAG_FRESH) before they can fill a node (a discharging silo's falling grains change labels at
#: nearly every step).
STATUS_DEEP_CLAIM = 3
#: Length of the MPM stage's status array.
STATUS_SLOTS = 4

#: The largest extent of deforming domains, the margins and the moves are reduced into this many
#: slots (point p uses slot p % EXT_SLOTS, and only when it beats the slot): no million atomics on
#: one address, and few loads for ``judge``, one thread on the critical path of every step, to reduce
#: (8 against 32 was faster on every scene: docs/benchmarks.md, "Tuning constants and their measured
#: reasons").
EXT_SLOTS = 8

# Slots of ``Interaction.motion`` (each reduced over EXT_SLOTS slots), in quanta (rounded up), the
# largest over the steps since the last rebuild (zeroed only by ``reset_search``): never less than
# the current ones, so the bounds stay safe, and a point that does not beat its slot's running
# maximum (most of them, once a body moves) costs ``check`` no atomic.
#: max |Δx_p| since the last rebuild.
MOVE_ABSOLUTE = 0
#: max |Δx_p − Δx_ref(p)|: the moves relative to the reference point of the point's cell.
MOVE_RELATIVE = 1
#: max |Δx_ref(c) − Δx_ref(c')| over cells c, c' within the search reach.
MOVE_CELLS = 2

# Slots of ``Interaction.flags``. The next step's verdict is set by ``judge`` at the end of a step,
# or by the host (first step, after a reorder or a checkpoint); ``check`` writes what it found.
#: 1 when the next step rebuilds the interaction graph.
FLAG_REBUILD = 0
#: Rebuilds so far.
FLAG_COUNT = 1
#: 1 when ``check`` found a node range changed (a rebuild).
FLAG_RANGE = 2
#: 1 when ``check`` found a listed pair flipped or a point in another cell (a relabel).
FLAG_CHANGED = 3
#: Consecutive steps whose check asked for a rebuild.
FLAG_STREAK = 4
#: Steps left that rebuild without a check (a streak of rebuilds: see STREAK_START).
FLAG_FORCED = 5
#: 1 when the next step labels the components anew (every rebuild; a relabel through ``relink``).
FLAG_RELABEL = 6
#: Relabels without a rebuild so far.
FLAG_RELABELS = 7
#: 1 while the rebuilds list pairs within a wide band (a streak of rebuilds: see WIDE_STEPS).
FLAG_WIDE = 8
#: Consecutive steps that kept everything while wide.
FLAG_CALM = 9
#: The band [quanta] of the next rebuild's pair lists.
FLAG_BAND = 10
#: Steps since the last rebuild.
FLAG_AGE = 11
#: Pairs the last rebuild listed in ``Interaction.spill`` (may exceed its size).
FLAG_SPILLED = 12
#: 1 when this step's ``relink`` found a listed pair flipped.
FLAG_FLIPPED = 13
#: 1 once a relabel since the last rebuild took a point in another cell (``Interaction.home``).
FLAG_STRAYED = 14
#: First of BAND_BINS slots: the sampled pairs of the last rebuild just outside its band (see BAND_SAMPLE).
FLAG_BINS = 15
#: 1 when the last rebuild filled FLAG_BINS (a narrow rebuild that kept margins).
FLAG_MEASURED = 23
#: 1 when ``check`` keeps the absolute moves alone until the next rebuild (see ``judge``).
FLAG_ABSOLUTE = 24
#: Labellings so far (``judge``): ``label`` marks the cells whose labels changed with it (S.dirty).
FLAG_STAMP = 25
#: 1 when ``check`` found a claim of this step past half a node's layers (``STATUS_DEEP_CLAIM``).
FLAG_DEEP = 26
#: 1 when the next step's relabel frees every copy and every point claims anew, as a rebuild does
#: (``judge``, after FLAG_DEEP): the copies the relabels kept for labels that moved on are gone.
FLAG_FRESH = 27
#: Length of ``Interaction.flags``.
FLAG_SLOTS = 28

#: Pairs a point lists (``Interaction.pairs``): the overlap tests of a rebuild that were within the
#: band of flipping; those past it go to one list for all (``Interaction.spill``), and past its
#: size they count in the margin instead. Eight hold the half neighbourhood of a point in a dense
#: flow with two by two points a cell (about four pairs each, up to seven), where every pair is
#: near flipping.
PAIR_SLOTS = 8

# A scene whose checks ask for a rebuild STREAK_START steps in a row (a dispersed flow, whose
# points change cells and meet at every step) first widens the band of its pair lists
# (``FLAG_WIDE``): each rebuild lists the pairs within WIDE_STEPS times the growth per step of the
# smaller bound on the pairs' moves since the last rebuild (see ``judge``; at least the narrow band,
# at most ``band_cap``), so the lists last about WIDE_STEPS steps, and the steps between relabel
# over them instead of rebuilding. CALM_STEPS steps in a row that keep everything end it (a narrow
# rebuild). If the checks still ask for a rebuild STREAK_START steps in a row, the scene stops
# checking: the next ``min(streak, STREAK_MAX)`` steps rebuild without one, then a check decides
# again. A rebuild and a relabel are always exact, so none of this changes a result, only what a
# step costs.
#: Rebuilds in a row that widen the band, then stop the checks.
STREAK_START = 8
#: The most steps that rebuild without a check.
STREAK_MAX = 32
#: Steps the wide lists last (16 and 32 equal, 8 slower at 1M points: docs/benchmarks.md, "Tuning
#: constants and their measured reasons").
WIDE_STEPS = 16
#: Steps in a row that keep everything and end the wide lists.
CALM_STEPS = 8

# The narrow band follows the scene (``judge``). A rebuild that lists with the narrow band also
# counts, over one point in BAND_SAMPLE (pseudo-random, ``priority``), the pairs it left out of
# the lists whose overlap test is within 2^(k/4) to 2^((k+1)/4) times the band of flipping (bin
# k < BAND_BINS: quarter octaves). The next narrow rebuild widens the band by as many quarter
# octaves as keep the lists, estimated from those counts, within 1/BAND_BUDGET of the spill list,
# with one more quarter octave to spare (the pairs just outside a band drift into it); it halves
# the band when the lists outgrew twice that. A wider band lists more pairs (tested at every
# check) and leaves the margin of all the others wider. A dense body settling under gravity, whose
# neighbours overlap by 0.17 % of a cell (the paper's ρ_cr) and whose pairs across the load drift
# towards parting, kept its margin at the narrow band itself and rebuilt every ~10 steps (CPU,
# 262k points, 200 steps: 11 rebuilds with the fixed band, 5 with 2^-9.5 cells, 27 with 2^-9,
# past the overlap, which lists every pair).
#: A point counts for the band when the top 32 − SAMPLE_SHIFT bits of its ``priority`` are zero.
SAMPLE_SHIFT = 28
#: One point in BAND_SAMPLE counts the pairs just outside the band.
BAND_SAMPLE = 1 << (32 - SAMPLE_SHIFT)
#: Quarter octaves counted above the band.
BAND_BINS = 8
#: The narrow lists aim at 1/BAND_BUDGET of the spill list.
BAND_BUDGET = 4
#: The narrow band grows to at most NARROW_GROWTH times its least: a dispersed flow, whose pairs are
#: far from flipping, would widen it at every rebuild and put off the wide lists it needs (CPU, 16k
#: points of the dispersed cloud, first 100 steps: 19 rebuilds uncapped, 13 with the fixed band).
NARROW_GROWTH = 16
#: The BAND_BINS counts of one thread, in registers.
bin_vec = wp.types.vector(length=BAND_BINS, dtype=wp.int32)
#: A margin that nothing limits (no pair, no pruned window), in quanta (``Interaction.quantum``):
#: margins are reduced as integers, whose atomic minimum is native (a float one is a CAS loop, slow
#: when a million threads meet on a few slots).
NO_MARGIN = 2147483647

#: Slot of the per-step statistics array: the number of components.
STAT_COMPONENTS = 0
#: Slot of the per-step statistics array: the most grid layers in use at one node.
STAT_LAYERS = 1
