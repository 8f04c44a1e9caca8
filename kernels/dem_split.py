"""The DEM pair search split over candidate vertices (large scenes on CUDA): the same touches, forces
and history as ``dem_contacts``' ``contact_forces``, to the bit, found by three kernels instead of one.

``contact_forces`` gives each listed pair one thread, which tests in turn every vertex of either
core that lies within the other body's bounding circle against all the other's features (~34
feature tests for two touching pentagons). The pairs of a warp need different numbers of tests,
so most lanes wait (8.7 of 32 active at 100k pentagons). Split:

1. ``candidates`` (threads striding over the listed pairs): the pair's bounding circles, then each
   vertex's circle test; the vertices that pass are packed into one list (``Split.candidate``),
   one atomic a block (``scan.block_append``: a million appends on one counter queued for 0.5 ms).
2. ``search`` (threads striding over that list): one vertex's feature tests, as in
   ``search_pair``; each touch is recorded for its pair (feature, normal, distance).
3. ``assemble`` (threads striding over the listed pairs): the pair's touches in the order ``search_pair`` meets
   them (side, vertex, feature), each through the same ``add_touch``: forces, torques, history.

A pair whose touches or candidates do not fit the records (more than ``hits`` touches, the
candidate list full, or past ``pairs`` listed pairs) is searched whole by ``assemble`` with
``search_pair``: every result is the one of ``contact_forces``.
"""

import functools

import warp as wp

from .clock import CLOCK_DT
from .dem_bodies import make_dem_structs
from .dem_contacts import make_dem_contacts
from .scan import block_append
from .types import Namespace, kernel, scalar_types

__all__ = ["MAX_VERTICES", "make_split_search"]

#: Vertices of a core the split search takes (5 bits of a candidate's code); scenes with more
#: keep ``contact_forces``.
MAX_VERTICES = 31
_VERTEX_BITS = 5
_FEATURE_BITS = 6  # features of a vertex's search: at most 2 × 31 + 1 < 64


@functools.cache
def make_split_search(precision: str, hits: int, assemble_registers: int | None = None):
    """Struct ``Split`` and kernels ``candidates``, ``search``, ``assemble`` for one precision;
    ``hits`` touches recorded per pair (more: that pair is searched whole; two pentagons touch at
    1-2 spots, face on face at up to 4; the stage passes ``Tuning.split_hits_per_pair``);
    ``assemble`` built with at most ``assemble_registers`` registers per thread on CUDA (None: the
    compiler's choice)."""
    t = scalar_types(precision)
    T = t.scalar
    vec2 = t.vec2
    Bodies, Contacts, Params = make_dem_structs(precision)
    dem = make_dem_contacts(precision, False)
    pair_side, no_touches, vertex_search, add_touch = dem.pair_side, dem.no_touches, dem.vertex_search, dem.add_touch
    search_pair, listed_pair, pair_bodies = dem.search_pair, dem.listed_pair, dem.pair_bodies
    overlapping_circles, store_pair = dem.overlapping_circles, dem.store_pair
    vertex_feature, edge_count = dem.vertex_feature, dem.edge_count
    H = hits

    @wp.struct
    class Split:
        candidate: wp.array(dtype=wp.int32)  # (capacity) q, side, vertex of each candidate vertex
        candidate_count: wp.array(dtype=wp.int32)  # (1) candidates this step (reset by ``assemble``)
        whole: wp.array(dtype=wp.int32)  # (pairs) 1: search pair q whole in ``assemble``
        touches: wp.array(dtype=wp.int32)  # (pairs) touches recorded for pair q
        code: wp.array(dtype=wp.int32)  # (pairs * hits) side, vertex, loop index and feature of a touch
        normal: wp.array(dtype=vec2)  # (pairs * hits) N of the touch
        distance: wp.array(dtype=T)  # (pairs * hits) d of the touch [m]
        pairs: int  # listed pairs with records

    @wp.func
    def order_of(code: int):
        """The position of a touch in ``search_pair``'s order: side, vertex, then loop index."""
        return code >> _FEATURE_BITS

    @kernel
    def candidates(B: Bodies, C: Contacts, world: wp.array(dtype=vec2), S: Split, count: wp.array(dtype=wp.int32),
                   threads: int):
        """Listed pairs tid, tid + threads, ... (``threads`` launched, whole blocks): each pair's
        vertices within the other body's bounding circle, packed as candidates (q, side, vertex)
        into ``S.candidate`` with one atomic a block on ``count`` (``S.candidate_count``:
        ``block_append``); its touches reset."""
        listed = C.total[0]
        for r in range((listed + threads - 1) // threads):  # (the same rounds for every thread of a block)
            q = r * threads + wp.tid()
            tid = int(-1)
            if q < listed and q < S.pairs:
                tid = listed_pair(C, q)
            near0 = int(0)  # bit k: vertex k of side 0 (of side 1 in near1) is a candidate
            near1 = int(0)
            n = int(0)
            if tid >= 0:
                S.touches[q] = 0
                S.whole[q] = 0
                i = tid // C.slots
                j = C.nbr[tid]
                if overlapping_circles(B, i, j):
                    reach = B.radius[i] + B.radius[j]
                    for side in range(2):
                        r_start, r_count, o_start, o_count, c_o, r_o, a_r = pair_side(B, i, j, side)
                        for k in range(r_count):
                            if wp.length(world[r_start + k] - c_o) < r_o + reach:
                                if side == 0:
                                    near0 = near0 | (1 << k)
                                else:
                                    near1 = near1 | (1 << k)
                                n += 1
            c = block_append(count, n)
            for m in range(n):
                # the m-th candidate: the lowest bit left of side 0, then of side 1
                side = int(0)
                bits = near0
                if bits == 0:
                    side = 1
                    bits = near1
                k = int(0)
                while (bits >> k) & 1 == 0:
                    k += 1
                if side == 0:
                    near0 = near0 ^ (1 << k)
                else:
                    near1 = near1 ^ (1 << k)
                if c + m < S.candidate.shape[0]:
                    S.candidate[c + m] = (q << (1 + _VERTEX_BITS)) | (side << _VERTEX_BITS) | k
                else:
                    S.whole[q] = 1

    @kernel
    def search(B: Bodies, C: Contacts, world: wp.array(dtype=vec2), S: Split, threads: int):
        """Candidates tid, tid + threads, ... (``threads`` launched): the vertex's feature tests
        (``search_pair``'s inner loop); each touch recorded for its pair."""
        n = wp.min(S.candidate_count[0], S.candidate.shape[0])
        for c in range(wp.tid(), n, threads):
            code = S.candidate[c]
            q = code >> (1 + _VERTEX_BITS)
            side = (code >> _VERTEX_BITS) & 1
            k = code & ((1 << _VERTEX_BITS) - 1)
            tid = C.pairs[q]
            i = tid // C.slots
            j = C.nbr[tid]
            reach = B.radius[i] + B.radius[j]
            r_start, r_count, o_start, o_count, c_o, r_o, a_r = pair_side(B, i, j, side)
            X = world[r_start + k]
            n_feat, n_corner, inside, best_d, best_f, best_n = vertex_search(side, o_count)
            for f in range(n_feat + n_corner + 1):
                hit, N, d, feature, inside, best_d, best_f, best_n = vertex_feature(
                    X, world, o_start, o_count, f, n_feat, n_corner, reach, r_start, r_count, k,
                    inside, best_d, best_f, best_n)
                if hit:
                    h = wp.atomic_add(S.touches, q, 1)
                    if h < H:
                        at = q * H + h
                        S.code[at] = (((((side << _VERTEX_BITS) | k) << _FEATURE_BITS) | f) << _FEATURE_BITS) | feature
                        S.normal[at] = N
                        S.distance[at] = d

    @wp.func
    def assemble_pair(B: Bodies, C: Contacts, prm: Params, world: wp.array(dtype=vec2), S: Split,
                      clock: wp.array(dtype=wp.float64), status: wp.array(dtype=wp.int32), q: int, tid: int):
        """Listed pair q (slot tid): its recorded touches in ``search_pair``'s order through
        ``add_touch`` (or the whole search, when they did not fit), stored as ``contact_forces``
        stores them."""
        i, j, xi, xj = pair_bodies(B, C, tid)
        keys, slips, energy, lost, fi, ti, fj, tj = no_touches()
        touching = overlapping_circles(B, i, j)
        if touching:
            reach = B.radius[i] + B.radius[j]
            dt = T(clock[CLOCK_DT])
            n = int(H + 1)
            if q < S.pairs:
                n = S.touches[q]
                if S.whole[q] != 0:
                    n = H + 1
            if n > H:
                keys, slips, energy, lost, fi, ti, fj, tj = search_pair(
                    B, C, prm, world, tid, i, j, xi, xj, reach, dt, status)
            else:
                n_hist = int(0)
                done = int(-1)  # the order of the last touch added
                for _m in range(n):
                    # the next touch in search order (n <= hits: a selection among a few)
                    pick = int(-1)
                    for h in range(n):
                        o = order_of(S.code[q * H + h])
                        if o > done and (pick < 0 or o < order_of(S.code[q * H + pick])):
                            pick = h
                    at = q * H + pick
                    code = S.code[at]
                    done = order_of(code)
                    feature = code & ((1 << _FEATURE_BITS) - 1)
                    k = (code >> (2 * _FEATURE_BITS)) & ((1 << _VERTEX_BITS) - 1)
                    side = code >> (2 * _FEATURE_BITS + _VERTEX_BITS)
                    r_start, r_count, o_start, o_count, c_o, r_o, a_r = pair_side(B, i, j, side)
                    keys, slips, n_hist, energy, lost, fi, ti, fj, tj = add_touch(
                        B, C, prm, tid, i, j, side, k, world[r_start + k], S.normal[at], S.distance[at], feature,
                        edge_count(o_count), reach, a_r, dt, xi, xj, keys, slips, n_hist, energy, lost, fi, ti, fj,
                        tj, status)
        store_pair(B, C, tid, i, j, touching, keys, slips, energy, lost, fi, ti, fj, tj)

    @kernel(max_registers=assemble_registers)
    def assemble(B: Bodies, C: Contacts, prm: Params, world: wp.array(dtype=vec2), S: Split,
                 clock: wp.array(dtype=wp.float64), status: wp.array(dtype=wp.int32), threads: int):
        """Listed pairs tid, tid + threads, ... (``threads`` launched): ``assemble_pair``."""
        if wp.tid() == 0:
            S.candidate_count[0] = 0  # (``search`` has read it)
        for q in range(wp.tid(), C.total[0], threads):
            tid = listed_pair(C, q)
            if tid >= 0:
                assemble_pair(B, C, prm, world, S, clock, status, q, tid)

    return Namespace(Split=Split, candidates=candidates, search=search, assemble=assemble)
