"""The overlap tests of single pairs between rebuilds: the listed pairs (``Interaction.pairs`` and
``spill``, stored as codes q or −q − 1) tested again with today's positions, the pre-task of a pair
from the stored node ranges, and lengths in the integer quanta that margins and moves are reduced in."""

import functools
from typing import NamedTuple

import warp as wp

from ..state import make_state_structs
from ..types import scalar_types
from .cells import make_cells
from .flags import NO_MARGIN
from .interaction import make_interaction_struct
from .unionfind import unite

__all__ = ["Pairs", "make_pairs"]


class Pairs(NamedTuple):
    """The pair tests of one variant (``make_pairs``)."""

    quanta: wp.Function  # (length, S, up) -> whole quanta, capped at NO_MARGIN
    share: wp.Function  # (S, p, q) -> whether two points whose domains overlap share a node
    joined_with: wp.Function  # (xp, ep, P, S, q) -> the overlap test of (p, q), p's position and extents given
    joined_now: wp.Function  # (P, S, p, q) -> the overlap test of (p, q) with today's positions
    spilled: wp.Function  # (spill entry) -> (p, code of q)
    relist: wp.Function  # (P, S, p, xp, ep, code, root) -> (today's code, an ancestor of p): merges if joined
    flips: wp.Function  # (P, S, p, code) -> whether the test differs from the last labelling's


@functools.cache
def make_pairs(shape: str, precision: str, staged: bool = False) -> Pairs:
    """The pair tests for a shape function (``Pairs``)."""
    t = scalar_types(precision)
    T = t.scalar
    Particles, Grid, Domain = make_state_structs(precision)
    Interaction = make_interaction_struct(precision)
    tent_cells = make_cells(shape, precision, staged).tent_cells

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
    def share(S: Interaction, p: int, q: int):
        # whether two points whose domains overlap share a node (the pre-task): always for the tent
        # (in one cell's reach at a rebuild; or, with S.moves, overlapping domains under half a cell,
        # which is also why the others' stored ranges, updated by ``check`` with S.moves, answer right)
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
            if S.moves != 0 or share(S, p, q):  # (with S.moves overlapping domains share a node)
                ancestor = unite(S.parent, root, q)
        return now, ancestor

    @wp.func
    def flips(P: Particles, S: Interaction, p: int, code: int):
        # whether the overlap test of listed pair (p, q) differs from the one of the last labelling
        q = code
        if code < 0:
            q = -code - 1
        return joined_now(P, S, p, q) != (code >= 0)

    return Pairs(quanta, share, joined_with, joined_now, spilled, relist, flips)
