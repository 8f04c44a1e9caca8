"""Shape functions of the background grid, one 1D law per family, combined by tensor product.

Positions are in grid units relative to the first (ghost) node, so node k sits at coordinate k and
the signed node-to-point distance is ``c - k``. Every family is written as a law of that distance
and of the particle half-length ``lp`` (grid units, used by GIMP only); ``make_weights_1d`` turns a
law into the K weights and derivatives of the K nodes a point can touch, and ``make_stencil`` into
the per-point stencil (with CPDI1's four corners) that the transfers and the granular node ranges use.
"""


import functools

import warp as wp

from .state import make_state_structs
from .types import scalar_types

__all__ = ["CORNERS", "SUPPORT_NODES", "make_shape_law", "make_stencil", "make_weights_1d", "support_radius"]

#: Nodes per direction a point can touch (cpGIMP allows particle half-lengths up to one cell).
SUPPORT_NODES = {"linear": 2, "ugimp": 3, "cpgimp": 4, "bspline2": 3, "bspline3": 4, "cpdi1": 2}

#: Largest particle half-length, in cells, that cpGIMP accepts before clamping (keeps 4 nodes).
CPGIMP_MAX_HALF = 0.999


def support_radius(kind: str) -> float:
    """Half-width of the support of a shape function in cells, for points of zero size."""
    return {"linear": 1.0, "ugimp": 1.0, "cpgimp": 1.0, "bspline2": 1.5, "bspline3": 2.0, "cpdi1": 1.0}[kind]


@functools.cache
def make_shape_law(kind: str, precision: str):
    """1D law ``law(d, lp) -> (N, dN/dd)`` for signed distance d (cells) and half-length lp."""
    T = scalar_types(precision).scalar

    if kind in ("linear", "cpdi1"):  # CPDI1 evaluates the tent function at its domain corners

        @wp.func
        def law(d: T, lp: T):
            # Tent function of original MPM ("MPM notes", interpolation function - MPM). The
            # intervals are half-open so that a point on a node line takes the slopes of the cell
            # above it (nodes base and base+1 see d in [0, 1) and [-1, 0)): Σ dN = 0 everywhere.
            if d >= T(0.0) and d < T(1.0):
                return T(1.0) - d, T(-1.0)
            if d < T(0.0) and d >= T(-1.0):
                return T(1.0) + d, T(1.0)
            return T(0.0), T(0.0)

    elif kind in ("ugimp", "cpgimp"):

        @wp.func
        def tent_integral(s: T):
            # H(s) = ∫_{-inf}^{s} tent(t) dt
            if s <= T(-1.0):
                return T(0.0)
            if s <= T(0.0):
                return T(0.5) * (T(1.0) + s) * (T(1.0) + s)
            if s <= T(1.0):
                return T(1.0) - T(0.5) * (T(1.0) - s) * (T(1.0) - s)
            return T(1.0)

        @wp.func
        def tent(s: T):
            return wp.max(T(1.0) - wp.abs(s), T(0.0))

        @wp.func
        def law(d: T, lp: T):
            # GIMP weight = tent averaged over the particle domain [d-lp, d+lp] ("MPM notes",
            # interpolation function - GIMP; MPM-SDEM eq. 15-16 with a box characteristic).
            # Exact for any lp, so one law serves uGIMP (fixed lp) and cpGIMP (lp from F).
            inv = T(0.5) / lp
            w = (tent_integral(d + lp) - tent_integral(d - lp)) * inv
            dw = (tent(d + lp) - tent(d - lp)) * inv
            return w, dw

    elif kind == "bspline2":

        @wp.func
        def law(d: T, lp: T):
            # Quadratic B-spline (MPM-SDEM appendix).
            r = wp.abs(d)
            if r < T(0.5):
                return T(0.75) - r * r, T(-2.0) * d
            if r < T(1.5):
                q = T(1.5) - r
                return T(0.5) * q * q, -q * wp.sign(d)
            return T(0.0), T(0.0)

    elif kind == "bspline3":

        @wp.func
        def law(d: T, lp: T):
            # Cubic B-spline (MPM-SDEM appendix).
            r = wp.abs(d)
            if r < T(1.0):
                return T(0.5) * r * r * r - r * r + T(2.0) / T(3.0), (T(1.5) * r * r - T(2.0) * r) * wp.sign(d)
            if r < T(2.0):
                q = T(2.0) - r
                return q * q * q / T(6.0), T(-0.5) * q * q * wp.sign(d)
            return T(0.0), T(0.0)

    else:
        raise ValueError(f"unknown shape function {kind!r}")
    return law


@functools.cache
def make_weights_1d(kind: str, precision: str):
    """``weights(c, lp) -> (base, w, dw)``: first node index and the K weights/derivatives.

    c is the point coordinate in grid units, lp its half-length in cells; dw is dN/dc (divide by
    h for a physical gradient).
    """
    T = scalar_types(precision).scalar
    K = SUPPORT_NODES[kind]
    vecK = wp.types.vector(K, T)
    law = make_shape_law(kind, precision)
    gimp = kind in ("ugimp", "cpgimp")
    radius = T(support_radius(kind))

    @wp.func
    def weights(c: T, lp: T):
        r = radius
        if wp.static(gimp):
            r = T(1.0) + lp
        base = int(wp.floor(c - r)) + 1
        w = vecK()
        dw = vecK()
        for k in range(wp.static(K)):
            wk, dwk = law(c - T(base + k), lp)
            w[k] = wk
            dw[k] = dwk
        return base, w, dw

    return weights


#: Sub-stencils per point: one for the tensor-product shape functions, one per domain corner
#: for CPDI1 (each corner carries the tent function of its own cell).
CORNERS = {"cpdi1": 4}


@functools.cache
def make_stencil(shape: str, precision: str):
    """The per-point stencil of a shape function, as three ``wp.func``s.

    ``stencil(P, D, p, k) -> (bx, by, wx, wy, dwx, dwy, g)``: first node and 1D weights of
    sub-stencil k (k < CORNERS); ``contribution(wx, wy, dwx, dwy, g, i, j, inv_h) -> (w, ∇w)``:
    weight and physical gradient [1/m] that node (bx+i, by+j) gets from it; ``on_grid(bx, by, G)``.
    Every transfer kernel sums contributions over k, i, j, so each shape function is written once.
    """
    t = scalar_types(precision)
    T = t.scalar
    K = SUPPORT_NODES[shape]
    Particles, Grid, Domain = make_state_structs(precision)
    weights = make_weights_1d(shape, precision)
    gimp = shape in ("ugimp", "cpgimp")
    contiguous = shape == "cpgimp"
    cpdi = shape == "cpdi1"

    @wp.func
    def stencil(P: Particles, D: Domain, p: int, k: int):
        c = (P.x[p] - D.origin) * D.inv_h
        lp = t.vec2(T(0.0), T(0.0))
        g = t.vec2()
        if wp.static(gimp):
            lp = P.half0[p] * D.inv_h
        if wp.static(contiguous):
            # cpGIMP: the particle domain stretches with F along its material axes.
            F = P.F[p]
            sx = wp.sqrt(F[0, 0] * F[0, 0] + F[1, 0] * F[1, 0])
            sy = wp.sqrt(F[0, 1] * F[0, 1] + F[1, 1] * F[1, 1])
            lp = t.vec2(wp.min(lp[0] * sx, T(CPGIMP_MAX_HALF)), wp.min(lp[1] * sy, T(CPGIMP_MAX_HALF)))
        if wp.static(cpdi):
            # CPDI1 (Sadeghirad et al. 2011): the point's domain is the parallelogram spanned by
            # r1 = F (l_x, 0), r2 = F (0, l_y) around x_p; N_ip is the mean of the tent function at
            # its corners x1..x4 = x_p ∓ r1 ∓ r2 (counter-clockwise from −r1−r2), and
            # ∇N_ip = [(N(x1) − N(x3)) a + (N(x2) − N(x4)) b] / V with a = (r1y − r2y, r2x − r1x),
            # b = (r1y + r2y, −r1x − r2x), V = 4 |r1 × r2|.
            F = P.F[p]
            h0 = P.half0[p]
            r1 = h0[0] * t.vec2(F[0, 0], F[1, 0])
            r2 = h0[1] * t.vec2(F[0, 1], F[1, 1])
            s1 = T(-1.0)
            s2 = T(-1.0)
            sg = T(1.0)
            if k == 1:
                s1 = T(1.0)
            if k == 2:
                s1 = T(1.0)
                s2 = T(1.0)
                sg = T(-1.0)
            if k == 3:
                s2 = T(1.0)
                sg = T(-1.0)
            c = c + (s1 * r1 + s2 * r2) * D.inv_h
            vol = T(4.0) * wp.abs(r1[0] * r2[1] - r1[1] * r2[0])
            a = t.vec2(r1[1] - r2[1], r2[0] - r1[0])
            if k == 1 or k == 3:
                a = t.vec2(r1[1] + r2[1], -r1[0] - r2[0])
            g = (sg / vol) * a
        bx, wx, dwx = weights(c[0], lp[0])
        by, wy, dwy = weights(c[1], lp[1])
        return bx, by, wx, wy, dwx, dwy, g

    vecK = wp.types.vector(K, T)

    @wp.func
    def contribution(wx: vecK, wy: vecK, dwx: vecK, dwy: vecK, g: t.vec2, i: int, j: int, inv_h: T):
        if wp.static(cpdi):
            n = wx[i] * wy[j]
            return T(0.25) * n, n * g
        return wx[i] * wy[j], t.vec2(dwx[i] * wy[j], wx[i] * dwy[j]) * inv_h

    @wp.func
    def on_grid(bx: int, by: int, G: Grid):
        return bx >= 0 and by >= 0 and bx + K <= G.mass.shape[0] and by + K <= G.mass.shape[1]

    return stencil, contribution, on_grid
