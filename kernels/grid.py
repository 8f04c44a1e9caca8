"""Grid update: nodal velocities from momenta, the explicit force update, boundary conditions."""

import functools

import warp as wp

from .state import make_state_structs
from .types import kernel, scalar_types

__all__ = ["BC_FIXED", "BC_FREE", "BC_FRICTION", "BC_SLIP", "make_boundary_condition", "make_grid_update"]

BC_FIXED = 0
BC_SLIP = 1
BC_FRICTION = 2
BC_FREE = 3


@functools.cache
def make_boundary_condition(precision: str):
    """``apply_bc(v, kind, mu, n) -> v`` for a node on a wall with outward normal n."""
    t = scalar_types(precision)
    T = t.scalar

    @wp.func
    def apply_bc(v: t.vec2, kind: int, mu: T, n: t.vec2):
        vn = wp.dot(v, n)
        if kind == BC_FIXED:
            return t.vec2()
        if kind == BC_SLIP:
            # roller: no normal motion either way, free tangential motion
            return v - vn * n
        if kind == BC_FRICTION:
            # Coulomb wall: a node moving into the wall loses its normal velocity and its
            # tangential velocity is reduced by μ|Δv_n| (not past zero); a node moving away is free.
            if vn > T(0.0):
                vt = v - vn * n
                s = wp.length(vt)
                if s <= mu * vn:
                    return t.vec2()
                return vt * (T(1.0) - mu * vn / s)
        return v

    return apply_bc


@functools.cache
def make_grid_update(precision: str, *, velocity: bool, force: bool, fused_impulse: bool = False, remap: bool = False):
    """Nodal velocity V = p/m (with BC), and/or Ṽ = V + dt (f/m + g) (with BC).

    fused_impulse: the momentum already holds p + dt f (USL + PIC), so Ṽ = p/m + dt g.
    remap: normalise ``Grid.vm`` (MUSL re-mapped momentum) in place instead of ``Grid.mom``.
    """
    t = scalar_types(precision)
    T = t.scalar
    Particles, Grid, Domain = make_state_structs(precision)
    apply_bc = make_boundary_condition(precision)

    @wp.func
    def boundary(v: t.vec2, D: Domain, i: int, j: int):
        out = v
        if i <= D.node_lo[0]:
            out = apply_bc(out, D.bc_kind[0], D.bc_mu[0], t.vec2(T(-1.0), T(0.0)))
        if i >= D.node_hi[0]:
            out = apply_bc(out, D.bc_kind[1], D.bc_mu[1], t.vec2(T(1.0), T(0.0)))
        if j <= D.node_lo[1]:
            out = apply_bc(out, D.bc_kind[2], D.bc_mu[2], t.vec2(T(0.0), T(-1.0)))
        if j >= D.node_hi[1]:
            out = apply_bc(out, D.bc_kind[3], D.bc_mu[3], t.vec2(T(0.0), T(1.0)))
        return out

    @kernel
    def grid_update(G: Grid, D: Domain, clock: wp.array(dtype=wp.float64)):
        i, j = wp.tid()
        dt = T(clock[1])
        if dt <= T(0.0):
            return
        m = G.mass[i, j]
        if m <= D.mass_eps:
            if wp.static(remap):
                G.vm[i, j] = t.vec2()
            else:
                G.v[i, j] = t.vec2()
                G.vt[i, j] = t.vec2()
            return
        inv_m = T(1.0) / m
        g = D.gravity
        if D.gravity_ramp > wp.float64(0.0):
            g = g * T(wp.min(clock[0] / D.gravity_ramp, wp.float64(1.0)))
        if wp.static(remap):
            G.vm[i, j] = boundary(G.vm[i, j] * inv_m, D, i, j)
            return
        if wp.static(fused_impulse):
            G.vt[i, j] = boundary(G.mom[i, j] * inv_m + dt * g, D, i, j)
            return
        v = G.v[i, j]
        if wp.static(velocity):
            v = boundary(G.mom[i, j] * inv_m, D, i, j)  # "Motion integration" eq. 16
            G.v[i, j] = v
        if wp.static(force):
            # Ṽ = V + a Δt, a = f/m + g ("Motion integration" eq. 28; "MPM notes" steps 5-7)
            G.vt[i, j] = boundary(v + dt * (G.force[i, j] * inv_m + g), D, i, j)

    return grid_update
