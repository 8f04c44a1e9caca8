"""The contact stage of the spheropolygon DEM: its start, the force law of one touch, the search of a
body pair's touches and the kernel that sums them onto both bodies.

Contacts are vertex–edge and vertex–vertex pairs (MPM-SDEM eq. 38–43): every vertex of one body
against every edge of the other and back. To count each touching spot once, a vertex X pairs with
an edge only when its projection falls strictly inside the edge and X is in front of it, and with a
vertex W only when X lies in W's corner (Voronoi) region and W in X's (``vertex_feature`` of
``kernels.contact_geometry``). A touch gives the overlap (eq. 38), the contact point (eq. 41) and the
spring–dashpot force with the Coulomb cap (eq. 43); a pair's forces and torques go to both bodies
(eq. 39–40). One thread per listed pair slot; the tangential history of each touch is kept in the
slot under the touch's feature key.

The pieces of the pair search are returned too: the search split over candidate vertices
(``kernels.dem_split``) and the disk–disk pass (``kernels.dem_disks``) reuse them, so their forces
are the same floats.
"""

import functools

import warp as wp

from .clock import CLOCK_DT
from .contact_geometry import make_contact_geometry, make_history_lookup
from .dem_bodies import HISTORY_SLOTS, KEY_KIND, KEY_VERTEX, STATUS_HISTORY_OVERFLOW, make_dem_structs
from .dem_period import make_dem_period
from .types import Namespace, kernel, scalar_types
from .verlet import make_verlet

__all__ = ["make_dem_contact_forces", "make_dem_contacts"]


@functools.cache
def make_dem_contacts(precision: str, deterministic: bool = False, periodic: bool = False):
    """The start-of-stage kernels, the touch law and the pair-search functions of the DEM for one
    precision (the contact kernel that calls them: ``make_dem_contact_forces``); with ``periodic``
    (x periodic) each pair is computed with its partner's minimum image (``kernels.dem_period``)."""
    t = scalar_types(precision)
    T = t.scalar
    vec2 = t.vec2
    vec4 = t.vec4
    Bodies, Contacts, Params = make_dem_structs(precision)
    needs_rebuild = make_verlet(precision).needs_rebuild
    geometry = make_contact_geometry(precision)
    rotate, cross = geometry.rotate, geometry.cross
    point_velocity, edge_count, vertex_feature = geometry.point_velocity, geometry.edge_count, geometry.vertex_feature
    contact_point, spring_dashpot = geometry.contact_point, geometry.spring_dashpot
    find_slip = make_history_lookup(precision, HISTORY_SLOTS)
    period = make_dem_period(precision)
    in_corner, image, needs_rebuild_image = geometry.in_corner, period.image, period.needs_rebuild_image

    # -- the start of the stage ----------------------------------------------------------------
    @kernel
    def start_contacts(B: Bodies, local: wp.array(dtype=vec2), owner: wp.array(dtype=wp.int32),
                       world: wp.array(dtype=vec2), prm: Params, flags: wp.array(dtype=wp.int32),
                       vertices: int, clear: int, moving: int):
        """The start of a step's contact stage, one launch over max(vertices, clear) threads (a small
        scene's step is paid per launch): thread k places world vertex k < ``vertices`` of the
        moving bodies (x_b + R(θ_b) local, their vertices first), clears body k < ``clear``'s
        force and torque of this step (fixed bodies collect the points' reactions as their load),
        and flags a list rebuild when moving body k < ``moving`` moved or turned more than half
        the skin since the last build. The three touch disjoint arrays."""
        k = wp.tid()
        if k < vertices:
            b = owner[k]
            world[k] = B.x[b] + rotate(B.angle[b], local[k])
        if k < clear:
            B.force[k] = vec2()
            B.torque[k] = T(0.0)
        if k < moving:
            if wp.static(periodic):
                if needs_rebuild_image(B, k, prm.skin, prm):
                    flags[0] = 1
            elif needs_rebuild(B, k, B.x_ref, B.angle_ref, prm.skin):
                flags[0] = 1

    @kernel
    def clear_loads(B: Bodies):
        """Body i's contact force [N/m] and torque [N m/m] of this step cleared: the start of the
        contact stage where nothing moves (fixed bodies under points), a launch with one struct
        parameter (``start_contacts``'s longer list cost normal-force 1 µs a step on an H100)."""
        i = wp.tid()
        B.force[i] = vec2()
        B.torque[i] = T(0.0)

    # -- contact forces (MPM-SDEM eq. 38-43) ------------------------------------------------------
    @wp.func
    def touch_force(B: Bodies, prm: Params, i: int, j: int, side: int, X: vec2, N: vec2, d: T, reach: T, a_r: T,
                    slip0: T, dt: T):
        """The force on body i [N/m] of one touching vertex X (a vertex of i on side 0, of j on side
        1, of sphero radius a_r [m]) at distance d along N (from the other core towards X), with the
        tangential stretch δ_t = slip0 [m] of the last step: overlap eq. 38, contact point eq. 41 (in
        the middle of the overlap), spring–dashpot and Coulomb cap eq. 43. Returns (F on i, contact
        point p [m], δ_t, stored energy, dissipated work). The bodies' velocities and masses are read
        here, at a touch, and not held through the feature search (registers: ``mpmdem.sim.dem``). The
        vertex–edge search (``vertex_contact``) and the disk–disk pass (``kernels.dem_disks``) share it."""
        delta, p = contact_point(X, N, d, reach, a_r)
        xi = B.x[i]
        xj = B.x[j]
        if wp.static(periodic):  # (X, and so p, in i's frame: j's image nearest i)
            xj = xj + image(xi, xj, prm)
        vel = point_velocity(B.v[i], B.omega[i], p - xi) - point_velocity(B.v[j], B.omega[j], p - xj)
        if side == 1:
            vel = -vel
        # normal dashpot with the effective mass of the two bodies at p along N, rotation included
        # (1/m + (r×N)²/I each), so that ζ, and so e, hold for off-centre impacts too
        lever_i = cross(p - xi, N)
        lever_j = cross(p - xj, N)
        inv_eff = (B.inv_mass[i] + B.inv_inertia[i] * lever_i * lever_i + B.inv_mass[j]
                   + B.inv_inertia[j] * lever_j * lever_j)
        mu = wp.min(B.friction[i], B.friction[j])
        F, slip, e_pair, lost_pair = spring_dashpot(prm.law.kn, prm.law.kt, prm.law.zeta, mu, delta, vel, N, inv_eff,
                                                    slip0, dt)
        if side == 1:
            F = -F  # force on i
        return F, p, slip, e_pair, lost_pair

    @wp.func
    def vertex_contact(B: Bodies, C: Contacts, prm: Params, tid: int, i: int, j: int, side: int, X: vec2, N: vec2,
                       d: T, reach: T, a_r: T, key: int, dt: T):
        """``touch_force`` of one touching vertex X of pair slot ``tid`` (bodies i, j), its δ_t of the
        last step looked up under the feature ``key`` in the pair's history."""
        return touch_force(B, prm, i, j, side, X, N, d, reach, a_r, find_slip(C.key[tid], C.slip[tid], key), dt)

    @wp.func
    def pair_side(B: Bodies, i: int, j: int, side: int):
        """The search of one side of pair (i, j): side 0 the vertices of i against the core of j,
        side 1 those of j against i. Returns (first vertex and count of the searching core, first
        vertex and count of the other, the other's centroid [m] and core radius [m], the searching
        body's sphero radius a [m])."""
        if side == 0:
            return B.vstart[i], B.vcount[i], B.vstart[j], B.vcount[j], B.x[j], B.core_radius[j], B.radius[i]
        return B.vstart[j], B.vcount[j], B.vstart[i], B.vcount[i], B.x[i], B.core_radius[i], B.radius[j]

    @wp.func
    def corner_count(side: int, o_count: int):
        """Corners of the other core a vertex is tested against: its vertices on side 0, none on side 1
        (a vertex–vertex contact is found once)."""
        n = int(0)
        if side == 0:
            n = o_count
        return n

    @wp.func
    def no_touches():
        """The sums of a pair before its first touch: (history keys, δ_t, energy, dissipated work,
        force and torque on i, force and torque on j)."""
        return wp.vec4i(-1, -1, -1, -1), vec4(), T(0.0), wp.vec2d(0.0, 0.0), vec2(), T(0.0), vec2(), T(0.0)

    @wp.func
    def vertex_search(side: int, o_count: int):
        """The start of one vertex's feature search against a core of ``o_count`` vertices: (edges,
        corners, and the last pass's state for ``vertex_feature``: inside, best_d, best_f, best_n)."""
        return edge_count(o_count), corner_count(side, o_count), o_count >= 3, T(-1.0e30), int(-1), vec2()

    @wp.func
    def add_touch(B: Bodies, C: Contacts, prm: Params, tid: int, i: int, j: int, side: int, k: int, X: vec2,
                  N: vec2, d: T, feature: int, n_feat: int, reach: T, a_r: T, dt: T, xi: vec2, xj: vec2,
                  keys: wp.vec4i, slips: vec4, n_hist: int, energy: T, lost: wp.vec2d, fi: vec2, ti: T,
                  fj: vec2, tj: T, status: wp.array(dtype=wp.int32)):
        """One touch of pair slot ``tid`` (``vertex_feature``'s hit of vertex k on ``side``) added to the
        pair's sums: its feature key and δ_t into the history, its energy and dissipated work, its
        force and torques on i and j (eq. 39-40). Returns the sums."""
        # key of the feature: vertex k against an edge (kind = side) or a corner (2)
        kind = side
        if feature >= n_feat:
            kind = 2
            feature = feature - n_feat
        key = kind * KEY_KIND + k * KEY_VERTEX + feature
        F, p, slip, e_pair, lost_pair = vertex_contact(B, C, prm, tid, i, j, side, X, N, d, reach, a_r, key, dt)
        lost = lost + lost_pair
        energy += e_pair
        if n_hist < wp.static(HISTORY_SLOTS):
            keys[n_hist] = key
            slips[n_hist] = slip
            n_hist += 1
        else:
            wp.atomic_add(status, STATUS_HISTORY_OVERFLOW, 1)
        fi += F
        ti += cross(p - xi, F)
        fj -= F
        tj -= cross(p - xj, F)
        return keys, slips, n_hist, energy, lost, fi, ti, fj, tj

    @wp.func
    def shifted_feature(X: vec2, world: wp.array(dtype=vec2), start: int, count: int, f: int, n_edges: int,
                        n_corners: int, reach: T, own_start: int, own_count: int, own_k: int, inside: bool,
                        best_d: T, best_f: int, best_n: vec2, own_shift: vec2):
        """``vertex_feature`` of a vertex X given in the other core's frame, whose own core is
        ``own_shift`` [m] away (periodic x): a corner's second test (W in the corner region of X's own
        vertex) takes W into X's own frame; edges and the last pass are ``vertex_feature``'s."""
        if f >= n_edges and f < n_edges + n_corners:
            w = f - n_edges
            W = world[start + w]
            D = X - W
            d = wp.length(D)
            hit = False
            N = vec2()
            if d < reach and d > T(1.0e-12) * reach:
                if in_corner(X, world, start, count, w) and in_corner(W + own_shift, world, own_start, own_count,
                                                                      own_k):
                    N = D / d
                    hit = True
            return hit, N, d, f, inside, best_d, best_f, best_n
        return vertex_feature(X, world, start, count, f, n_edges, n_corners, reach, own_start, own_count, own_k,
                              inside, best_d, best_f, best_n)

    @wp.func
    def search_pair(B: Bodies, C: Contacts, prm: Params, world: wp.array(dtype=vec2), tid: int, i: int, j: int,
                    xi: vec2, xj: vec2, reach: T, dt: T, status: wp.array(dtype=wp.int32)):
        """Every touch of the pair in slot ``tid`` (bodies i, j), searched in turn: each vertex of
        either core within the other's bounding circle against the other's features. Returns the
        history (keys, δ_t), energy, dissipated work and the forces and torques on i and j. Periodic
        x: j's image nearest i (shift s); a vertex is searched in the other core's frame (side 0: X − s,
        side 1: X + s) and its touch computed in i's frame."""
        keys, slips, energy, lost, fi, ti, fj, tj = no_touches()
        n_hist = int(0)
        xj_i = xj
        if wp.static(periodic):
            s = image(xi, xj, prm)
            xj_i = xj + s
        sides = int(2)  # (a loop, not unrolled: one copy of the search in registers)
        for side in range(sides):
            r_start, r_count, o_start, o_count, c_o, r_o, a_r = pair_side(B, i, j, side)
            for k in range(r_count):
                X = world[r_start + k]
                Xs = X  # (in the other core's frame)
                if wp.static(periodic):
                    own_shift = s  # (from the other core's frame to X's own)
                    if side == 1:
                        own_shift = -s
                    Xs = X - own_shift
                    if side == 1:
                        X = Xs
                if wp.length(Xs - c_o) >= r_o + reach:
                    continue
                # candidate features of the other body: its edges when it has any, then (side 0
                # only) its vertices as corners, then the pass for a vertex gone inside its core
                n_feat, n_corner, inside, best_d, best_f, best_n = vertex_search(side, o_count)
                for f in range(n_feat + n_corner + 1):
                    if wp.static(periodic):
                        hit, N, d, feature, inside, best_d, best_f, best_n = shifted_feature(
                            Xs, world, o_start, o_count, f, n_feat, n_corner, reach, r_start, r_count, k,
                            inside, best_d, best_f, best_n, own_shift)
                    else:
                        hit, N, d, feature, inside, best_d, best_f, best_n = vertex_feature(
                            X, world, o_start, o_count, f, n_feat, n_corner, reach, r_start, r_count, k,
                            inside, best_d, best_f, best_n)
                    if hit:
                        keys, slips, n_hist, energy, lost, fi, ti, fj, tj = add_touch(
                            B, C, prm, tid, i, j, side, k, X, N, d, feature, n_feat, reach, a_r, dt, xi, xj_i,
                            keys, slips, n_hist, energy, lost, fi, ti, fj, tj, status)
        return keys, slips, energy, lost, fi, ti, fj, tj

    @wp.func
    def listed_pair(C: Contacts, q: int):
        """The slot of the q-th listed pair (the packed list; slot q itself in deterministic mode),
        −1 past the list."""
        tid = q
        if wp.static(not deterministic):
            if q >= C.total[0]:
                return -1
            tid = C.pairs[q]
        i = tid // C.slots
        if tid - i * C.slots >= C.count[i]:
            return -1
        return tid

    @wp.func
    def pair_bodies(B: Bodies, C: Contacts, tid: int):
        """Bodies i (the owner of slot ``tid``) and j of a listed pair, and their centroids [m]."""
        i = tid // C.slots
        j = C.nbr[tid]
        return i, j, B.x[i], B.x[j]

    @wp.func
    def overlapping_circles(B: Bodies, i: int, j: int):
        """Whether the bounding circles of bodies i and j overlap: only then can they touch."""
        return wp.length(B.x[j] - B.x[i]) < B.core_radius[i] + B.core_radius[j] + (B.radius[i] + B.radius[j])

    @wp.func
    def overlapping_images(B: Bodies, prm: Params, i: int, j: int):
        """``overlapping_circles`` with j's image nearest i (periodic x)."""
        xi = B.x[i]
        xj = B.x[j]
        D = xj + image(xi, xj, prm) - xi
        return wp.length(D) < B.core_radius[i] + B.core_radius[j] + (B.radius[i] + B.radius[j])

    @wp.func
    def store_pair(B: Bodies, C: Contacts, tid: int, i: int, j: int, touching: bool, keys: wp.vec4i, slips: vec4,
                   energy: T, lost: wp.vec2d, fi: vec2, ti: T, fj: vec2, tj: T):
        """The pair's forces and torques added to both bodies (when their circles overlap), its history,
        energy and dissipated work stored."""
        if touching:
            wp.atomic_add(B.force, i, fi)
            wp.atomic_add(B.torque, i, ti)
            wp.atomic_add(B.force, j, fj)
            wp.atomic_add(B.torque, j, tj)
        C.key[tid] = keys
        C.slip[tid] = slips
        C.energy[tid] = energy
        C.dissipated[tid] = C.dissipated[tid] + lost

    return Namespace(
        start_contacts=start_contacts, clear_loads=clear_loads, touch_force=touch_force, cross=cross,
        # the pieces of the pair search, for the search split over candidate vertices (kernels/dem_split.py)
        pair_side=pair_side, no_touches=no_touches, vertex_search=vertex_search, add_touch=add_touch,
        search_pair=search_pair, pair_bodies=pair_bodies,
        listed_pair=listed_pair, overlapping_circles=overlapping_circles, overlapping_images=overlapping_images,
        store_pair=store_pair,
        vertex_feature=vertex_feature, edge_count=edge_count,
    )


@functools.cache
def make_dem_contact_forces(precision: str, deterministic: bool = False, max_registers: int | None = None,
                            disk_pairs: bool = False, periodic: bool = False):
    """The contact kernel of the DEM for one precision: forces and torques of the listed pairs
    (eq. 39–40), with at most ``max_registers`` registers per thread on CUDA (None: the compiler's
    choice, which the stage uses; capped builds are for ``bench/kernel_registers.py``); with
    ``disk_pairs`` it leaves the pairs of two bodies flagged ``B.disk`` to the disk–disk pass
    (``kernels.dem_disks``); ``periodic``: x periodic, pairs with their minimum image."""
    pieces = make_dem_contacts(precision, deterministic, periodic)
    T = scalar_types(precision).scalar
    vec2 = scalar_types(precision).vec2
    Bodies, Contacts, Params = make_dem_structs(precision)
    listed_pair, pair_bodies, no_touches = pieces.listed_pair, pieces.pair_bodies, pieces.no_touches
    overlapping_circles, search_pair, store_pair = pieces.overlapping_circles, pieces.search_pair, pieces.store_pair
    overlapping_images = pieces.overlapping_images

    @kernel(deterministic=deterministic, max_registers=max_registers)
    def contact_forces(B: Bodies, C: Contacts, prm: Params, world: wp.array(dtype=vec2),
                       clock: wp.array(dtype=wp.float64), status: wp.array(dtype=wp.int32)):
        """Forces and torques of one listed pair, added to both bodies (eq. 39-40)."""
        tid = listed_pair(C, wp.tid())
        if tid < 0:
            return
        i, j, xi, xj = pair_bodies(B, C, tid)
        if wp.static(disk_pairs):
            if B.disk[i] != 0 and B.disk[j] != 0:
                return
        keys, slips, energy, lost, fi, ti, fj, tj = no_touches()
        if wp.static(periodic):
            touching = overlapping_images(B, prm, i, j)
        else:
            touching = overlapping_circles(B, i, j)
        if touching:
            keys, slips, energy, lost, fi, ti, fj, tj = search_pair(
                B, C, prm, world, tid, i, j, xi, xj, B.radius[i] + B.radius[j], T(clock[CLOCK_DT]), status)
        store_pair(B, C, tid, i, j, touching, keys, slips, energy, lost, fi, ti, fj, tj)

    return contact_forces
