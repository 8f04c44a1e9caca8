"""The sift of the MPM–DEM coupling's listed points (large scenes): before the force search, the
points near a body this step are packed for the force kernel and the contacts of the others end.

A point may touch a listed body (MPM-SDEM eq. 44) only within its bounding circle, core radius
R + a + r_p, and within reach of its core (``within_reach`` of ``kernels.contact_geometry``). Most
listed points are only within the skin; this light kernel (few registers, full occupancy) does their
reads, so the heavy search (``kernels.imp_forces``) runs only where a contact can be.
"""

import functools

import warp as wp

from .contact_geometry import make_contact_geometry
from .imp_links import make_imp_structs, make_release_gate
from .types import kernel, scalar_types

__all__ = ["make_imp_sift"]


@functools.cache
def make_imp_sift(precision: str, staged: bool = False):
    """Kernel ``sift`` of the coupling for one precision (staged: points before their release time
    are left out)."""
    t = scalar_types(precision)
    T = t.scalar
    vec2 = t.vec2
    Particles, Bodies, Links, _, veci, vec2h = make_imp_structs(precision)
    within_reach = make_contact_geometry(precision).within_reach
    released = make_release_gate(precision, staged)

    @wp.func
    def near_a_body(P: Particles, B: Bodies, L: Links, world: wp.array(dtype=vec2), p: int, n: int):
        """Whether point p may touch one of its n listed bodies (the feature search of ``forces``):
        within its bounding circle (core radius R + a + r_p), then within reach of its core
        (``within_reach``). The margin, 1e-5 (reach + |x_p| + R), is hundreds of times the
        round-off between that test and the search in f32: both subtract the same vertices from
        x_p, and their projections on an edge err by a few ulps of its length (≤ 2R)."""
        X = P.x[p]
        rp = L.radius[p]
        near = bool(False)
        for s in range(n):
            b = L.body[p * L.slots + s]
            reach = B.radius[b] + rp
            R = B.core_radius[b]
            if not near and wp.length(X - B.x[b]) < R + reach:
                near = within_reach(X, world, B.vstart[b], B.vcount[b], reach, T(1.0e-5) * (reach + wp.length(X) + R))
        return near

    @kernel
    def sift(P: Particles, B: Bodies, L: Links, world: wp.array(dtype=vec2), clock: wp.array(dtype=wp.float64)):
        """Large scenes, before ``forces``: of the listed points (``finish_lists``), pack those near
        a body this step into ``L.near`` for the force kernel, and end the contacts of the others
        here, as ``forces`` would (no force, no history; their dissipated work stays). Most listed
        points are only within the skin; this light kernel (few registers, full occupancy) does
        their reads, so the heavy search runs only where a contact can be."""
        k = wp.tid()
        if k >= L.listed_count[0]:
            return
        p = L.listed[k]
        n = L.count[p]
        if not released(P, clock, p):
            n = 0
        if n > 0:
            if near_a_body(P, B, L, world, p, n):
                L.near[wp.atomic_add(L.near_count, 0, 1)] = p
                return
        if L.active[p] != 0:
            # (a pair keeps a history key only where the point touched at the last force pass, which
            # left it active: the keys of the others, most listed points, are not read)
            for s in range(n):
                key = L.key[p * L.slots + s]
                if key[0] != -1 or key[1] != -1:
                    L.key[p * L.slots + s] = veci(-1, -1)
                    L.slip[p * L.slots + s] = vec2h()
            P.fcont[p] = vec2()
            L.energy[p] = T(0.0)
            L.active[p] = 0
            if n > 0:
                L.contact_at[p] = P.x[p]

    return sift
