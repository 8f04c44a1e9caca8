"""Device code of the MPM–DEM coupling by identified material points (MPM-SDEM §4).

A material point within the Verlet distance of a rigid spheropolygon is an *identified material
point* (IMP): for the contact it is a disk of radius r_p centred on the point (MPM-SDEM Fig. 4–5).
Per step (all kernels, no host sync, capturable in a CUDA graph):

1. ``check_lists``: flag a rebuild of the point–body lists when a point or a moving body has moved
   (or turned) more than half the skin since the last build, or a staged point has entered the
   scene — the DEM's Verlet rule (and, without free bodies, clear the bodies' loads).
2. On a flagged step only: points are binned in cells of the MPM grid; each body visits the cells
   its core's bounding box, grown by a, the largest r_p and the skin, covers (``tile`` threads per body
   share its cells, so a long wall is not one thread's work) and lists the points within
   a_i + r_p + skin of its core outline (eq. 44's gap plus the skin). Each point then sorts its
   bodies (sums in a fixed order) and carries the tangential history of pairs that stay listed.
3. ``forces``: every point against its listed bodies, as a disk of radius r_p against each edge
   and vertex (the DEM's Voronoi rule: one contact per touching spot on a convex core): overlap
   ξ = a_i + r_p − d (eq. 44), normal spring–dashpot, tangential spring with history and the
   Coulomb cap (eq. 43), summed over bodies into the point's contact force f_p (eq. 46), which
   the P2G spreads with the point's own shape function (eq. 47–48). The opposite force and its
   torque go to the body (eq. 49–50).

Torque lever: the grid receives f_p at x_p (eq. 47: Σ_I N_I(x_p) x_I = x_p), so the body's
reaction torque is taken about the same line of action, (x_p − c_i) × (−f_p). Eq. 50 writes the
lever to the contact point p(x_p, E_i); with friction that adds a couple f_t (r_p − ξ/2) per
contact that nothing balances, and total angular momentum drifts. The ``grid`` scheme, which puts
the force on the grid node nearest the contact point, takes the contact point's lever (the node
is within a cell of it: angular momentum then drifts by that much, see tests/test_coupling.py).
"""

import functools

import warp as wp

from .clock import CLOCK_DT, CLOCK_T
from .contact_geometry import make_contact_geometry, make_history_lookup
from .dem import FIXED, make_dem_kernels
from .state import make_state_structs
from .types import Namespace, kernel, scalar_types

__all__ = [
    "COUPLING_SCHEMES",
    "IMP_DIAG_NAMES",
    "IMP_HISTORY",
    "STATUS_CELL_OVERFLOW",
    "STATUS_SIZE",
    "STATUS_SLOT_OVERFLOW",
    "make_coupling_kernels",
    "make_liu_kernels",
]

#: How the contact force reaches the grid: at the point (the paper's), at the node nearest the
#: contact point, or not at all (Liu et al.'s momentum exchange through shared nodes).
COUPLING_SCHEMES = ("imp", "grid", "liu")

#: Features of one body a point may touch at once (two edges in a concave corner); the kernels
#: spell the vectors of this length out.
IMP_HISTORY = 2

STATUS_SLOT_OVERFLOW = 0
STATUS_CELL_OVERFLOW = 1
STATUS_SIZE = 2

#: Order of the sums written by the diagnostics kernel.
IMP_DIAG_NAMES = ("energy_imp", "dissipated_imp_damping", "dissipated_imp_friction", "imp_pairs", "imp_contacts")

#: Position of a point not listed yet (a staged point before its release).
_UNLISTED = 1.0e30


@functools.cache
def make_coupling_kernels(precision: str, scheme: str = "imp", *, staged: bool = False, deterministic: bool = False):
    """Structs and kernels of the IMP coupling for one precision and coupling scheme.

    scheme "imp" and "liu" take the body's torque about x_p, "grid" about the contact point.
    staged: points whose release time is still ahead take no part.
    """
    t = scalar_types(precision)
    T = t.scalar
    vec2 = t.vec2
    Particles, Grid, Domain = make_state_structs(precision)
    dem = make_dem_kernels(precision, deterministic)
    Bodies = dem.Bodies
    needs_rebuild, sort_ids, cell_in, bin_item = dem.needs_rebuild, dem.sort_ids, dem.cell_in, dem.bin_item
    geometry = make_contact_geometry(precision)
    cross, polygon_distance, box_distance = geometry.cross, geometry.polygon_distance, geometry.box_distance
    within_reach = geometry.within_reach
    point_velocity, edge_count, vertex_feature = geometry.point_velocity, geometry.edge_count, geometry.vertex_feature
    contact_point, spring_dashpot = geometry.contact_point, geometry.spring_dashpot
    find_slip = make_history_lookup(precision, IMP_HISTORY)
    lever_at_contact = scheme == "grid"
    vec2h = wp.types.vector(IMP_HISTORY, T)
    veci = wp.types.vector(IMP_HISTORY, wp.int32)

    @wp.struct
    class Links:
        body: wp.array(dtype=wp.int32)  # (points * slots) listed body of each slot, −1 empty
        count: wp.array(dtype=wp.int32)  # (points) bodies listed
        key: wp.array(dtype=veci)  # (points * slots) feature keys of the tangential history
        slip: wp.array(dtype=vec2h)  # (points * slots) tangential spring stretch δ_t [m]
        old_body: wp.array(dtype=wp.int32)
        old_key: wp.array(dtype=veci)
        old_slip: wp.array(dtype=vec2h)
        x_ref: wp.array(dtype=vec2)  # (points) position at the last build [m]
        body_x_ref: wp.array(dtype=vec2)  # (bodies) centroid and angle at the last build
        body_angle_ref: wp.array(dtype=T)
        radius: wp.array(dtype=T)  # (points) contact radius r_p [m] (MPM-SDEM eq. 45)
        energy: wp.array(dtype=T)  # (points) elastic energy of the point's contacts [J/m]
        dissipated: wp.array(dtype=wp.vec2d)  # (points) damping, friction work since the start [J/m]
        contact_at: wp.array(dtype=vec2)  # (points) where the force acts ("grid" scheme) [m]
        active: wp.array(dtype=wp.int32)  # (points) contacts touching this step
        listed: wp.array(dtype=wp.int32)  # (points) the points the force kernel visits, packed at each build
        listed_count: wp.array(dtype=wp.int32)  # (1) how many
        near: wp.array(dtype=wp.int32)  # (points, large scenes) the listed points near a body this step (``sift``)
        near_count: wp.array(dtype=wp.int32)  # (1) how many (reset by ``check_lists``)
        slots: int

    @wp.struct
    class Params:
        kn: T  # normal stiffness [N/m per m]
        kt: T  # tangential stiffness
        zeta: T  # damping ratio from the restitution coefficient
        skin: T  # Verlet skin [m]
        r_max: T  # largest contact radius [m]
        cell_origin: vec2  # point bins (the MPM grid's cells)
        inv_cell: T
        cells_x: int
        cells_y: int
        cell_cap: int
        bodies: int
        moving: int  # bodies [0, moving) can move
        tile: int  # threads per body in the list build
        friction: wp.array(dtype=T)  # (materials * bodies) Coulomb μ of each (material, body) pair

    @wp.func
    def released(P: Particles, clock: wp.array(dtype=wp.float64), p: int):
        ok = True
        if wp.static(staged):
            ok = clock[CLOCK_T] >= P.release[p]
        return ok

    # -- list maintenance ---------------------------------------------------------------------
    @kernel
    def check_lists(P: Particles, B: Bodies, L: Links, prm: Params, clock: wp.array(dtype=wp.float64),
                    flags: wp.array(dtype=wp.int32), moving: int, clear: int):
        """Flag a rebuild when point i moved more than half the skin (or was just released), or
        moving body i (i < moving) moved or turned more than half the skin; body i < ``clear`` has
        its loads of this step cleared (where the DEM stage has no contact launch to do it). One
        launch over max(points, moving, clear) threads: a small scene's step is paid per launch."""
        i = wp.tid()
        if i == 0:
            L.near_count[0] = 0  # (``sift`` packs this step's near points after it)
        if i < clear:
            B.force[i] = vec2()
            B.torque[i] = T(0.0)
        if i < moving:
            if needs_rebuild(B, i, L.body_x_ref, L.body_angle_ref, prm.skin):
                flags[0] = 1
        if i >= P.x.shape[0]:
            return
        if not released(P, clock, i):
            return
        moved = wp.length(P.x[i] - L.x_ref[i])
        if moved > T(0.5) * prm.skin or not wp.isfinite(moved):
            flags[0] = 1

    @wp.func
    def cell_of(x: vec2, prm: Params):
        return cell_in(x, prm.cell_origin, prm.inv_cell, prm.cells_x, prm.cells_y)

    @kernel
    def bin_points(P: Particles, L: Links, prm: Params, clock: wp.array(dtype=wp.float64),
                   flags: wp.array(dtype=wp.int32), cell_count: wp.array(dtype=wp.int32),
                   cell_items: wp.array(dtype=wp.int32), status: wp.array(dtype=wp.int32)):
        """Point p into its cell's bin; keep its old list for the history hand-over."""
        if flags[0] == 0:
            return
        p = wp.tid()
        if p == 0:
            L.listed_count[0] = 0  # (``finish_lists`` packs them anew)
        S = L.slots
        base = p * S
        for s in range(S):
            L.old_body[base + s] = L.body[base + s]
            L.old_key[base + s] = L.key[base + s]
            L.old_slip[base + s] = L.slip[base + s]
            L.body[base + s] = -1
        L.count[p] = 0
        if not released(P, clock, p):
            L.x_ref[p] = vec2(T(_UNLISTED), T(_UNLISTED))
            return
        x = P.x[p]
        L.x_ref[p] = x
        cx, cy = cell_of(x, prm)
        bin_item(cell_count, cell_items, cx * prm.cells_y + cy, prm.cell_cap, p, status, STATUS_CELL_OVERFLOW)

    @kernel
    def build_lists(P: Particles, B: Bodies, L: Links, prm: Params, world: wp.array(dtype=vec2),
                    flags: wp.array(dtype=wp.int32), cell_count: wp.array(dtype=wp.int32),
                    cell_items: wp.array(dtype=wp.int32), status: wp.array(dtype=wp.int32)):
        """Body b (with ``tile`` lanes) lists the points within a_b + r_p + skin of its outline."""
        if flags[0] == 0:
            return
        tid = wp.tid()
        b = tid // prm.tile
        lane = tid - b * prm.tile
        xb = B.x[b]
        a = B.radius[b]
        grow = a + prm.r_max + prm.skin
        reach = B.core_radius[b] + grow
        start = B.vstart[b]
        count = B.vcount[b]
        # the cells of the core's box grown by the reach (not of the bounding circle: a long thin
        # wall's circle covers the whole domain)
        lo = world[start]
        hi = lo
        for k in range(1, count):
            w = world[start + k]
            lo = wp.min(lo, w)
            hi = wp.max(hi, w)
        lo_x, lo_y = cell_of(lo - vec2(grow, grow), prm)
        hi_x, hi_y = cell_of(hi + vec2(grow, grow), prm)
        nx = hi_x - lo_x + 1
        ny = hi_y - lo_y + 1
        if lane == 0:
            L.body_x_ref[b] = xb
            L.body_angle_ref[b] = B.angle[b]
        S = L.slots
        for c in range(lane, nx * ny, prm.tile):
            gx = lo_x + c // ny
            gy = lo_y + c - (c // ny) * ny
            cell = gx * prm.cells_y + gy
            for s in range(wp.min(cell_count[cell], prm.cell_cap)):
                p = cell_items[cell * prm.cell_cap + s]
                x = P.x[p]
                if wp.length(x - xb) < reach:
                    if polygon_distance(x, world, start, count) < a + L.radius[p] + prm.skin:
                        k = wp.atomic_add(L.count, p, 1)
                        if k < S:
                            L.body[p * S + k] = b
                        else:
                            wp.atomic_add(status, STATUS_SLOT_OVERFLOW, 1)

    @kernel
    def finish_lists(L: Links, flags: wp.array(dtype=wp.int32)):
        """Sort each point's bodies (a fixed summation order) and carry the history of pairs
        that stay listed; pack the points the force kernel must visit until the next build: those
        with a body listed, and those whose contact must be cleared (``forces``)."""
        if flags[0] == 0:
            return
        p = wp.tid()
        S = L.slots
        base = p * S
        n = wp.min(L.count[p], S)
        L.count[p] = n
        if n > 0 or L.active[p] != 0:
            L.listed[wp.atomic_add(L.listed_count, 0, 1)] = p
        sort_ids(L.body, base, n)
        for s in range(S):
            key = veci(-1, -1)
            slip = vec2h()
            if s < n:
                b = L.body[base + s]
                for o in range(S):
                    if L.old_body[base + o] == b:
                        key = L.old_key[base + o]
                        slip = L.old_slip[base + o]
            L.key[base + s] = key
            L.slip[base + s] = slip

    # -- forces (MPM-SDEM eq. 43-46, 49-50) -----------------------------------------------------
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

    @wp.func
    def point_contact(prm: Params, X: vec2, N: vec2, d: T, reach: T, rp: T, key: int, dt: T, vp: vec2, mp: T,
                      xb: vec2, vb: vec2, wb: T, inv_mb: T, inv_ib: T, mu: T, keys: veci, slips: vec2h):
        """The force on a point at X [N/m] (eq. 46) of its touch at distance d along N from the core of
        a body: overlap eq. 44, contact point in the middle of the overlap (eq. 41), spring–dashpot and
        Coulomb cap eq. 43, the dashpot seeing the point (velocity vp, mass mp) and the body (centroid
        xb, velocity vb, spin wb, inverse mass and inertia) at the contact, as two DEM bodies do; μ
        and the pair's history (keys, slips) as read by the caller. Returns (F, contact point [m],
        the lever arm of the body's torque [m], δ_t, stored energy, dissipated work)."""
        delta, pc = contact_point(X, N, d, reach, rp)
        arm = X - xb
        if wp.static(lever_at_contact):
            arm = pc - xb
        vel = vp - point_velocity(vb, wb, pc - xb)
        lever = cross(arm, N)
        inv_eff = T(1.0) / mp + inv_mb + inv_ib * lever * lever
        F, slip, e_contact, lost_contact = spring_dashpot(prm.kn, prm.kt, prm.zeta, mu, delta, vel, N, inv_eff,
                                                          find_slip(keys, slips, key), dt)
        return F, pc, arm, slip, e_contact, lost_contact

    @functools.cache
    def make_forces(sifted: bool, static_bodies: int = 0):
        """The force kernel over the listed points, or (``sifted``) over those ``sift`` kept.

        static_bodies > 0: every point lists these bodies, slot s holding body s, for the whole run
        (``mpmdem.sim.tuning.Tuning.static_imp_bodies``). The bodies' bounding circles are tested first, all
        at once (an unrolled loop: their loads leave together, where the listed loop would wait on
        each body's in turn), and a body is searched only where the point is also within reach of
        its core's bounding box: a long wall's circle covers most of a scene, its box a strip. The
        box is never farther than any feature a touch is found at (a touch is within reach of an
        edge or a vertex, or inside the core), so this test changes no force; it is taken with the
        same round-off margin as the DEM's (``kernels.dem_lists``)."""
        boxed = static_bodies > 0

        @kernel(deterministic=deterministic)
        def forces(P: Particles, B: Bodies, L: Links, prm: Params, world: wp.array(dtype=vec2),
                   clock: wp.array(dtype=wp.float64), status: wp.array(dtype=wp.int32)):
            """Contact force f_p on point p from its listed bodies (eq. 44-46); reactions on the bodies.

            Launched over every point; unless deterministic, thread k takes the k-th packed point
            (``finish_lists``, or ``sift``'s near points) and the threads past them return, so the
            warps that search are full (a third of the points near bodies would otherwise hold nearly
            every warp in the search). Deterministic runs keep thread p on point p: the packing order
            varies from run to run."""
            p = wp.tid()
            if wp.static(sifted):
                if p >= L.near_count[0]:
                    return
                p = L.near[p]
            elif wp.static(not deterministic):
                if p >= L.listed_count[0]:
                    return
                p = L.listed[p]
            n = L.count[p]
            # a step with dt = 0 (the clock at its stop time) recomputes the same forces: the
            # outputs keep the loads of the last real step, and nothing slips or dissipates
            if not released(P, clock, p):
                n = 0
            if n == 0:
                # most points are far from every body: two reads, and writes only when a contact ended
                if L.active[p] != 0:
                    P.fcont[p] = vec2()
                    L.energy[p] = T(0.0)
                    L.active[p] = 0
                return
            # a point that touched nothing at the last pass holds no history key and no contact
            # (``sift``), so unless it touches now it writes nothing (most listed points)
            was_active = L.active[p]
            fc = vec2()
            dt = T(clock[CLOCK_DT])
            S = L.slots
            base = p * S
            X = P.x[p]
            rp = L.radius[p]
            energy = T(0.0)
            lost = wp.vec2d(0.0, 0.0)
            app = vec2()
            app_w = T(0.0)
            touching = int(0)
            near_mask = int(0)  # (static bodies: bit s, whether the point is in body s's bounding circle)
            if wp.static(boxed):
                for s in range(wp.static(static_bodies)):
                    if wp.length(X - B.x[s]) < B.core_radius[s] + (B.radius[s] + rp):
                        near_mask = near_mask | (1 << s)
            for s in range(n):
                keys = veci(-1, -1)
                slips = vec2h()
                n_hist = int(0)
                b = s
                near = bool(False)
                reach = T(0.0)
                if wp.static(boxed):
                    reach = B.radius[b] + rp
                    near = ((near_mask >> s) & 1) != 0
                else:
                    b = L.body[base + s]
                    reach = B.radius[b] + rp
                    near = wp.length(X - B.x[b]) < B.core_radius[b] + reach
                start = int(0)
                count = int(0)
                if near:
                    start = B.vstart[b]
                    count = B.vcount[b]
                    if wp.static(boxed):
                        near = box_distance(X, world, start, count) < reach + T(1.0e-3) * (reach + wp.length(X))
                if near:
                    # what a touch reads, loaded before the search so that its latency overlaps it
                    vp = P.v[p]
                    mp = P.mass[p]
                    mu = prm.friction[P.material[p] * prm.bodies + b]
                    xb = B.x[b]
                    vb = B.v[b]
                    wb = B.omega[b]
                    inv_mb = B.inv_mass[b]
                    inv_ib = B.inv_inertia[b]
                    old_keys = L.key[base + s]
                    old_slips = L.slip[base + s]
                    n_edges = edge_count(count)
                    # a point past every edge line of a polygon core (inside a convex core) is pushed
                    # out through the nearest edge, the overlap growing as d turns negative
                    inside = count >= 3
                    best_d = T(-1.0e30)
                    best_f = int(-1)
                    best_n = vec2()
                    for f in range(n_edges + count + 1):
                        # the point is a disk: a core of one vertex, in every corner region
                        hit, N, d, key, inside, best_d, best_f, best_n = vertex_feature(
                            X, world, start, count, f, n_edges, count, reach, 0, 1, 0, inside, best_d, best_f, best_n)
                        if hit:
                            F, pc, arm, slip, e_contact, lost_contact = point_contact(
                                prm, X, N, d, reach, rp, key, dt, vp, mp, xb, vb, wb, inv_mb, inv_ib, mu, old_keys,
                                old_slips)
                            lost = lost + lost_contact
                            energy += e_contact
                            if n_hist < wp.static(IMP_HISTORY):
                                keys[n_hist] = key
                                slips[n_hist] = slip
                                n_hist += 1
                            fc += F  # on the point (eq. 46)
                            wF = wp.length(F)
                            app += wF * pc
                            app_w += wF
                            touching += 1
                            # reaction on the body (eq. 49-50); fixed bodies keep it as their load
                            wp.atomic_add(B.force, b, -F)
                            wp.atomic_add(B.torque, b, -cross(arm, F))
                if n_hist > 0 or was_active != 0:
                    L.key[base + s] = keys
                    L.slip[base + s] = slips
            if touching == 0 and was_active == 0:
                return
            P.fcont[p] = fc
            if app_w > T(0.0):
                L.contact_at[p] = app / app_w
            else:
                L.contact_at[p] = X
            L.energy[p] = energy
            L.active[p] = touching
            L.dissipated[p] = L.dissipated[p] + lost

        return forces

    forces = make_forces(False)

    @kernel(deterministic=deterministic)
    def diagnostics(L: Links, out: wp.array(dtype=wp.float64)):
        """Sums of IMP_DIAG_NAMES over the points."""
        p = wp.tid()
        lost = L.dissipated[p]
        wp.atomic_add(out, 0, wp.float64(L.energy[p]))
        wp.atomic_add(out, 1, lost[0])
        wp.atomic_add(out, 2, lost[1])
        wp.atomic_add(out, 3, wp.float64(L.count[p]))
        wp.atomic_add(out, 4, wp.float64(L.active[p]))

    return Namespace(Links=Links, Params=Params, check_lists=check_lists,
                      clear_cells=dem.clear_cells, bin_points=bin_points, build_lists=build_lists,
                      finish_lists=finish_lists, forces=forces, make_forces=make_forces, sift=sift,
                      diagnostics=diagnostics,
                      finish_rebuild=dem.finish_rebuild, FIXED=FIXED)


@functools.cache
def make_liu_kernels(precision: str):
    """The "liu" comparison scheme (MPM-SDEM §5.4, after Liu et al.): each rigid body is carried by
    a few material points (its core's vertices, edge midpoints and centroid) that put its mass and
    velocity on a grid of their own; after the MPM force update, at every node where both the
    material and a body have mass and approach each other along the body's surface normal, the
    material's nodal velocity is corrected to the pair's centre-of-mass velocity along the normal
    (the frictionless multi-field MPM contact of Bardenhagen et al.), and the momentum it loses is
    the impulse on the body (force ``J / dt`` and its torque about the centroid)."""
    t = scalar_types(precision)
    T = t.scalar
    vec2 = t.vec2
    Particles, Grid, Domain = make_state_structs(precision)
    Bodies = make_dem_kernels(precision).Bodies
    geometry = make_contact_geometry(precision)
    rotate, spin, cross = geometry.rotate, geometry.spin, geometry.cross

    @wp.struct
    class BodyGrid:
        mass: wp.array2d(dtype=T)  # carried body mass per node [kg/m]
        mom: wp.array2d(dtype=vec2)  # its momentum [kg/s per m]
        grad: wp.array2d(dtype=vec2)  # Σ m_c ∇N_I(x_c): points into the body [kg/m²]
        owner: wp.array2d(dtype=wp.int32)  # body at the node
        local: wp.array(dtype=vec2)  # carrier positions in the body frame [m]
        body: wp.array(dtype=wp.int32)  # carrier → body
        share: wp.array(dtype=T)  # carrier → 1 / carriers of its body

    @kernel
    def carriers_to_grid(B: Bodies, BG: BodyGrid, D: Domain, clock: wp.array(dtype=wp.float64)):
        """P2G of the carrier points with the tent function."""
        c = wp.tid()
        if clock[CLOCK_DT] <= wp.float64(0.0):
            return
        b = BG.body[c]
        r = rotate(B.angle[b], BG.local[c])
        m = B.mass[b] * BG.share[c]
        v = B.v[b] + spin(B.omega[b], r)
        g = (B.x[b] + r - D.origin) * D.inv_h
        bx = int(wp.floor(g[0]))
        by = int(wp.floor(g[1]))
        fx = g[0] - T(bx)
        fy = g[1] - T(by)
        for i in range(2):
            for j in range(2):
                wx = T(1.0) - fx
                dwx = -D.inv_h
                if i == 1:
                    wx = fx
                    dwx = D.inv_h
                wy = T(1.0) - fy
                dwy = -D.inv_h
                if j == 1:
                    wy = fy
                    dwy = D.inv_h
                gi = bx + i
                gj = by + j
                if gi >= 0 and gj >= 0 and gi < D.layer_rows and gj < BG.mass.shape[1]:
                    wp.atomic_add(BG.mass, gi, gj, wx * wy * m)
                    wp.atomic_add(BG.mom, gi, gj, wx * wy * m * v)
                    wp.atomic_add(BG.grad, gi, gj, m * vec2(dwx * wy, wx * dwy))
                    BG.owner[gi, gj] = b

    @kernel
    def exchange(G: Grid, D: Domain, BG: BodyGrid, B: Bodies, clock: wp.array(dtype=wp.float64)):
        """Contact correction at the shared nodes; the impulse goes to the body."""
        i, j = wp.tid()
        dt = T(clock[CLOCK_DT])
        m1 = G.mass[i, j]
        m2 = BG.mass[i, j]
        if dt <= T(0.0) or m1 <= D.mass_eps or m2 <= T(0.0):
            return
        b = BG.owner[i, j]
        v1 = G.vt[i, j]
        v2 = BG.mom[i, j] / m2
        grad = BG.grad[i, j]
        xi = D.origin + vec2(T(i), T(j)) * D.h
        n = xi - B.x[b]
        if wp.length(grad) > T(1.0e-12) * m2 * D.inv_h:
            # Σ m_c ∂N_I/∂x_c points away from the carriers; between two carriers (inside the body)
            # that can be inwards, so it is turned to point away from the centroid (convex bodies)
            n = grad
            if wp.dot(n, xi - B.x[b]) < T(0.0):
                n = -n
        n = wp.normalize(n)
        vcm = v2  # a fixed or driven body does not give way
        if B.inv_mass[b] > T(0.0):
            vcm = (m1 * v1 + m2 * v2) / (m1 + m2)
        approach = wp.dot(v1 - vcm, n)
        if approach < T(0.0):
            dv = -approach * n
            G.vt[i, j] = v1 + dv
            J = -m1 * dv  # impulse on the body
            wp.atomic_add(B.force, b, J / dt)
            wp.atomic_add(B.torque, b, cross(xi - B.x[b], J) / dt)

    return Namespace(BodyGrid=BodyGrid, carriers_to_grid=carriers_to_grid, exchange=exchange)
