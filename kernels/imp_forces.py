"""The contact forces of the MPM–DEM coupling (MPM-SDEM eq. 43–46, 49–50): every listed point
against its listed bodies, and the diagnostics sums.

A point is a disk of radius r_p against each edge and vertex of a body's core (the DEM's Voronoi
rule: one contact per touching spot on a convex core): overlap ξ = a_i + r_p − d (eq. 44), normal
spring–dashpot, tangential spring with history and the Coulomb cap (eq. 43), summed over bodies
into the point's contact force f_p (eq. 46), which the P2G spreads with the point's own shape
function (eq. 47–48, ``kernels.transfer``). The opposite force and its torque go to the body
(eq. 49–50).

Torque lever: the grid receives f_p at x_p (eq. 47: Σ_I N_I(x_p) x_I = x_p), so the body's
reaction torque is taken about the same line of action, (x_p − c_i) × (−f_p). Eq. 50 writes the
lever to the contact point p(x_p, E_i); with friction that adds a couple f_t (r_p − ξ/2) per
contact that nothing balances, and total angular momentum drifts. The ``grid`` scheme, which puts
the force on the grid node nearest the contact point, takes the contact point's lever (the node
is within a cell of it: angular momentum then drifts by that much, see tests/sim/test_coupling.py).
"""

import functools

import warp as wp

from .clock import CLOCK_DT
from .contact_geometry import make_contact_geometry, make_history_lookup
from .imp_links import IMP_HISTORY, make_imp_structs, make_release_gate
from .types import kernel, scalar_types

__all__ = ["IMP_DIAG_NAMES", "make_imp_diagnostics", "make_imp_forces", "make_point_contact"]

#: Order of the sums written by the diagnostics kernel.
IMP_DIAG_NAMES = ("energy_imp", "dissipated_imp_damping", "dissipated_imp_friction", "imp_pairs", "imp_contacts")


@functools.cache
def make_point_contact(precision: str, scheme: str = "imp"):
    """``point_contact``, the force law of one point–body touch, for one precision; scheme "grid"
    takes the body's torque about the contact point, the others about x_p."""
    t = scalar_types(precision)
    T = t.scalar
    vec2 = t.vec2
    _, _, _, Params, veci, vec2h = make_imp_structs(precision)
    geometry = make_contact_geometry(precision)
    cross, point_velocity = geometry.cross, geometry.point_velocity
    contact_point, spring_dashpot = geometry.contact_point, geometry.spring_dashpot
    find_slip = make_history_lookup(precision, IMP_HISTORY)
    lever_at_contact = scheme == "grid"

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
        F, slip, e_contact, lost_contact = spring_dashpot(prm.law.kn, prm.law.kt, prm.law.zeta, mu, delta, vel, N,
                                                          inv_eff, find_slip(keys, slips, key), dt)
        return F, pc, arm, slip, e_contact, lost_contact

    return point_contact


@functools.cache
def make_imp_forces(precision: str, scheme: str = "imp", staged: bool = False, deterministic: bool = False,
                    sifted: bool = False, static_bodies: int = 0):
    """The force kernel of the coupling for one precision and scheme over the listed points, or
    (``sifted``) over those ``sift`` kept; staged: points before their release time are left out.

    static_bodies > 0: every point lists these bodies, slot s holding body s, for the whole run
    (``mpmdem.sim.tuning.Tuning.static_imp_bodies``). The bodies' bounding circles are tested first, all
    at once (an unrolled loop: their loads leave together, where the listed loop would wait on
    each body's in turn), and a body is searched only where the point is also within reach of
    its core's bounding box: a long wall's circle covers most of a scene, its box a strip. The
    box is never farther than any feature a touch is found at (a touch is within reach of an
    edge or a vertex, or inside the core), so this test changes no force; it is taken with the
    same round-off margin as the DEM's (``kernels.dem_lists``)."""
    t = scalar_types(precision)
    T = t.scalar
    vec2 = t.vec2
    Particles, Bodies, Links, Params, veci, vec2h = make_imp_structs(precision)
    geometry = make_contact_geometry(precision)
    cross, box_distance = geometry.cross, geometry.box_distance
    edge_count, vertex_feature = geometry.edge_count, geometry.vertex_feature
    released = make_release_gate(precision, staged)
    point_contact = make_point_contact(precision, scheme)
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



@functools.cache
def make_imp_diagnostics(precision: str, deterministic: bool = False):
    """Kernel ``diagnostics`` of the coupling for one precision."""
    Links = make_imp_structs(precision).Links

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

    return diagnostics
