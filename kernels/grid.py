"""Grid update: nodal velocities from momenta, the explicit force update, boundary conditions."""

import functools

import warp as wp

from .state import make_state_structs
from .types import kernel, scalar_types

__all__ = [
    "BC_FIXED",
    "BC_FREE",
    "BC_FRICTION",
    "BC_SLIP",
    "make_boundary_condition",
    "make_fold_ghosts",
    "make_grid_update",
    "make_mirror_ghosts",
]

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


@wp.func
def _mirror_node(i: int, j: int, lo: wp.vec2i, hi: wp.vec2i, kinds: wp.vec4i):
    """Interior mirror (si, sj) of a ghost node, the sign of each velocity component, and
    whether the node is a mirrored ghost (beyond a fixed or slip wall)."""
    si = i
    sj = j
    sx = 1.0
    sy = 1.0
    mirrored = False
    if i < lo[0] and (kinds[0] == BC_FIXED or kinds[0] == BC_SLIP):
        si = wp.min(2 * lo[0] - i, hi[0])
        sx = -1.0
        if kinds[0] == BC_FIXED:
            sy = -1.0
        mirrored = True
    elif i > hi[0] and (kinds[1] == BC_FIXED or kinds[1] == BC_SLIP):
        si = wp.max(2 * hi[0] - i, lo[0])
        sx = -1.0
        if kinds[1] == BC_FIXED:
            sy = -1.0
        mirrored = True
    if j < lo[1] and (kinds[2] == BC_FIXED or kinds[2] == BC_SLIP):
        sj = wp.min(2 * lo[1] - j, hi[1])
        sy = -sy
        if kinds[2] == BC_FIXED:
            sx = -sx
        mirrored = True
    elif j > hi[1] and (kinds[3] == BC_FIXED or kinds[3] == BC_SLIP):
        sj = wp.max(2 * hi[1] - j, lo[1])
        sy = -sy
        if kinds[3] == BC_FIXED:
            sx = -sx
        mirrored = True
    return si, sj, sx, sy, mirrored


@functools.cache
def make_mirror_ghosts(precision: str):
    """Ghost nodes beyond a fixed or slip wall take the mirrored velocity of the interior.

    Wide stencils (B-splines) reach one or two nodes past the wall. Setting those ghosts to the
    mirror image of the interior field (odd in every component for a fixed wall, odd in the
    normal component for a slip wall) makes the interpolated velocity satisfy the wall condition
    at the wall itself, instead of clamping a whole layer of material to it. Mirror sources are
    clamped to the interior (boundary nodes included), so no thread reads a node another writes.
    """
    t = scalar_types(precision)
    T = t.scalar
    Domain = make_state_structs(precision)[2]

    @kernel
    def mirror_ghosts(field: wp.array2d(dtype=t.vec2), D: Domain, clock: wp.array(dtype=wp.float64)):
        i, j = wp.tid()
        if clock[1] <= wp.float64(0.0):
            return
        si, sj, sx, sy, mirrored = _mirror_node(i, j, D.node_lo, D.node_hi, D.bc_kind)
        if mirrored:
            v = field[si, sj]
            field[i, j] = t.vec2(T(sx) * v[0], T(sy) * v[1])

    return mirror_ghosts


@wp.func
def _image(i: int, lo: int, hi: int, kind_lo: int, kind_hi: int, n: int):
    """Ghost node whose mirror is node i (−1 if none), with the wall it lies beyond (0 lo, 1 hi)."""
    if i > lo and (kind_lo == BC_FIXED or kind_lo == BC_SLIP):
        g = 2 * lo - i
        if g >= 0:
            return g, 0
    if i < hi and (kind_hi == BC_FIXED or kind_hi == BC_SLIP):
        g = 2 * hi - i
        if g < n:
            return g, 1
    return -1, 0


@functools.cache
def make_fold_ghosts(precision: str, *, mass: bool, momentum: bool, force: bool, remap: bool = False):
    """Fold what points put on ghost nodes back onto their interior mirrors.

    This is the image-point method: a point near a fixed or slip wall has a mirror image beyond
    it (velocity reflected as in ``make_mirror_ghosts``), and that image would put on interior
    node k exactly what the point puts on ghost node −k. Adding it makes the nodes next to a wall
    see a complete B-spline/GIMP support, so wide stencils keep their order of accuracy at walls.
    (Exact for slip walls; for fixed walls the odd extension is exact in 1D and a close
    approximation in 2D.) Each interior node gathers its images in a fixed order (no atomics),
    so the fold is deterministic. In a domain narrower than the stencil, ghosts farther out than
    the opposite wall have no interior mirror and are not folded.
    """
    t = scalar_types(precision)
    T = t.scalar
    Particles, Grid, Domain = make_state_structs(precision)

    @wp.func
    def sign(kind: int, normal_axis: int, axis: int) -> float:
        # image of a velocity component: odd in the wall normal; tangential odd only if fixed
        if axis == normal_axis or kind == BC_FIXED:
            return -1.0
        return 1.0

    @wp.func
    def fold_vec(a: wp.array2d(dtype=t.vec2), i: int, j: int, gi: int, gj: int, kx: int, ky: int):
        v = a[i, j]
        if gi >= 0:
            u = a[gi, j]
            v = v + t.vec2(T(sign(kx, 0, 0)) * u[0], T(sign(kx, 0, 1)) * u[1])
        if gj >= 0:
            u = a[i, gj]
            v = v + t.vec2(T(sign(ky, 1, 0)) * u[0], T(sign(ky, 1, 1)) * u[1])
        if gi >= 0 and gj >= 0:
            u = a[gi, gj]
            v = v + t.vec2(T(sign(kx, 0, 0) * sign(ky, 1, 0)) * u[0], T(sign(kx, 0, 1) * sign(ky, 1, 1)) * u[1])
        a[i, j] = v

    @kernel
    def fold_ghosts(G: Grid, D: Domain, clock: wp.array(dtype=wp.float64)):
        i, j = wp.tid()
        if clock[1] <= wp.float64(0.0):
            return
        lo = D.node_lo
        hi = D.node_hi
        if i < lo[0] or i > hi[0] or j < lo[1] or j > hi[1]:
            return
        gi, wx = _image(i, lo[0], hi[0], D.bc_kind[0], D.bc_kind[1], G.mass.shape[0])
        gj, wy = _image(j, lo[1], hi[1], D.bc_kind[2], D.bc_kind[3], G.mass.shape[1])
        if gi < 0 and gj < 0:
            return
        kx = D.bc_kind[wx]
        ky = D.bc_kind[2 + wy]
        if wp.static(mass):
            m = G.mass[i, j]
            if gi >= 0:
                m += G.mass[gi, j]
            if gj >= 0:
                m += G.mass[i, gj]
            if gi >= 0 and gj >= 0:
                m += G.mass[gi, gj]
            G.mass[i, j] = m
        if wp.static(momentum):
            if wp.static(remap):
                fold_vec(G.vm, i, j, gi, gj, kx, ky)
            else:
                fold_vec(G.mom, i, j, gi, gj, kx, ky)
        if wp.static(force):
            fold_vec(G.force, i, j, gi, gj, kx, ky)

    return fold_ghosts
