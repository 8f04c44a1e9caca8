"""Shape functions of the background grid, one 1D law per family, combined by tensor product.

Positions are in grid units relative to the first (ghost) node, so node k sits at coordinate k and
the signed node-to-point distance is ``c - k``. Every family is written as a law of that distance
and of the particle half-length ``lp`` (grid units, used by GIMP only); ``make_weights_1d`` turns a
law into the K weights and derivatives of the K nodes a point can touch.
"""


import functools

import warp as wp

from .types import scalar_types

__all__ = ["SUPPORT_NODES", "make_shape_law", "make_weights_1d", "support_radius"]

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
