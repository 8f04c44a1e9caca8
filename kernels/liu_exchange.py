"""The "liu" comparison scheme of the MPM–DEM coupling (MPM-SDEM §5.4, after Liu et al.): nodal loads
by momentum exchange at the grid nodes a body and the material share, instead of point contacts.
"""

import functools

import warp as wp

from .clock import CLOCK_DT
from .contact_geometry import make_contact_geometry
from .dem_bodies import make_dem_structs
from .state import make_state_structs
from .types import Namespace, kernel, scalar_types

__all__ = ["make_liu_kernels"]


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
    Bodies = make_dem_structs(precision).Bodies
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
