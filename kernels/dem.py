"""Device code of the spheropolygon DEM: world vertices, list checks, contacts, rigid-body update
(the lists themselves are built in ``kernels.dem_lists``).

A body is a spheropolygon (a core polygon ⊕ a disk of radius a, MPM-SDEM eq. 37) moved as a
rigid body. Contacts are vertex–edge and vertex–vertex pairs (MPM-SDEM eq. 38–43): every vertex
of one body against every edge of the other and back. To count each touching spot once, a vertex
X pairs with an edge only when its projection falls strictly inside the edge and X is in front of
it, and with a vertex W only when X lies in W's corner (Voronoi) region and W in X's: for convex
cores these regions tile the outside, so a corner resting on a face is one contact, not three.

Bodies are stored moving-first (free and kinematic), fixed last; fixed bodies are never
integrated and their world vertices are computed once. Each pair of bodies is listed once, in the
slots of its owner (the lower index of two small bodies, the small one of a small–large pair),
and one thread per slot computes the pair and adds its forces to both bodies.

Tangential history (the δ_t of eq. 43) is kept per vertex–edge contact: each pair slot holds
HISTORY_SLOTS (feature key, δ_t) entries, carried across steps and across list rebuilds.

In scenes with disk grains the pairs of two small sphero-disks (``Bodies.disk``) skip the feature
search: ``kernels.dem_disks`` computes them from the centre distance with the same ``touch_force``
(the kernels here built with ``disk_pairs`` leave them out).
"""

import functools

import warp as wp

from .clock import (
    CLOCK_DT,
    CLOCK_T,
    set_step,
)
from .contact_geometry import make_contact_geometry, make_history_lookup
from .reductions import close_step
from .types import Namespace, kernel, scalar_types

__all__ = ["FREE", "FIXED", "HISTORY_SLOTS", "KINEMATIC", "STATUS_CELL_OVERFLOW", "STATUS_HISTORY_OVERFLOW",
           "STATUS_NEIGHBOR_OVERFLOW", "STATUS_NONFINITE", "STATUS_OUTSIDE", "make_dem_kernels"]

FREE = 0
FIXED = 1
KINEMATIC = 2

#: Tangential-history entries per body pair (active vertex–edge contacts of one pair).
HISTORY_SLOTS = 4

STATUS_NONFINITE = 0
STATUS_OUTSIDE = 1
STATUS_NEIGHBOR_OVERFLOW = 2
STATUS_CELL_OVERFLOW = 3
STATUS_HISTORY_OVERFLOW = 4
STATUS_SIZE = 5

#: Feature keys of a contact: kind * KEY_KIND + vertex * KEY_VERTEX + edge (or partner vertex).
KEY_KIND = 1 << 28
KEY_VERTEX = 1 << 14


@functools.cache
def make_dem_kernels(precision: str, deterministic: bool = False):
    """Structs, functions and kernels of the DEM stage for one precision ("f32" or "f64")."""
    t = scalar_types(precision)
    T = t.scalar
    vec2 = t.vec2
    vec4 = t.vec4
    geometry = make_contact_geometry(precision)
    rotate, cross = geometry.rotate, geometry.cross
    point_velocity, edge_count, vertex_feature = geometry.point_velocity, geometry.edge_count, geometry.vertex_feature
    contact_point, spring_dashpot = geometry.contact_point, geometry.spring_dashpot
    find_slip = make_history_lookup(precision, HISTORY_SLOTS)

    @wp.struct
    class Bodies:
        x: wp.array(dtype=vec2)  # centroid [m]
        angle: wp.array(dtype=T)  # [rad]
        v: wp.array(dtype=vec2)  # [m/s] (half-step velocity of the leapfrog update)
        omega: wp.array(dtype=T)  # [rad/s]
        force: wp.array(dtype=vec2)  # contact force of this step [N/m]
        torque: wp.array(dtype=T)  # contact torque about the centroid [N m/m]
        mass: wp.array(dtype=T)  # [kg/m]
        inertia: wp.array(dtype=T)  # about the centroid [kg m²/m]
        inv_mass: wp.array(dtype=T)  # 0 for fixed and kinematic bodies
        inv_inertia: wp.array(dtype=T)
        radius: wp.array(dtype=T)  # sphero radius a [m]
        core_radius: wp.array(dtype=T)  # max |vertex - centroid| [m]
        friction: wp.array(dtype=T)  # Coulomb μ
        motion: wp.array(dtype=wp.int32)  # FREE, FIXED, KINEMATIC
        vstart: wp.array(dtype=wp.int32)  # first vertex in the vertex arrays
        vcount: wp.array(dtype=wp.int32)
        x_ref: wp.array(dtype=vec2)  # position and angle at the last list build
        angle_ref: wp.array(dtype=T)
        kin_v: wp.array(dtype=vec2)  # prescribed motion of kinematic bodies
        kin_omega: wp.array(dtype=T)
        kin_window: wp.array(dtype=wp.vec2d)  # [t_start, t_end) of the prescribed motion [s]
        work: wp.array(dtype=wp.float64)  # work done on the other bodies by a kinematic one [J/m]
        disk: wp.array(dtype=wp.int32)  # 1: a small sphero-disk whose disk–disk pairs take kernels.dem_disks

    @wp.struct
    class Contacts:
        nbr: wp.array(dtype=wp.int32)  # (bodies * K) partner index of each owned pair, -1 empty
        count: wp.array(dtype=wp.int32)  # (bodies) pairs owned
        key: wp.array(dtype=wp.vec4i)  # (bodies * K) feature keys of the tangential history
        slip: wp.array(dtype=vec4)  # (bodies * K) tangential spring stretch δ_t [m]
        energy: wp.array(dtype=T)  # (bodies * K) elastic energy of the pair's contacts [J/m]
        dissipated: wp.array(dtype=wp.vec2d)  # (bodies * K) damping, friction work since build [J/m]
        body_dissipated: wp.array(dtype=wp.vec2d)  # (bodies) folded in at each rebuild
        old_nbr: wp.array(dtype=wp.int32)
        old_key: wp.array(dtype=wp.vec4i)
        old_slip: wp.array(dtype=vec4)
        pairs: wp.array(dtype=wp.int32)  # listed slots packed at the front (non-deterministic mode)
        total: wp.array(dtype=wp.int32)  # (1) listed pairs
        slots: int  # K

    @wp.struct
    class Params:
        kn: T  # normal stiffness [N/m per m]
        kt: T  # tangential stiffness
        zeta: T  # damping ratio from the restitution coefficient
        skin: T  # Verlet skin [m]
        gravity: vec2
        gravity_ramp: float
        lo: vec2  # domain corners [m]; a free body whose centroid leaves them is an error
        hi: vec2
        cell_origin: vec2  # broad-phase cells
        inv_cell: T
        cells_x: int
        cells_y: int
        cell_cap: int
        moving: int  # bodies [0, moving) are free or kinematic

    # -- contact lists ----------------------------------------------------------------------------
    @wp.func
    def sort_ids(ids: wp.array(dtype=wp.int32), base: int, n: int):
        """Insertion sort of ids[base : base + n] (short lists of neighbour indices)."""
        for a in range(1, n):
            v = ids[base + a]
            b = a - 1
            while b >= 0 and ids[base + b] > v:
                ids[base + b + 1] = ids[base + b]
                b -= 1
            ids[base + b + 1] = v

    @wp.func
    def body_moved(B: Bodies, i: int, x_ref: wp.array(dtype=vec2), angle_ref: wp.array(dtype=T)):
        """Largest displacement [m] of body i's outline since (x_ref, angle_ref): centroid shift plus
        the arc its farthest vertex turned through."""
        return wp.length(B.x[i] - x_ref[i]) + B.core_radius[i] * wp.abs(B.angle[i] - angle_ref[i])

    @wp.func
    def needs_rebuild(B: Bodies, i: int, x_ref: wp.array(dtype=vec2), angle_ref: wp.array(dtype=T), skin: T):
        """Whether body i moved or turned more than half the skin since (x_ref, angle_ref), or went
        non-finite: the Verlet rule of the body–body and the point–body lists."""
        moved = body_moved(B, i, x_ref, angle_ref)
        return moved > T(0.5) * skin or not wp.isfinite(moved)

    @wp.func
    def cell_in(x: vec2, origin: vec2, inv_cell: T, nx: int, ny: int):
        """Cell (cx, cy) of a uniform binning holding x, clamped to the nx × ny cells."""
        cx = wp.clamp(int(wp.floor((x[0] - origin[0]) * inv_cell)), 0, nx - 1)
        cy = wp.clamp(int(wp.floor((x[1] - origin[1]) * inv_cell)), 0, ny - 1)
        return cx, cy

    @wp.func
    def bin_item(cell_count: wp.array(dtype=wp.int32), cell_items: wp.array(dtype=wp.int32), cell: int,
                 cap: int, item: int, status: wp.array(dtype=wp.int32), overflow: int):
        """Item into bin ``cell`` of a uniform binning (``cap`` items a bin); a full bin counts in
        ``status[overflow]``: the body–body and the point–body list builds."""
        s = wp.atomic_add(cell_count, cell, 1)
        if s < cap:
            cell_items[cell * cap + s] = item
        else:
            wp.atomic_add(status, overflow, 1)

    # -- per-step kernels -----------------------------------------------------------------------
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
            if needs_rebuild(B, k, B.x_ref, B.angle_ref, prm.skin):
                flags[0] = 1

    @kernel
    def clear_loads(B: Bodies):
        """Body i's contact force [N/m] and torque [N m/m] of this step cleared: the start of the
        contact stage where nothing moves (fixed bodies under points), a launch with one struct
        parameter (``start_contacts``'s longer list cost normal-force 1 µs a step on an H100)."""
        i = wp.tid()
        B.force[i] = vec2()
        B.torque[i] = T(0.0)

    @kernel
    def clear_cells(flags: wp.array(dtype=wp.int32), cell_count: wp.array(dtype=wp.int32)):
        if flags[0] == 0:
            return
        cell_count[wp.tid()] = 0

    @kernel
    def reset_total(flags: wp.array(dtype=wp.int32), C: Contacts):
        if flags[0] != 0:
            C.total[0] = 0

    @kernel
    def finish_rebuild(flags: wp.array(dtype=wp.int32), rebuilds: wp.array(dtype=wp.int64)):
        if flags[0] != 0:
            rebuilds[0] = rebuilds[0] + wp.int64(1)
        flags[0] = 0

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
        F, slip, e_pair, lost_pair = spring_dashpot(prm.kn, prm.kt, prm.zeta, mu, delta, vel, N, inv_eff, slip0, dt)
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
    def search_pair(B: Bodies, C: Contacts, prm: Params, world: wp.array(dtype=vec2), tid: int, i: int, j: int,
                    xi: vec2, xj: vec2, reach: T, dt: T, status: wp.array(dtype=wp.int32)):
        """Every touch of the pair in slot ``tid`` (bodies i, j), searched in turn: each vertex of
        either core within the other's bounding circle against the other's features. Returns the
        history (keys, δ_t), energy, dissipated work and the forces and torques on i and j."""
        keys, slips, energy, lost, fi, ti, fj, tj = no_touches()
        n_hist = int(0)
        sides = int(2)  # (a loop, not unrolled: one copy of the search in registers)
        for side in range(sides):
            r_start, r_count, o_start, o_count, c_o, r_o, a_r = pair_side(B, i, j, side)
            for k in range(r_count):
                X = world[r_start + k]
                if wp.length(X - c_o) >= r_o + reach:
                    continue
                # candidate features of the other body: its edges when it has any, then (side 0
                # only) its vertices as corners, then the pass for a vertex gone inside its core
                n_feat, n_corner, inside, best_d, best_f, best_n = vertex_search(side, o_count)
                for f in range(n_feat + n_corner + 1):
                    hit, N, d, feature, inside, best_d, best_f, best_n = vertex_feature(
                        X, world, o_start, o_count, f, n_feat, n_corner, reach, r_start, r_count, k,
                        inside, best_d, best_f, best_n)
                    if hit:
                        keys, slips, n_hist, energy, lost, fi, ti, fj, tj = add_touch(
                            B, C, prm, tid, i, j, side, k, X, N, d, feature, n_feat, reach, a_r, dt, xi, xj,
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

    def make_contact_forces(max_registers: int | None = None, disk_pairs: bool = False):
        """The contact kernel with at most ``max_registers`` registers per thread on CUDA (None:
        the compiler's choice, which the stage uses; capped builds are for
        ``bench/kernel_registers.py``); with ``disk_pairs`` it leaves the pairs of two bodies
        flagged ``B.disk`` to the disk–disk pass (``kernels.dem_disks``)."""

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
            touching = overlapping_circles(B, i, j)
            if touching:
                keys, slips, energy, lost, fi, ti, fj, tj = search_pair(
                    B, C, prm, world, tid, i, j, xi, xj, B.radius[i] + B.radius[j], T(clock[CLOCK_DT]), status)
            store_pair(B, C, tid, i, j, touching, keys, slips, energy, lost, fi, ti, fj, tj)

        return contact_forces

    contact_forces = make_contact_forces()

    # -- rigid-body update ----------------------------------------------------------------------
    @kernel
    def integrate(B: Bodies, prm: Params, clock: wp.array(dtype=wp.float64), status: wp.array(dtype=wp.int32)):
        """Semi-implicit Euler (leapfrog with half-step velocities, as the MPM stage, MPM-SDEM
        eq. 17-20): v += dt F/m, x += dt v; the same for ω and the angle (eq. 42)."""
        i = wp.tid()
        dt = T(clock[CLOCK_DT])
        t = clock[CLOCK_T]
        v = B.v[i]
        w = B.omega[i]
        if B.motion[i] == KINEMATIC:
            window = B.kin_window[i]
            v = vec2()
            w = T(0.0)
            if t >= window[0] and t < window[1]:
                v = B.kin_v[i]
                w = B.kin_omega[i]
            # the driven body exerts −F, −τ on the others: their power is −(F·v + τ ω)
            B.work[i] = B.work[i] - wp.float64((wp.dot(B.force[i], v) + B.torque[i] * w) * dt)
        else:
            ramp = float(1.0)
            if prm.gravity_ramp > 0.0:
                ramp = wp.min(float(t) / prm.gravity_ramp, 1.0)
            v = v + dt * (B.inv_mass[i] * B.force[i] + T(ramp) * prm.gravity)
            w = w + dt * B.inv_inertia[i] * B.torque[i]
        x = B.x[i] + dt * v
        B.v[i] = v
        B.omega[i] = w
        B.x[i] = x
        B.angle[i] = B.angle[i] + dt * w
        if not (wp.isfinite(x[0]) and wp.isfinite(x[1]) and wp.isfinite(v[0]) and wp.isfinite(v[1])
                and wp.isfinite(w)):
            wp.atomic_add(status, STATUS_NONFINITE, 1)
        elif B.motion[i] == FREE and (x[0] < prm.lo[0] or x[0] > prm.hi[0] or x[1] < prm.lo[1] or x[1] > prm.hi[1]):
            wp.atomic_add(status, STATUS_OUTSIDE, 1)

    @kernel
    def end_step(clock: wp.array(dtype=wp.float64), steps: wp.array(dtype=wp.int64)):
        """The last launch of a DEM step: t += dt and the step recorded for the host
        (``reductions.close_step``), and the next step's dt set (``clock.set_step``): the fixed dt, or
        the factor × the bound (both set once: they depend on masses and k_n only), split evenly to
        end on t_stop; 0 once the clock has reached t_stop."""
        dt, t, t_stop, fixed, factor, bound_next = close_step(clock, steps)
        set_step(clock, t, t_stop, fixed, factor, bound_next, wp.float64(0.0), wp.float64(0.0))

    # -- diagnostics ----------------------------------------------------------------------------
    @kernel
    def diagnostics(B: Bodies, C: Contacts, prm: Params, out: wp.array(dtype=wp.float64)):
        """Sums of: kinetic, gravity, contact energy, momenta x, y, angular, mass (free bodies),
        damping and friction work dissipated in contacts (all pairs), work of kinematic bodies."""
        i = wp.tid()
        e = wp.float64(0.0)
        lost = C.body_dissipated[i]
        for s in range(C.slots):
            e += wp.float64(C.energy[i * C.slots + s])
            lost = lost + C.dissipated[i * C.slots + s]
        wp.atomic_add(out, 2, e)
        wp.atomic_add(out, 7, lost[0])
        wp.atomic_add(out, 8, lost[1])
        if B.motion[i] != FREE:
            wp.atomic_add(out, 9, B.work[i])
            return
        m = wp.float64(B.mass[i])
        inertia = wp.float64(B.inertia[i])
        vx = wp.float64(B.v[i][0])
        vy = wp.float64(B.v[i][1])
        w = wp.float64(B.omega[i])
        x = wp.float64(B.x[i][0])
        y = wp.float64(B.x[i][1])
        wp.atomic_add(out, 0, wp.float64(0.5) * (m * (vx * vx + vy * vy) + inertia * w * w))
        wp.atomic_add(out, 1, -m * (wp.float64(prm.gravity[0]) * x + wp.float64(prm.gravity[1]) * y))
        wp.atomic_add(out, 3, m * vx)
        wp.atomic_add(out, 4, m * vy)
        wp.atomic_add(out, 5, m * (x * vy - y * vx) + inertia * w)
        wp.atomic_add(out, 6, m)

    return Namespace(
        Bodies=Bodies, Contacts=Contacts, Params=Params, start_contacts=start_contacts, clear_loads=clear_loads,
        touch_force=touch_force, cross=cross,
        clear_cells=clear_cells,
        finish_rebuild=finish_rebuild, reset_total=reset_total,
        contact_forces=contact_forces, make_contact_forces=functools.cache(make_contact_forces),
        # the pieces of the pair search, for the search split over candidate vertices (kernels/dem_split.py)
        pair_side=pair_side, no_touches=no_touches, vertex_search=vertex_search, add_touch=add_touch,
        search_pair=search_pair, pair_bodies=pair_bodies,
        listed_pair=listed_pair, overlapping_circles=overlapping_circles, store_pair=store_pair,
        vertex_feature=vertex_feature, edge_count=edge_count,
        integrate=integrate, end_step=end_step, diagnostics=diagnostics,
        # list maintenance shared with the body-pair lists (kernels/dem_lists.py) and the MPM-DEM coupling
        needs_rebuild=needs_rebuild, cell_in=cell_in, bin_item=bin_item, sort_ids=sort_ids,
    )


#: Order of the sums written by the diagnostics kernel.
DIAG_NAMES = (
    "energy_kinetic",
    "energy_gravity",
    "energy_contact",
    "momentum_x",
    "momentum_y",
    "momentum_angular",
    "mass",
    "dissipated_damping",
    "dissipated_friction",
    "work_driven",
)
