"""What P2G and G2P both compute per point and node, so the two directions sum the same terms: whether
a point's stencil lies on the grid, the momentum a point gives a node (with the affine term of
APIC / TPIC, "Motion integration" eq. 19, 23) and the grid row of a node's copy in granular mode.
"""

import functools

import warp as wp

from .granular import NO_LAYER
from .shape_functions import CORNERS, make_stencil
from .state import make_state_structs
from .types import scalar_types

__all__ = ["CORNERS", "copy_row", "make_momentum_term", "make_point_on_grid", "make_stencil"]


@functools.cache
def make_point_on_grid(shape: str, precision: str):
    """``point_on_grid(P, D, G, p)``: whether every sub-stencil of point p lies on the grid."""
    NC = CORNERS.get(shape, 1)
    Particles, Grid, Domain = make_state_structs(precision)
    stencil, contribution, on_grid = make_stencil(shape, precision)

    @wp.func
    def point_on_grid(P: Particles, D: Domain, G: Grid, p: int):
        ok = True
        for k in range(wp.static(NC)):
            bx, by, wx, wy, dwx, dwy, g = stencil(P, D, p, k)
            if not on_grid(bx, by, G):
                ok = False
        return ok

    return point_on_grid


@functools.cache
def make_momentum_term(precision: str, affine: bool):
    """``momentum_term(w, mv, mC, gi, gj, c, h)``: what a point of momentum m_p V_p (``mv``) and
    affine momentum m_p C_p (``mC``) gives node (gi, gj) of weight w: w m_p (V_p + C_p (x_i − x_p))
    with ``affine`` (APIC / TPIC, "Motion integration" eq. 19, 23), else w m_p V_p [kg m/s per m];
    c: the point's position in cells, h [m]. One function for P2G's momentum and MUSL's
    re-mapping in G2P, so that the two sum the same terms."""
    t = scalar_types(precision)
    T = t.scalar

    @wp.func
    def momentum_term(w: T, mv: t.vec2, mC: t.mat22, gi: int, gj: int, c: t.vec2, h: T):
        mom = w * mv
        if wp.static(affine):
            dpos = (t.vec2(T(gi), T(gj)) - c) * h
            mom = mom + w * (mC * dpos)
        return mom

    return momentum_term


@wp.func
def copy_row(packed: wp.vec4i, n: int, i: int, layer_rows: int):
    """Row of the grid copy of stencil node n (node row i) whose layer the step's claiming P2G kept in
    ``Particles.slots`` (granular mode), −1 if it found none (a layer overflow)."""
    s = (packed[n // 4] >> (8 * (n % 4))) & 255
    if s == NO_LAYER:
        return -1
    return s * layer_rows + i

