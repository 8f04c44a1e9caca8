"""Pair geometry and pair force law of spheropolygon contacts, shared by the DEM and the coupling.

Pure ``@wp.func``s, no arrays written: the body–body contacts (``kernels.dem_contacts``), the point–body
contacts of the identified material points (``kernels.imp_forces``) and brute-force reference
kernels in the tests all call the same functions (as JAX-MD keeps one pure pair law per energy).

A spheropolygon is a core polygon ⊕ a disk of radius a (MPM-SDEM eq. 37); its world vertices sit
in ``world[start : start + count]``, counter-clockwise. A vertex X of radius a_X (a material point:
a disk of radius r_p, eq. 44–45) touches the other core's edge when its projection falls strictly
inside the edge and it is in front of it, and the other core's vertex W when X lies in W's corner
(Voronoi) region and W in X's: for convex cores these regions tile the outside, so a corner resting
on a face is one contact, not three. ``vertex_feature`` is one step of that search over the
features of the other core, in the order edges, corners, then the pass that pushes a vertex which
went inside the core out through its nearest edge.

Per touching feature: overlap ξ = a_X + a_other − d (eq. 38, eq. 44 for a point), contact point in
the middle of the overlap (eq. 41), normal spring–dashpot and tangential spring with history and
the Coulomb cap (eq. 43) in ``spring_dashpot``, whose constants (k_n, k_t, ζ) both stages hold in
one ``ContactLaw`` struct, defined here once.
"""

import functools

import warp as wp

from .types import Namespace, scalar_types

__all__ = ["make_contact_geometry", "make_history_lookup"]


@functools.cache
def make_contact_geometry(precision: str):
    """Geometry and force-law ``@wp.func``s of spheropolygon contacts for one precision, and the
    ``ContactLaw`` struct of the law's constants (eq. 43)."""
    t = scalar_types(precision)
    T = t.scalar
    vec2 = t.vec2

    @wp.struct
    class ContactLaw:
        kn: T  # normal stiffness k_n [N/m per m]
        kt: T  # tangential stiffness k_t [N/m per m]
        zeta: T  # damping ratio ζ of the normal dashpot, from the restitution coefficient

    @wp.func
    def rotate(angle: T, p: vec2):
        c = wp.cos(angle)
        s = wp.sin(angle)
        return vec2(c * p[0] - s * p[1], s * p[0] + c * p[1])

    @wp.func
    def cross(r: vec2, f: vec2):
        return r[0] * f[1] - r[1] * f[0]

    @wp.func
    def spin(w: T, r: vec2):
        # ω × r for ω along z
        return vec2(-w * r[1], w * r[0])

    @wp.func
    def point_velocity(v: vec2, w: T, r: vec2):
        """Velocity of the body point at lever r from the centroid of a body moving with (v, ω)."""
        return v + spin(w, r)

    @wp.func
    def segment_distance(p: vec2, a: vec2, b: vec2):
        e = b - a
        l2 = wp.dot(e, e)
        s = T(0.0)
        if l2 > T(0.0):
            s = wp.clamp(wp.dot(p - a, e) / l2, T(0.0), T(1.0))
        return wp.length(p - (a + s * e))

    @wp.func
    def polygon_distance(p: vec2, world: wp.array(dtype=vec2), start: int, count: int):
        """Distance [m] from p to the core polygon outline (a point for one vertex)."""
        d = wp.length(p - world[start])
        for e in range(count):
            d = wp.min(d, segment_distance(p, world[start + e], world[start + (e + 1) % count]))
        return d

    @wp.func
    def box_distance(p: vec2, world: wp.array(dtype=vec2), start: int, count: int):
        """Distance [m] from p to the bounding box of the core's vertices (0 inside it): never more
        than ``polygon_distance``, since the outline lies in the box; a cheap test before it."""
        lo = world[start]
        hi = lo
        for e in range(1, count):
            w = world[start + e]
            lo = vec2(wp.min(lo[0], w[0]), wp.min(lo[1], w[1]))
            hi = vec2(wp.max(hi[0], w[0]), wp.max(hi[1], w[1]))
        dx = wp.max(wp.max(lo[0] - p[0], p[0] - hi[0]), T(0.0))
        dy = wp.max(wp.max(lo[1] - p[1], p[1] - hi[1]), T(0.0))
        return wp.sqrt(dx * dx + dy * dy)

    @wp.func
    def within_reach(p: vec2, world: wp.array(dtype=vec2), start: int, count: int, reach: T, margin: T):
        """Whether a vertex at p may touch the core at (start, count) with a gap of ``reach`` [m]:
        False only where p is at least reach + margin [m] from the core's outline and beyond one
        of its edge lines by more than the margin. The search (``vertex_feature``) touches an edge
        or a corner only within reach of the outline, and pushes out only a vertex behind every
        edge line of a core of three or more vertices, so it finds no touch where this is False,
        for convex and non-convex cores; the margin covers the round-off between the formulas."""
        gap = wp.length(p - world[start])
        inside = count >= 3
        for e in range(count):
            A = world[start + e]
            C = world[start + (e + 1) % count]
            E = C - A
            gap = wp.min(gap, segment_distance(p, A, C))
            if wp.dot(p - A, vec2(E[1], -E[0])) > margin * wp.length(E):  # (edge_contact's d > margin)
                inside = False
        return inside or gap < reach + margin

    @wp.func
    def in_corner(p: vec2, world: wp.array(dtype=vec2), start: int, count: int, k: int):
        """Is p in the corner region of vertex k: beyond both edges that meet there (always, for
        a core of one vertex: a disk, or a material point)."""
        if count == 1:
            return True
        w = world[start + k]
        nxt = world[start + (k + 1) % count]
        prv = world[start + (k + count - 1) % count]
        return wp.dot(p - w, nxt - w) <= T(0.0) and wp.dot(p - w, prv - w) <= T(0.0)

    @wp.func
    def edge_contact(X: vec2, world: wp.array(dtype=vec2), start: int, count: int, f: int, reach: T):
        """X against edge f of a CCW core: (touching, outward normal N, signed distance d [m]).
        It touches when its projection falls strictly inside the edge and 0 <= d < reach."""
        A = world[start + f]
        E = world[start + (f + 1) % count] - A
        l2 = wp.dot(E, E)
        u = wp.dot(X - A, E) / l2
        N = vec2(E[1], -E[0]) / wp.sqrt(l2)
        d = wp.dot(X - A, N)
        return u > T(0.0) and u < T(1.0) and d >= T(0.0) and d < reach, N, d

    @wp.func
    def edge_count(count: int):
        """Edges of a core of ``count`` vertices that a vertex can touch (none for a disk)."""
        n = int(0)
        if count >= 2:
            n = count
        return n

    @wp.func
    def vertex_feature(X: vec2, world: wp.array(dtype=vec2), start: int, count: int, f: int, n_edges: int,
                       n_corners: int, reach: T, own_start: int, own_count: int, own_k: int, inside: bool,
                       best_d: T, best_f: int, best_n: vec2):
        """Feature f of the search of vertex X (vertex own_k of the core at own_start, own_count;
        own_count = 1 for a disk or a point) against the core at (start, count): f < n_edges its
        edge f, then its vertex f − n_edges as a corner, and f = n_edges + n_corners the last pass.

        A vertex that went past every edge line of a polygon core (a convex core: it is inside)
        still pushes out through the nearest edge, with the overlap reach − d growing on as d turns
        negative: the last pass (too soft a k_n, or too fast an impact, would otherwise let a corner
        tunnel through). ``inside`` (start: count >= 3), ``best_d`` (start: −1e30), ``best_f``
        (start: −1) and ``best_n`` carry that search from one feature to the next.

        Returns (touching, normal N from the other core towards X, distance d [m], the feature
        touched (f, or the nearest edge in the last pass), inside, best_d, best_f, best_n).
        """
        N = vec2()
        d = T(0.0)
        feature = f
        hit = False
        if f < n_edges:
            hit, N, d = edge_contact(X, world, start, count, f, reach)
            if d >= T(0.0):
                inside = False
            elif d > best_d:
                best_d = d
                best_f = f
                best_n = N
        elif f == n_edges + n_corners:
            if inside and best_f >= 0:
                N = best_n
                d = best_d
                feature = best_f
                hit = True
        else:
            w = f - n_edges
            W = world[start + w]
            D = X - W
            d = wp.length(D)
            if d < reach and d > T(1.0e-12) * reach:
                if in_corner(X, world, start, count, w) and in_corner(W, world, own_start, own_count, own_k):
                    N = D / d
                    hit = True
        return hit, N, d, feature, inside, best_d, best_f, best_n

    @wp.func
    def contact_point(X: vec2, N: vec2, d: T, reach: T, a_X: T):
        """Overlap δ = reach − d (eq. 38, eq. 44) of vertex X of sphero radius a_X at distance d along
        N from the other core, and the contact point in the middle of the overlap (eq. 41)."""
        delta = reach - d
        return delta, X - (a_X - T(0.5) * delta) * N

    @wp.func
    def spring_dashpot(kn: T, kt: T, zeta: T, mu: T, delta: T, vel: vec2, N: vec2, inv_eff: T, slip0: T, dt: T):
        """One contact of overlap δ (eq. 38/44) with relative velocity ``vel`` along the normal N:
        force k_n δ − c_n v_n along N, c_n = 2ζ sqrt(k_n m_eff), m_eff = 1/inv_eff; tangential
        spring δ_t = slip0 + v_t dt with the Coulomb cap k_t δ_t ≤ μ k_n δ (eq. 43).
        Returns (force, δ_t, stored energy, (dashpot work, friction work) dissipated this step)."""
        vn = wp.dot(vel, N)
        tan = vec2(-N[1], N[0])
        c_n = T(2.0) * zeta * wp.sqrt(kn / inv_eff)
        fn = kn * delta - c_n * vn
        slip = slip0 + wp.dot(vel, tan) * dt
        ft = -kt * slip
        cap = mu * kn * delta
        lost_friction = wp.float64(0.0)
        if wp.abs(ft) > cap:
            slip_new = wp.sign(slip) * cap / wp.max(kt, T(1.0e-30))
            lost_friction = wp.float64(cap * wp.abs(slip - slip_new))
            slip = slip_new
            ft = -wp.sign(slip) * cap
        # dashpot work over the step, c_n vn v̄n dt, with v̄n ≈ vn + ½ dt fn/m_eff the normal velocity at
        # the middle of the step (the dashpot acts on the lagged half-step velocity vn; vn² dt alone
        # errs by O(ω dt), this by O((ω dt)²))
        lost_damping = wp.float64(c_n * vn * (vn + T(0.5) * dt * fn * inv_eff) * dt)
        energy = T(0.5) * (kn * delta * delta + kt * slip * slip)
        return fn * N + ft * tan, slip, energy, wp.vec2d(lost_damping, lost_friction)

    return Namespace(
        ContactLaw=ContactLaw,
        rotate=rotate, cross=cross, spin=spin, point_velocity=point_velocity, segment_distance=segment_distance,
        polygon_distance=polygon_distance, box_distance=box_distance, within_reach=within_reach,
        in_corner=in_corner, edge_contact=edge_contact,
        edge_count=edge_count,
        vertex_feature=vertex_feature, contact_point=contact_point, spring_dashpot=spring_dashpot,
    )


@functools.cache
def make_history_lookup(precision: str, slots: int):
    """``find_slip(keys, slips, key)``: the tangential stretch δ_t stored under a feature key among
    ``slots`` (key, δ_t) history entries, 0 for a new contact (eq. 43)."""
    t = scalar_types(precision)
    T = t.scalar
    keys_t = wp.types.vector(slots, wp.int32)
    slips_t = wp.types.vector(slots, T)

    @wp.func
    def find_slip(keys: keys_t, slips: slips_t, key: int):
        out = T(0.0)
        for h in range(wp.static(slots)):
            if keys[h] == key:
                out = slips[h]
        return out

    return find_slip
